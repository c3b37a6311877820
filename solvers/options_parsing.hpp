#pragma once
// Reading `--option key=value` values: numbers must be finite, integers whole,
// booleans true/false; unknown keys are rejected. Errors are InputError with
// the item "--option KEY".
#include <map>
#include <set>
#include <string>

namespace tensegrity {

class BackendOptionReader {
 public:
  explicit BackendOptionReader(const std::map<std::string, std::string>& options)
      : options_(options) {}
  double number(const std::string& key, double fallback, double min_exclusive = -1e308);
  int integer(const std::string& key, int fallback, int min_inclusive = 0);
  bool boolean(const std::string& key, bool fallback);
  std::string text(const std::string& key, const std::string& fallback);
  bool has(const std::string& key) const { return options_.count(key) > 0; }
  // Throws for any key that none of the calls above asked for.
  void reject_unknown(const std::string& backend) const;

 private:
  const std::map<std::string, std::string>& options_;
  std::set<std::string> seen_;
};

}  // namespace tensegrity
