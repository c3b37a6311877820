#pragma once
// Input errors: every message names the file, the item and the reason,
// formatted "FILE: ITEM: REASON". The CLI catches them once (exit status 2).
#include <stdexcept>
#include <string>

namespace tensegrity {

class InputError : public std::runtime_error {
 public:
  InputError(std::string file, std::string item, std::string reason)
      : std::runtime_error(file + ": " + (item.empty() ? "" : item + ": ") + reason),
        file_(std::move(file)), item_(std::move(item)), reason_(std::move(reason)) {}
  const std::string& file() const { return file_; }
  const std::string& item() const { return item_; }
  const std::string& reason() const { return reason_; }

 private:
  std::string file_, item_, reason_;
};

}  // namespace tensegrity
