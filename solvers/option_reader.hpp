#pragma once
// Reading a backend's `key=value` options into its typed options struct.
// Numbers must be finite and inside the option's valid range, integers whole
// and inside theirs, booleans true/false, choices one of their names. Every
// error is an OptionError that names the option and the valid values; an
// unknown key lists the backend's valid keys.
#include <limits>
#include <set>
#include <string>
#include <vector>

#include "solvers/solver.hpp"

namespace tensegrity {

// An interval of valid values, each end open or closed.
struct ValueRange {
  double low = -std::numeric_limits<double>::infinity();
  double high = std::numeric_limits<double>::infinity();
  bool low_open = true;
  bool high_open = true;

  static ValueRange positive() { return {0.0, std::numeric_limits<double>::infinity(), true, true}; }
  static ValueRange non_negative() { return {0.0, std::numeric_limits<double>::infinity(), false, true}; }
  static ValueRange at_least(double low) { return {low, std::numeric_limits<double>::infinity(), false, true}; }
  static ValueRange open(double low, double high) { return {low, high, true, true}; }
  static ValueRange left_open(double low, double high) { return {low, high, true, false}; }
  static ValueRange closed(double low, double high) { return {low, high, false, false}; }

  bool contains(double v) const;
  std::string text() const;  // e.g. "(0, 1]", "[0, inf)"
};

class OptionReader {
 public:
  OptionReader(const OptionPairs& pairs, std::string backend) : pairs_(pairs), backend_(std::move(backend)) {}
  double number(const std::string& key, double fallback, const ValueRange& valid);
  int integer(const std::string& key, int fallback, int min, int max);
  bool boolean(const std::string& key, bool fallback);
  std::string choice(const std::string& key, const std::string& fallback, const std::vector<std::string>& allowed);
  // Any key that none of the calls above asked for is an OptionError listing the valid keys.
  void reject_unknown() const;
  // An OptionError for `key` (its value as given) with `reason`.
  [[noreturn]] void fail(const std::string& key, const std::string& reason) const;

 private:
  const std::string* find(const std::string& key);
  const OptionPairs& pairs_;
  std::string backend_;
  std::set<std::string> known_;
};

// Throws an OptionError for the first key of `pairs` (the backends that take
// no options).
void reject_all_options(const OptionPairs& pairs, const std::string& backend);

}  // namespace tensegrity
