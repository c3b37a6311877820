#include "model/scene_io.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "model/errors.hpp"
#include "model/format_keys.hpp"
#include "model/json_io.hpp"
#include "model/json_text.hpp"

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

// Files larger than this are refused rather than read into memory whole.
constexpr std::size_t kMaxFileBytes = std::size_t{256} << 20;

std::string read_whole_file(const std::string& path) {
  auto fail = [&path](const std::string& what, int error) {
    return InputError(path, "", what + (error != 0 ? std::string(": ") + std::strerror(error) : std::string()));
  };
  // O_NONBLOCK: opening a FIFO without a writer must not wait forever (it then
  // reads as empty); it is cleared at once so that reading a pipe still works.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) throw fail("cannot open file", errno);
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat info {};
  if (::fstat(fd, &info) != 0) throw fail("cannot read file", errno);
  if (S_ISDIR(info.st_mode)) throw InputError(path, "", "cannot read file: it is a directory");
  if (S_ISREG(info.st_mode) && static_cast<std::uintmax_t>(info.st_size) > kMaxFileBytes)
    throw InputError(path, "", "file too large (" + std::to_string(info.st_size) + " bytes; the limit is " +
                                   std::to_string(kMaxFileBytes) + ")");
  const int flags = ::fcntl(fd, F_GETFL);
  if (flags < 0 || ::fcntl(fd, F_SETFL, flags & ~O_NONBLOCK) != 0) throw fail("cannot read file", errno);
  std::string text;
  char chunk[1 << 16];
  for (;;) {
    const ssize_t got = ::read(fd, chunk, sizeof chunk);
    if (got < 0) {
      if (errno == EINTR) continue;
      throw fail("cannot read file", errno);
    }
    if (got == 0) break;
    // Devices and pipes have no size: an endless one (/dev/zero) stops here.
    if (text.size() + static_cast<std::size_t>(got) > kMaxFileBytes)
      throw InputError(path, "", "file too large (more than " + std::to_string(kMaxFileBytes) + " bytes)");
    text.append(chunk, static_cast<std::size_t>(got));
  }
  return text;
}

std::string describe(const json& v) {
  if (v.is_null()) return "null";
  // dump() escapes control characters; ensure_ascii keeps the message ASCII.
  std::string text = v.dump(-1, ' ', true);
  if (text.size() > 40) text = text.substr(0, 37) + "...";
  return std::string(v.type_name()) + " " + text;
}

const json* find_key(const json& object, const char* key) {
  const auto it = object.find(key);
  return it == object.end() ? nullptr : &*it;
}

const json& require_key(const json& object, const char* key, const std::string& source,
                        const std::string& item_prefix) {
  const json* v = find_key(object, key);
  if (v == nullptr)
    throw InputError(source, item_prefix.empty() ? std::string(key) : item_prefix,
                     std::string("missing required field \"") + key + "\"");
  return *v;
}

std::string join(const std::string& prefix, const std::string& key) {
  return prefix.empty() ? key : prefix + "." + key;
}

std::string index_item(const std::string& prefix, std::size_t i) {
  return prefix + "[" + std::to_string(i) + "]";
}

}  // namespace

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

std::string read_text_file(const std::string& path) { return read_whole_file(path); }

json read_json_file(const std::string& path) { return parse_json_text(read_whole_file(path), path); }

double json_finite_number(const json& v, const std::string& source, const std::string& item) {
  if (!v.is_number())
    throw InputError(source, item, "expected a number, got " + describe(v));
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
  if (!v.is_array()) throw InputError(source, item, "expected an array of 3 numbers, got " + describe(v));
  if (v.size() != 3)
    throw InputError(source, item, "expected exactly 3 numbers, got " + std::to_string(v.size()));
  Eigen::Vector3d x;
  for (int k = 0; k < 3; ++k) x[k] = json_finite_number(v[k], source, index_item(item, k));
  return x;
}

int json_index(const json& v, int count, const std::string& what, const std::string& source,
               const std::string& item) {
  if (!v.is_number()) throw InputError(source, item, "expected a " + what + " index, got " + describe(v));
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
  if (!j.is_object()) throw InputError(source, "", "expected a JSON object, got " + describe(j));
  const json& f = require_key(j, "format", source, "");
  if (!f.is_string()) throw InputError(source, "format", "expected a string, got " + describe(f));
  if (f.get<std::string>() != format)
    throw InputError(source, "format", "expected \"" + format + "\", got " + f.dump());
  const json& v = require_key(j, "version", source, "");
  if (!v.is_number_integer())
    throw InputError(source, "version", "expected the integer 1, got " + describe(v));
  if (v != 1)
    throw InputError(source, "version", "unsupported version " + v.dump() + " (this program reads version 1)");
}

