#include "solvers/options_parsing.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>

#include "model/errors.hpp"

namespace tensegrity {
namespace {

InputError bad(const std::string& key, const std::string& value, const std::string& why) {
  return InputError("command line", "--option " + key + "=" + value, why);
}

}  // namespace

double BackendOptionReader::number(const std::string& key, double fallback, double min_exclusive) {
  seen_.insert(key);
  auto it = options_.find(key);
  if (it == options_.end()) return fallback;
  const std::string& v = it->second;
  char* end = nullptr;
  errno = 0;
  const double x = std::strtod(v.c_str(), &end);
  if (v.empty() || end != v.c_str() + v.size()) throw bad(key, v, "not a number");
  if (errno == ERANGE || !std::isfinite(x)) throw bad(key, v, "not a finite number");
  if (!(x > min_exclusive)) throw bad(key, v, "must be greater than " + std::to_string(min_exclusive));
  return x;
}

int BackendOptionReader::integer(const std::string& key, int fallback, int min_inclusive) {
  seen_.insert(key);
  auto it = options_.find(key);
  if (it == options_.end()) return fallback;
  const std::string& v = it->second;
  char* end = nullptr;
  errno = 0;
  const long x = std::strtol(v.c_str(), &end, 10);
  if (v.empty() || end != v.c_str() + v.size()) throw bad(key, v, "not an integer");
  if (errno == ERANGE || x > 1000000000L || x < -1000000000L) throw bad(key, v, "out of range");
  if (x < min_inclusive) throw bad(key, v, "must be at least " + std::to_string(min_inclusive));
  return static_cast<int>(x);
}

bool BackendOptionReader::boolean(const std::string& key, bool fallback) {
  seen_.insert(key);
  auto it = options_.find(key);
  if (it == options_.end()) return fallback;
  if (it->second == "true" || it->second == "1" || it->second == "yes") return true;
  if (it->second == "false" || it->second == "0" || it->second == "no") return false;
  throw bad(key, it->second, "expected true or false");
}

std::string BackendOptionReader::text(const std::string& key, const std::string& fallback) {
  seen_.insert(key);
  auto it = options_.find(key);
  return it == options_.end() ? fallback : it->second;
}

void BackendOptionReader::reject_unknown(const std::string& backend) const {
  for (const auto& [key, value] : options_) {
    if (!seen_.count(key)) throw bad(key, value, "unknown option for solver " + backend);
  }
}

}  // namespace tensegrity
