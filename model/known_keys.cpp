#include "model/known_keys.hpp"

#include <algorithm>
#include <limits>
#include <mutex>
#include <utility>

#include "model/errors.hpp"

namespace tensegrity {

namespace {

// Keys of 3 characters or fewer allow one edit, since two would turn "x" into
// any other short key.
constexpr std::size_t kShortKeyLength = 3;
constexpr std::size_t kShortKeyDistance = 1;
constexpr std::size_t kKeyDistance = 2;
// A warning line names at most this many keys.
constexpr std::size_t kMaxKeysNamed = 10;

std::mutex& sink_mutex() {
  static std::mutex m;
  return m;
}

InputWarningSink& current_sink() {
  static InputWarningSink sink;
  return sink;
}

std::string quoted_key(std::string_view key) {
  // Keys are shown as in the file; dump() escapes control bytes, ensure_ascii the rest.
  const std::string text = nlohmann::json(std::string(key)).dump(-1, ' ', true);
  return "'" + text.substr(1, text.size() - 2) + "'";
}

}  // namespace

std::size_t edit_distance(std::string_view a, std::string_view b) {
  const std::size_t n = a.size(), m = b.size();
  // Three rows of the dynamic programme: i-2, i-1 and i.
  std::vector<std::size_t> before(m + 1), previous(m + 1), row(m + 1);
  for (std::size_t j = 0; j <= m; ++j) previous[j] = j;
  for (std::size_t i = 1; i <= n; ++i) {
    row[0] = i;
    for (std::size_t j = 1; j <= m; ++j) {
      const std::size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
      row[j] = std::min({previous[j] + 1, row[j - 1] + 1, previous[j - 1] + cost});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1])
        row[j] = std::min(row[j], before[j - 2] + 1);
    }
    std::swap(before, previous);
    std::swap(previous, row);
  }
  return previous[m];
}

std::size_t typo_distance_limit(std::string_view key, std::string_view known) {
  return std::min(key.size(), known.size()) <= kShortKeyLength ? kShortKeyDistance : kKeyDistance;
}

std::string misspelled_key(std::string_view key, const std::vector<std::string_view>& known) {
  if (std::find(known.begin(), known.end(), key) != known.end()) return "";
  std::string best;
  std::size_t best_distance = std::numeric_limits<std::size_t>::max();
  for (const std::string_view k : known) {
    const std::size_t d = edit_distance(key, k);
    if (d <= typo_distance_limit(key, k) && d < best_distance) {
      best = std::string(k);
      best_distance = d;
    }
  }
  return best;
}

void KeyChecker::check(const nlohmann::json& object, std::initializer_list<std::string_view> known,
                       const std::string& item) {
  check(object, std::vector<std::string_view>(known), item);
}

void KeyChecker::check(const nlohmann::json& object, const std::vector<std::string_view>& known,
                       const std::string& item) {
  if (!object.is_object()) return;
  for (auto it = object.begin(); it != object.end(); ++it) {
    const std::string& key = it.key();
    if (std::find(known.begin(), known.end(), key) != known.end()) continue;
    const std::string intended = misspelled_key(key, known);
    if (!intended.empty())
      throw InputError(source_, item, "unknown key " + quoted_key(key) + " (did you mean " + quoted_key(intended) + "?)");
    std::string path = item.empty() ? key : item + "." + key;
    if (seen_.insert(path).second) unknown_.push_back(std::move(path));
  }
}

std::string unknown_keys_message(const std::vector<std::string>& unknown_keys) {
  if (unknown_keys.empty()) return "";
  std::string message = "unknown keys kept: ";
  for (std::size_t k = 0; k < unknown_keys.size() && k < kMaxKeysNamed; ++k) {
    const std::string text = nlohmann::json(unknown_keys[k]).dump(-1, ' ', true);
    message += (k == 0 ? "" : ", ") + text.substr(1, text.size() - 2);
  }
  if (unknown_keys.size() > kMaxKeysNamed)
    message += " and " + std::to_string(unknown_keys.size() - kMaxKeysNamed) + " more";
  return message;
}

void KeyChecker::report() const {
  if (!unknown_.empty()) warn_about_input(source_, unknown_keys_message(unknown_));
}

ScopedInputWarningSink::ScopedInputWarningSink(InputWarningSink sink) {
  const std::lock_guard<std::mutex> lock(sink_mutex());
  previous_ = std::exchange(current_sink(), std::move(sink));
}

ScopedInputWarningSink::~ScopedInputWarningSink() {
  const std::lock_guard<std::mutex> lock(sink_mutex());
  current_sink() = std::move(previous_);
}

void warn_about_input(const std::string& file, const std::string& message) {
  const std::lock_guard<std::mutex> lock(sink_mutex());
  if (current_sink()) current_sink()(file, message);
}

}  // namespace tensegrity