std::string json_string(const json& v, const std::string& source, const std::string& item) {
  if (!v.is_string()) throw InputError(source, item, "expected a string, got " + describe(v));
  return v.get<std::string>();
}

const std::vector<std::string_view>& scene_keys() {
  static const std::vector<std::string_view> keys = {"format", "version",  "name",     "description",
                                                     "gravity", "nodes",   "elements", "character"};
  return keys;
}

const std::vector<std::string_view>& scene_node_keys() {
  static const std::vector<std::string_view> keys = {"x", "fixed", "mass", "name", "block", "block_node", "link"};
  return keys;
}

const std::vector<std::string_view>& scene_element_keys() {
  static const std::vector<std::string_view> keys = {"kind",  "nodes",         "mass", "name",     "block",
                                                     "block_element", "link", "material", "target_strain"};
  return keys;
}

Structure scene_from_json(const json& j, const std::string& source) {
  KeyChecker keys(source);
  Structure s = scene_from_json(j, source, keys);
  keys.report();
  return s;
}

Structure scene_from_json(const json& j, const std::string& source, KeyChecker& keys) {
  json_expect_header(j, "tensegrity-scene", source);
  keys.check(j, scene_keys(), "");
  Structure s;
  for (auto it = j.begin(); it != j.end(); ++it) {
    const std::string& key = it.key();
    if (key == "format" || key == "version" || key == "nodes" || key == "elements") continue;
    if (key == "name")
      s.name = json_string(*it, source, "name");
    else if (key == "gravity")
      s.gravity = json_vector3(*it, source, "gravity");
    else
      s.extra[key] = *it;
  }

  const json& nodes = require_key(j, "nodes", source, "");
  if (!nodes.is_array()) throw InputError(source, "nodes", "expected an array of nodes, got " + describe(nodes));
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    const std::string item = index_item("nodes", i);
    const json& node = nodes[i];
    if (!node.is_object()) throw InputError(source, item, "expected a node object, got " + describe(node));
    keys.check(node, scene_node_keys(), item);
    const Eigen::Vector3d x = json_vector3(require_key(node, "x", source, join(item, "x")), source, join(item, "x"));
    bool is_fixed = false;
    double mass = 0.0;
    json extra = json::object();
    for (auto it = node.begin(); it != node.end(); ++it) {
      if (it.key() == "x") continue;
      if (it.key() == "fixed") {
        if (!it->is_boolean())
          throw InputError(source, join(item, "fixed"), "expected true or false, got " + describe(*it));
        is_fixed = it->get<bool>();
      } else if (it.key() == "mass") {
        mass = json_mass(*it, source, join(item, "mass"));
      } else {
        extra[it.key()] = *it;
      }
    }
    s.add_node(x, is_fixed, mass);
    s.node_extra.back() = std::move(extra);
  }

  const json& elements = require_key(j, "elements", source, "");
  if (!elements.is_array())
    throw InputError(source, "elements", "expected an array of elements, got " + describe(elements));
  const int n = s.num_nodes();
  for (std::size_t e = 0; e < elements.size(); ++e) {
    const std::string item = index_item("elements", e);
    const json& element = elements[e];
    if (!element.is_object())
      throw InputError(source, item, "expected an element object, got " + describe(element));
    keys.check(element, scene_element_keys(), item);
    const std::string kind_text = json_string(require_key(element, "kind", source, join(item, "kind")), source,
                                              join(item, "kind"));
    ElementKind kind;
    if (kind_text == "strut")
      kind = ElementKind::Strut;
    else if (kind_text == "cable")
      kind = ElementKind::Cable;
    else
      throw InputError(source, join(item, "kind"),
                       "unknown kind " + json(kind_text).dump(-1, ' ', true) + " (expected \"strut\" or \"cable\")");
    const std::string ends_item = join(item, "nodes");
    const json& ends = require_key(element, "nodes", source, ends_item);
    if (!ends.is_array())
      throw InputError(source, ends_item, "expected an array of 2 node indices, got " + describe(ends));
    if (ends.size() != 2)
      throw InputError(source, ends_item, "expected exactly 2 node indices, got " + std::to_string(ends.size()));
    const int a = json_index(ends[0], n, "node", source, index_item(ends_item, 0));
    const int b = json_index(ends[1], n, "node", source, index_item(ends_item, 1));
    double mass = 0.0;
    json extra = json::object();
    for (auto it = element.begin(); it != element.end(); ++it) {
      if (it.key() == "kind" || it.key() == "nodes") continue;
      if (it.key() == "mass")
        mass = json_mass(*it, source, join(item, "mass"));
      else
        extra[it.key()] = *it;
    }
    s.add_element(a, b, kind, mass);
    s.element_extra.back() = std::move(extra);
  }
  validate(s, source);
  return s;
}

