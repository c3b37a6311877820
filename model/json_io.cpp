#include "model/json_io.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <set>
#include <string>
#include <vector>

#include "model/errors.hpp"
#include "model/text_file.hpp"

namespace tensegrity {

using nlohmann::json;

namespace {

// Records where (byte offset) and why the parser stopped; everything else is
// ignored. Used only after a failed parse, to place the error.
class ErrorLocator : public nlohmann::json_sax<json> {
 public:
  bool null() override { return true; }
  bool boolean(bool) override { return true; }
  bool number_integer(number_integer_t) override { return true; }
  bool number_unsigned(number_unsigned_t) override { return true; }
  bool number_float(number_float_t, const string_t&) override { return true; }
  bool string(string_t&) override { return true; }
  bool binary(binary_t&) override { return true; }
  bool start_object(std::size_t) override { return true; }
  bool key(string_t&) override { return true; }
  bool end_object() override { return true; }
  bool start_array(std::size_t) override { return true; }
  bool end_array() override { return true; }
  bool parse_error(std::size_t position, const std::string& last_token,
                   const nlohmann::detail::exception& ex) override {
    failed = true;
    byte = position;
    // An overflowing number is reported once read whole: point at its start.
    if (ex.id == 406 && !last_token.empty() && byte >= last_token.size()) byte -= last_token.size() - 1;
    reason = ex.what();
    return false;
  }

