#include "solvers/option_reader.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <sstream>

#include "model/errors.hpp"

namespace tensegrity {
namespace {

// Integers beyond this are not budgets or counts of anything a solve can do.
constexpr long kLargestInteger = 1000000000L;

std::string number_text(double v) {
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  std::ostringstream out;
  out << v;
  return out.str();
}

std::string joined(const std::set<std::string>& items) {
  std::string out;
  for (const auto& item : items) out += (out.empty() ? "" : ", ") + item;
  return out;
}

}  // namespace

bool ValueRange::contains(double v) const {
  const bool above = low_open ? v > low : v >= low;
  const bool below = high_open ? v < high : v <= high;
  return above && below;
}

std::string ValueRange::text() const {
  return std::string(low_open ? "(" : "[") + number_text(low) + ", " + number_text(high) + (high_open ? ")" : "]");
}

const std::string* OptionReader::find(const std::string& key) {
  known_.insert(key);
  auto it = pairs_.find(key);
  return it == pairs_.end() ? nullptr : &it->second;
}

void OptionReader::fail(const std::string& key, const std::string& reason) const {
  auto it = pairs_.find(key);
  throw OptionError(backend_, key, it == pairs_.end() ? std::string() : it->second, reason);
}

double OptionReader::number(const std::string& key, double fallback, const ValueRange& valid) {
  const std::string* v = find(key);
  if (v == nullptr) return fallback;
  char* end = nullptr;
  errno = 0;
  const double x = std::strtod(v->c_str(), &end);
  if (v->empty() || end != v->c_str() + v->size()) fail(key, "not a number (valid: " + valid.text() + ")");
  if (errno == ERANGE || !std::isfinite(x)) fail(key, "not a finite number (valid: " + valid.text() + ")");
  if (!valid.contains(x)) fail(key, "out of range (valid: " + valid.text() + ")");
  return x;
}

int OptionReader::integer(const std::string& key, int fallback, int min, int max) {
  const std::string* v = find(key);
  if (v == nullptr) return fallback;
  const std::string range = "[" + std::to_string(min) + ", " + std::to_string(max) + "]";
  char* end = nullptr;
  errno = 0;
  const long x = std::strtol(v->c_str(), &end, 10);
  if (v->empty() || end != v->c_str() + v->size()) fail(key, "not an integer (valid: " + range + ")");
  if (errno == ERANGE || x > kLargestInteger || x < -kLargestInteger || x < min || x > max)
    fail(key, "out of range (valid: " + range + ")");
  return static_cast<int>(x);
}

bool OptionReader::boolean(const std::string& key, bool fallback) {
  const std::string* v = find(key);
  if (v == nullptr) return fallback;
  if (*v == "true" || *v == "1" || *v == "yes") return true;
  if (*v == "false" || *v == "0" || *v == "no") return false;
  fail(key, "expected true or false");
}

std::string OptionReader::choice(const std::string& key, const std::string& fallback,
                                 const std::vector<std::string>& allowed) {
  const std::string* v = find(key);
  if (v == nullptr) return fallback;
  for (const auto& a : allowed)
    if (*v == a) return a;
  std::string names;
  for (const auto& a : allowed) names += (names.empty() ? "" : ", ") + a;
  fail(key, "unknown value (valid: " + names + ")");
}

void OptionReader::reject_unknown() const {
  for (const auto& [key, value] : pairs_)
    if (!known_.count(key))
      throw OptionError(backend_, key, value,
                        "unknown option" + (known_.empty() ? std::string(" (this backend takes none)")
                                                           : " (valid: " + joined(known_) + ")"));
}

void reject_all_options(const OptionPairs& pairs, const std::string& backend) {
  OptionReader(pairs, backend).reject_unknown();
}

}  // namespace tensegrity