Structure read_scene_file(const std::string& path) { return scene_from_json(read_json_file(path), path); }

namespace {

json vector_json(const Eigen::Vector3d& x) { return json::array({x[0], x[1], x[2]}); }

// Unknown keys never overwrite the ones the model writes itself.
void merge_extra(json& target, const json& extra) {
  if (!extra.is_object()) return;
  for (auto it = extra.begin(); it != extra.end(); ++it)
    if (!target.contains(it.key())) target[it.key()] = *it;
}

}  // namespace

json scene_to_json(const Structure& s) {
  json j = json::object();
  j["format"] = "tensegrity-scene";
  j["version"] = 1;
  if (!s.name.empty()) j["name"] = s.name;
  if (s.has_gravity()) j["gravity"] = vector_json(s.gravity);
  json nodes = json::array();
  for (int i = 0; i < s.num_nodes(); ++i) {
    json node = json::object();
    node["x"] = vector_json(s.positions.col(i));
    if (i < static_cast<int>(s.fixed.size()) && s.fixed[i]) node["fixed"] = true;
    if (i < s.node_mass.size() && s.node_mass[i] != 0.0) node["mass"] = s.node_mass[i];
    if (i < static_cast<int>(s.node_extra.size())) merge_extra(node, s.node_extra[i]);
    nodes.push_back(std::move(node));
  }
  json elements = json::array();
  for (int e = 0; e < s.num_elements(); ++e) {
    const Element& el = s.elements[e];
    json element = json::object();
    element["kind"] = to_string(el.kind);
    element["nodes"] = json::array({el.a, el.b});
    if (el.mass != 0.0) element["mass"] = el.mass;
    if (e < static_cast<int>(s.element_extra.size())) merge_extra(element, s.element_extra[e]);
    elements.push_back(std::move(element));
  }
  j["nodes"] = std::move(nodes);
  j["elements"] = std::move(elements);
  merge_extra(j, s.extra);
  return j;
}

void write_scene_file(const Structure& s, const std::string& path) {
  write_text_file_atomically(path, to_json_text(scene_to_json(s)));
}

void write_text_file_atomically(const std::string& path, const std::string& text) {
  if (path == "-") {
    std::cout << text;
    std::cout.flush();
    if (!std::cout) throw InputError("-", "", "cannot write to standard output");
    return;
  }
  const std::filesystem::path target(path);
  std::error_code ec;
  if (std::filesystem::is_directory(target, ec))
    throw InputError(path, "", "cannot write: it is a directory");
  // The temporary file lives in the target's directory so that rename() is
  // atomic and a failure leaves no partial output under the final name.
  const std::filesystem::path directory = target.has_parent_path() ? target.parent_path() : ".";
  std::string temp = (directory / ("." + target.filename().string() + ".tmp-XXXXXX")).string();
  const int fd = mkstemp(temp.data());
  if (fd < 0) throw InputError(path, "", std::string("cannot create output file: ") + std::strerror(errno));
  auto fail = [&](const char* what) {
    const std::string reason = std::string(what) + ": " + std::strerror(errno);
    ::close(fd);
    ::unlink(temp.c_str());
    throw InputError(path, "", reason);
  };
  // mkstemp creates mode 0600; give the file the mode a plain open() would.
  const mode_t mask = ::umask(0);
  ::umask(mask);
  if (::fchmod(fd, 0666 & ~mask) != 0) fail("cannot set output file mode");
  std::size_t written = 0;
  while (written < text.size()) {
    const ssize_t k = ::write(fd, text.data() + written, text.size() - written);
    if (k < 0) {
      if (errno == EINTR) continue;
      fail("cannot write output file");
    }
    written += static_cast<std::size_t>(k);
  }
  if (::close(fd) != 0) {
    const std::string reason = std::string("cannot write output file: ") + std::strerror(errno);
    ::unlink(temp.c_str());
    throw InputError(path, "", reason);
  }
  if (std::rename(temp.c_str(), path.c_str()) != 0) {
    const std::string reason = std::string("cannot create output file: ") + std::strerror(errno);
    ::unlink(temp.c_str());
    throw InputError(path, "", reason);
  }
}

}  // namespace tensegrity
