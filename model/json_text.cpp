#include "model/json_text.hpp"

#include <sstream>

#include <algorithm>
#include <array>
#include <string_view>
#include <vector>

namespace tensegrity {

namespace {

// Keys of the file formats in reading order; anything else follows alphabetically.
constexpr std::array<std::string_view, 23> kKeyOrder = {
    "format", "version",  "name",   "scene",      "solver",     "status",
    "gravity", "kind",    "x",      "nodes",      "fixed",      "mass",
    "elements", "positions", "forces", "rest_lengths", "stats", "iterations",
    "seconds", "residual", "relative_residual", "geometry_change", "message"};

int key_rank(const std::string& key) {
  const auto it = std::find(kKeyOrder.begin(), kKeyOrder.end(), key);
  return static_cast<int>(it - kKeyOrder.begin());
}

std::vector<std::string> ordered_keys(const nlohmann::json& object) {
  std::vector<std::string> keys;
  for (auto it = object.begin(); it != object.end(); ++it) keys.push_back(it.key());
  std::stable_sort(keys.begin(), keys.end(), [](const std::string& a, const std::string& b) {
    return key_rank(a) < key_rank(b);
  });
  return keys;
}

void write_inline(const nlohmann::json& j, std::string& out) {
  if (j.is_object()) {
    out += '{';
    bool first = true;
    for (const std::string& key : ordered_keys(j)) {
      if (!first) out += ", ";
      first = false;
      out += nlohmann::json(key).dump();
      out += ": ";
      write_inline(j.at(key), out);
    }
    out += '}';
  } else if (j.is_array()) {
    out += '[';
    for (std::size_t i = 0; i < j.size(); ++i) {
      if (i > 0) out += ", ";
      write_inline(j[i], out);
    }
    out += ']';
  } else {
    out += j.dump();  // non-finite doubles become null: valid JSON, never "nan"
  }
}

constexpr std::size_t kInlineWidth = 100;

void write_block(const nlohmann::json& j, int indent, std::string& out) {
  std::string flat;
  write_inline(j, flat);
  const bool nested = (j.is_object() || j.is_array()) &&
                      std::any_of(j.begin(), j.end(), [](const nlohmann::json& v) {
                        return v.is_object() || v.is_array();
                      });
  // Arrays of scalars (forces, rest lengths) stay on one line however long;
  // containers of containers get one child per line.
  if (!nested && !(j.is_object() && flat.size() > kInlineWidth)) {
    out += flat;
    return;
  }
  if (flat.size() <= kInlineWidth && indent > 0) {
    out += flat;
    return;
  }
  const std::string pad(indent + 2, ' ');
  if (j.is_object()) {
    out += "{\n";
    const auto keys = ordered_keys(j);
    for (std::size_t k = 0; k < keys.size(); ++k) {
      out += pad + nlohmann::json(keys[k]).dump() + ": ";
      write_block(j.at(keys[k]), indent + 2, out);
      out += k + 1 < keys.size() ? ",\n" : "\n";
    }
    out += std::string(indent, ' ') + "}";
  } else {
    out += "[\n";
    for (std::size_t i = 0; i < j.size(); ++i) {
      out += pad;
      write_block(j[i], indent + 2, out);
      out += i + 1 < j.size() ? ",\n" : "\n";
    }
    out += std::string(indent, ' ') + "]";
  }
}

}  // namespace

std::string to_json_text(const nlohmann::json& j) {
  std::string out;
  write_block(j, 0, out);
  out += '\n';
  return out;
}

std::string message_number(double v) {
  std::ostringstream s;
  s.precision(6);
  s << v;
  return s.str();
}

}  // namespace tensegrity