  bool failed = false;
  std::size_t byte = 0;
  std::string reason;
};

// nlohmann's messages start "[json.exception.parse_error.101] parse error at
// line 1, column 2: "; keep only the explanation (we give the place ourselves).
std::string strip_nlohmann_prefix(std::string message) {
  const auto bracket = message.find("] ");
  if (message.rfind("[json.exception.", 0) == 0 && bracket != std::string::npos)
    message.erase(0, bracket + 2);
  if (message.rfind("parse error", 0) == 0) {
    const auto colon = message.find(": ");
    if (colon != std::string::npos) message.erase(0, colon + 2);
  }
  return message;
}

// Messages are one line of printable ASCII whatever bytes the input held.
std::string printable(const std::string& text) {
  std::string out;
  for (const unsigned char c : text) {
    if (c >= 0x20 && c < 0x7f) {
      out += static_cast<char>(c);
    } else {
      char escaped[8];
      std::snprintf(escaped, sizeof escaped, "\\x%02x", c);
      out += escaped;
    }
  }
  return out;
}

// A stack of open containers, so that a duplicate key can be named by its path.
struct PathFrame {
  bool is_object = false;
  std::size_t index = 0;   // arrays: the child being read
  std::string key;         // objects: the child being read
  std::set<std::string> keys;
};

struct DuplicateKey {
  std::string item;
};

// No file of this program nests more than a few levels.
constexpr std::size_t kMaxJsonDepth = 128;

struct TooDeep {
  std::string item;
};

std::string path_of(const std::vector<PathFrame>& frames, std::size_t depth) {
  std::string path;
  for (std::size_t d = 0; d < depth; ++d) {
    const PathFrame& f = frames[d];
    if (f.is_object)
      path += (path.empty() ? "" : ".") + f.key;
    else
      path += "[" + std::to_string(f.index) + "]";
  }
  return path;
}

void child_done(std::vector<PathFrame>& frames) {
  if (!frames.empty() && !frames.back().is_object) ++frames.back().index;
}

const json* find_key(const json& object, const char* key) {
  const auto it = object.find(key);
  return it == object.end() ? nullptr : &*it;
}

std::string index_item(const std::string& prefix, std::size_t i) {
  return prefix + "[" + std::to_string(i) + "]";
}

}  // namespace

std::string json_describe(const json& v) {
  if (v.is_null()) return "null";
  // dump() escapes control characters; ensure_ascii keeps the message ASCII.
  std::string text = v.dump(-1, ' ', true);
  if (text.size() > 40) text = text.substr(0, 37) + "...";
  return std::string(v.type_name()) + " " + text;
}

const json& json_require_key(const json& object, const char* key, const std::string& source,
                             const std::string& item_prefix) {
  const json* v = find_key(object, key);
  if (v == nullptr)
    throw InputError(source, item_prefix.empty() ? std::string(key) : item_prefix,
                     std::string("missing required field \"") + key + "\"");
  return *v;
}

std::pair<std::size_t, std::size_t> line_and_column(const std::string& text, std::size_t byte) {
  // `byte` is nlohmann's count of characters read: the offending character is
  // text[byte - 1] (or the end of the input).
  const std::size_t offending = std::min(byte > 0 ? byte - 1 : 0, text.size());
  std::size_t line = 1, line_start = 0;
  for (std::size_t i = 0; i < offending; ++i)
    if (text[i] == '\n') {
      ++line;
      line_start = i + 1;
    }
  return {line, offending - line_start + 1};
}

json parse_json_text(const std::string& text, const std::string& source) {
  std::vector<PathFrame> frames;
  // Duplicate keys are ambiguous (which value wins?), so they are input errors.
  auto track = [&frames](int, json::parse_event_t event, json& parsed) {
    switch (event) {
      case json::parse_event_t::object_start:
      case json::parse_event_t::array_start:
        // Copying, printing and destroying a JSON value recurse once per
        // level: deeper input would overflow the stack.
        if (frames.size() >= kMaxJsonDepth) throw TooDeep{path_of(frames, 4) + "..."};
        frames.push_back(PathFrame{event == json::parse_event_t::object_start, 0, {}, {}});
        break;
      case json::parse_event_t::key: {
        PathFrame& top = frames.back();
        top.key = parsed.get<std::string>();
        if (!top.keys.insert(top.key).second)
          throw DuplicateKey{path_of(frames, frames.size())};
        break;
      }
      case json::parse_event_t::object_end:
      case json::parse_event_t::array_end:
        frames.pop_back();
        child_done(frames);
        break;
      case json::parse_event_t::value: child_done(frames); break;
    }
    return true;
  };
  try {
    return json::parse(text, track);
  } catch (const DuplicateKey& d) {
    throw InputError(source, d.item, "duplicate key in a JSON object");
  } catch (const TooDeep& d) {
    throw InputError(source, d.item.empty() ? std::string("top level") : d.item,
                     "JSON nested deeper than " + std::to_string(kMaxJsonDepth) + " levels");
  } catch (const json::exception&) {
    ErrorLocator locator;
    json::sax_parse(text, &locator);
    const auto [line, column] = line_and_column(text, locator.byte);
    throw InputError(source, "line " + std::to_string(line) + ", column " + std::to_string(column),
                     "malformed JSON: " + printable(strip_nlohmann_prefix(locator.reason)));
  }
}

json read_json_file(const std::string& path) { return parse_json_text(read_text_file(path), path); }

double json_finite_number(const json& v, const std::string& source, const std::string& item) {
  if (!v.is_number())
    throw InputError(source, item, "expected a number, got " + json_describe(v));
  const double value = v.get<double>();
  if (!std::isfinite(value)) throw InputError(source, item, "number is not finite");
  return value;
}

double json_mass(const json& v, const std::string& source, const std::string& item) {
  const double mass = json_finite_number(v, source, item);
  if (mass < 0.0) throw InputError(source, item, "negative mass " + v.dump() + " (kg must be >= 0)");
  return mass;
}

Eigen::Vector3d json_vector3(const json& v, const std::string& source, const std::string& item) {
  if (!v.is_array()) throw InputError(source, item, "expected an array of 3 numbers, got " + json_describe(v));
  if (v.size() != 3)
    throw InputError(source, item, "expected exactly 3 numbers, got " + std::to_string(v.size()));
  Eigen::Vector3d x;
  for (int k = 0; k < 3; ++k) x[k] = json_finite_number(v[k], source, index_item(item, k));
  return x;
}

int json_index(const json& v, int count, const std::string& what, const std::string& source,
               const std::string& item) {
  if (!v.is_number()) throw InputError(source, item, "expected a " + what + " index, got " + json_describe(v));
  if (!v.is_number_integer())
    throw InputError(source, item, what + " index must be an integer, got " + v.dump());
  if (v.is_number_unsigned()) {
    const auto u = v.get<std::uint64_t>();
    if (u >= static_cast<std::uint64_t>(count))
      throw InputError(source, item, what + " index " + v.dump() + " is out of range (" +
                                         std::to_string(count) + " " + what + "s)");
    return static_cast<int>(u);
  }
  const auto i = v.get<std::int64_t>();
  if (i < 0) throw InputError(source, item, "negative " + what + " index " + v.dump());
  if (i >= count)
    throw InputError(source, item, what + " index " + v.dump() + " is out of range (" +
                                       std::to_string(count) + " " + what + "s)");
  return static_cast<int>(i);
}

void json_expect_header(const json& j, const std::string& format, const std::string& source) {
  if (!j.is_object()) throw InputError(source, "", "expected a JSON object, got " + json_describe(j));
  const json& f = json_require_key(j, "format", source, "");
  if (!f.is_string()) throw InputError(source, "format", "expected a string, got " + json_describe(f));
  if (f.get<std::string>() != format)
    throw InputError(source, "format", "expected \"" + format + "\", got " + f.dump());
  const json& v = json_require_key(j, "version", source, "");
  if (!v.is_number_integer())
    throw InputError(source, "version", "expected the integer 1, got " + json_describe(v));
  if (v != 1)
    throw InputError(source, "version", "unsupported version " + v.dump() + " (this program reads version 1)");
}

std::string json_string(const json& v, const std::string& source, const std::string& item) {
  if (!v.is_string()) throw InputError(source, item, "expected a string, got " + json_describe(v));
  return v.get<std::string>();
}

}  // namespace tensegrity
