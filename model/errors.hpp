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

// A backend option (`key=value`) that a backend does not know or whose value
// is malformed or out of range. The library names the backend and the option;
// the command line adds its own flag wording (`--option key=value`).
class OptionError : public InputError {
 public:
  OptionError(std::string backend, std::string key, std::string value, std::string reason)
      : InputError("options", backend + " option " + key + (value.empty() ? "" : "=" + value), reason),
        backend_(std::move(backend)), key_(std::move(key)), value_(std::move(value)) {}
  const std::string& backend() const { return backend_; }
  const std::string& key() const { return key_; }
  const std::string& value() const { return value_; }

 private:
  std::string backend_, key_, value_;
};

// A name that a registry does not know: a solver backend ("solver"), a
// stress-test family ("family"). The library names the kind and the name; the
// command line adds the flag that gave it.
class UnknownNameError : public InputError {
 public:
  UnknownNameError(std::string kind, std::string name, std::string reason)
      : InputError("options", kind + " '" + name + "'", std::move(reason)),
        kind_(std::move(kind)), name_(std::move(name)) {}
  const std::string& kind() const { return kind_; }
  const std::string& name() const { return name_; }

 private:
  std::string kind_, name_;
};

}  // namespace tensegrity
