// Scene files: a round trip keeps every number bit for bit and every unknown
// field; every class of bad input raises an InputError naming the file, the
// item and the reason (tests/bad_inputs/, one file per class).
#include <gtest/gtest.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string>

#include "model/errors.hpp"
#include "model/json_io.hpp"
#include "model/scene_io.hpp"

namespace tensegrity {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

const fs::path kBadInputs = fs::path(TENSEGRITY_SOURCE_DIR) / "tests" / "bad_inputs";

class TempDir {
 public:
  TempDir() {
    path_ = fs::temp_directory_path() /
            ("tensegrity-scene-io-" + std::to_string(::getpid()) + "-" + std::to_string(counter_++));
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  fs::path operator/(const std::string& name) const { return path_ / name; }
  const fs::path& path() const { return path_; }

 private:
  static inline int counter_ = 0;
  fs::path path_;
};

std::string read_file(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

bool same_bits(double a, double b) { return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b); }

struct Expected {
  std::string item;    // exact
  std::string reason;  // a substring of the reason
};

// What each file of tests/bad_inputs must report.
const std::map<std::string, Expected>& expected_errors() {
  static const std::map<std::string, Expected> table = {
      {"empty_file", {"line 1, column 1", "malformed JSON: syntax error"}},
      {"truncated", {"line 12, column 7", "malformed JSON"}},
      {"missing_comma", {"line 8, column 5", "malformed JSON: syntax error while parsing array"}},
      {"invalid_utf8", {"line 4, column 16", "ill-formed UTF-8 byte"}},
      {"nan_literal", {"line 8, column 36", "malformed JSON: syntax error"}},
      {"infinity_literal", {"line 9, column 17", "malformed JSON: syntax error"}},
      {"overflow_number", {"line 8, column 12", "number overflow parsing '1e999'"}},
      {"overflow_negative", {"line 5, column 25", "number overflow parsing '-1e400'"}},
      {"duplicate_key", {"nodes[1].x", "duplicate key"}},
      {"not_an_object", {"", "expected a JSON object, got array"}},
      {"wrong_format", {"format", "expected \"tensegrity-scene\", got \"tensegrity-solution\""}},
      {"missing_format", {"format", "missing required field \"format\""}},
      {"unsupported_version", {"version", "unsupported version 2"}},
      {"version_not_integer", {"version", "expected the integer 1, got string \"1\""}},
      {"name_not_string", {"name", "expected a string, got number 42"}},
      {"gravity_two_numbers", {"gravity", "expected exactly 3 numbers, got 2"}},
      {"gravity_not_array", {"gravity", "expected an array of 3 numbers, got number"}},
      {"missing_nodes", {"nodes", "missing required field \"nodes\""}},
      {"nodes_not_array", {"nodes", "expected an array of nodes, got object"}},
      {"node_not_object", {"nodes[1]", "expected a node object, got array"}},
      {"missing_position", {"nodes[1].x", "missing required field \"x\""}},
      {"position_two_numbers", {"nodes[1].x", "expected exactly 3 numbers, got 2"}},
      {"position_four_numbers", {"nodes[1].x", "expected exactly 3 numbers, got 4"}},
      {"position_not_number", {"nodes[2].x[1]", "expected a number, got string \"1.0\""}},
      {"position_null", {"nodes[2].x[1]", "expected a number, got null"}},
      {"fixed_not_boolean", {"nodes[0].fixed", "expected true or false, got string \"yes\""}},
      {"fixed_as_number", {"nodes[0].fixed", "expected true or false, got number 1"}},
      {"negative_node_mass", {"nodes[1].mass", "negative mass -0.1"}},
      {"negative_element_mass", {"elements[1].mass", "negative mass -2.0"}},
      {"mass_not_number", {"nodes[1].mass", "expected a number, got string \"heavy\""}},
      {"missing_elements", {"elements", "missing required field \"elements\""}},
      {"elements_not_array", {"elements", "expected an array of elements, got string"}},
      {"no_elements", {"elements", "no elements"}},
      {"element_not_object", {"elements[2]", "expected an element object, got array"}},
      {"missing_kind", {"elements[1].kind", "missing required field \"kind\""}},
      {"unknown_kind", {"elements[1].kind", "unknown kind \"rod\""}},
      {"kind_not_string", {"elements[1].kind", "expected a string, got number 1"}},
      {"missing_element_nodes", {"elements[2].nodes", "missing required field \"nodes\""}},
      {"element_one_node", {"elements[2].nodes", "expected exactly 2 node indices, got 1"}},
      {"element_three_nodes", {"elements[2].nodes", "expected exactly 2 node indices, got 3"}},
      {"index_out_of_range", {"elements[2].nodes[1]", "node index 3 is out of range (3 nodes)"}},
      {"index_negative", {"elements[2].nodes[0]", "negative node index -1"}},
      {"index_not_integer", {"elements[2].nodes[1]", "must be an integer, got 1.5"}},
      {"index_integral_float", {"elements[2].nodes[1]", "must be an integer, got 2.0"}},
      {"index_as_string", {"elements[2].nodes[0]", "expected a node index, got string \"0\""}},
      {"index_beyond_int", {"elements[2].nodes[1]", "node index 4294967296 is out of range"}},
      {"self_loop", {"elements[2].nodes", "element joins node 2 to itself"}},
      {"zero_length", {"elements[3]", "zero-length element: nodes 2 and 3"}},
      {"duplicate", {"elements[3].nodes", "nodes 1 and 2 are already joined by elements[1]"}},
      {"duplicate_reversed", {"elements[3].nodes", "nodes 2 and 1 are already joined by elements[1]"}},
      {"no_free_node", {"nodes", "no free node"}},
      {"typo_fixd", {"nodes[2]", "unknown key 'fixd' (did you mean 'fixed'?)"}},
      {"typo_gravty", {"", "unknown key 'gravty' (did you mean 'gravity'?)"}},
      {"typo_mas", {"nodes[1]", "unknown key 'mas' (did you mean 'mass'?)"}},
      {"typo_knd", {"elements[1]", "unknown key 'knd' (did you mean 'kind'?)"}},
  };
  return table;
}

std::set<std::string> bad_input_classes() {
  std::set<std::string> names;
  const std::string suffix = ".scene.json";
  for (const auto& entry : fs::directory_iterator(kBadInputs)) {
    const std::string file = entry.path().filename().string();
    if (file.size() > suffix.size() && file.ends_with(suffix))
      names.insert(file.substr(0, file.size() - suffix.size()));
  }
  return names;
}

TEST(SceneBadInput, EveryFileHasAnExpectationAndAReadmeLine) {
  const auto classes = bad_input_classes();
  EXPECT_EQ(classes.size(), expected_errors().size());
  const std::string readme = read_file(kBadInputs / "README.md");
  for (const std::string& name : classes) {
    EXPECT_TRUE(expected_errors().count(name)) << name << " has no expected error";
    EXPECT_NE(readme.find("`" + name + ".scene.json`"), std::string::npos) << name << " is not in README.md";
  }
  for (const auto& [name, expected] : expected_errors()) EXPECT_TRUE(classes.count(name)) << name << " is missing";
}

TEST(SceneBadInput, EachClassNamesFileItemAndReason) {
  for (const auto& [name, expected] : expected_errors()) {
    SCOPED_TRACE(name);
    const std::string path = (kBadInputs / (name + ".scene.json")).string();
    try {
      read_scene_file(path);
      ADD_FAILURE() << "no error for " << name;
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), path);
      EXPECT_EQ(e.item(), expected.item);
      EXPECT_NE(e.reason().find(expected.reason), std::string::npos) << "reason: " << e.reason();
      const std::string message = e.what();
      EXPECT_EQ(message.rfind(path + ": ", 0), 0u) << message;
      EXPECT_EQ(message.find('\n'), std::string::npos) << "one line only: " << message;
      for (const unsigned char c : message) EXPECT_TRUE(c >= 0x20 && c < 0x7f) << "byte " << int(c);
    }
  }
}

TEST(SceneBadInput, MissingFileAndDirectory) {
  try {
    read_scene_file("/nonexistent/dir/none.scene.json");
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), "/nonexistent/dir/none.scene.json");
    EXPECT_NE(e.reason().find("No such file or directory"), std::string::npos) << e.reason();
  }
  try {
    read_scene_file(kBadInputs.string());
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_NE(e.reason().find("directory"), std::string::npos) << e.reason();
  }
}

// Our line/column (from nlohmann's byte count) against nlohmann's own
// "line L, column C" for a few placements of the error.
TEST(SceneBadInput, LineAndColumnMatchTheParser) {
  const std::vector<std::string> texts = {
      "{\n  \"a\": [1, 2,,]\n}",        "{\n\n\n      \"b\": trux\n}", "[1,\n2,\n3",
      "{\"a\": 1}\n\n   x",            "\n\n\n\n\n}",                    "{\r\n  \"a\": 1,\r\n  \"b\" 2\r\n}",
  };
  const std::regex place("line ([0-9]+), column ([0-9]+)");
  for (const std::string& text : texts) {
    SCOPED_TRACE(text);
    std::size_t byte = 0;
    std::string theirs;
    try {
      const json parsed = json::parse(text);
      FAIL() << "parsed " << parsed.dump();
    } catch (const json::parse_error& e) {
      byte = e.byte;
      theirs = e.what();
    }
    std::smatch m;
    ASSERT_TRUE(std::regex_search(theirs, m, place)) << theirs;
    const auto [line, column] = line_and_column(text, byte);
    EXPECT_EQ(line, std::stoul(m[1]));
    EXPECT_EQ(column, std::stoul(m[2]));
    try {
      parse_json_text(text, "t.json");
      FAIL();
    } catch (const InputError& e) {
      EXPECT_EQ(e.item(), "line " + std::string(m[1]) + ", column " + std::string(m[2]));
    }
  }
  // Hand-counted: the stray 'x' is the fourth character of the third line.
  EXPECT_EQ(line_and_column("{\"a\": 1}\n\n   x", 14), (std::pair<std::size_t, std::size_t>(3, 4)));
  // When the offending character is a newline, nlohmann says "line 5, column
  // 0"; we place it where it is: the 15th character of line 4, after "tru".
  try {
    parse_json_text("{\n\n\n      \"b\": tru\n}", "t.json");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.item(), "line 4, column 15");
  }
}

TEST(SceneBadInput, DuplicateKeyPathsInsideArrays) {
  try {
    parse_json_text(R"({"nodes": [{"x": 1}, {"x": 2}, {"x": 3, "y": [0, {"k": 1, "k": 2}]}]})", "t.json");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.item(), "nodes[2].y[1].k");
  }
  // The same key in different objects is fine.
  EXPECT_NO_THROW(parse_json_text(R"({"a": {"k": 1}, "b": {"k": 2}, "c": [{"k": 1}, {"k": 2}]})", "t.json"));
}

json valid_scene_json() {
  return json::parse(R"({
    "format": "tensegrity-scene", "version": 1, "name": "t",
    "nodes": [{"x": [0.0, 0.0, 0.0], "fixed": true}, {"x": [1.0, 0.0, 0.5]}, {"x": [0.0, 1.0, 0.5]}],
    "elements": [{"kind": "strut", "nodes": [0, 1]}, {"kind": "cable", "nodes": [1, 2]},
                 {"kind": "cable", "nodes": [0, 2]}]})");
}

TEST(SceneFromJson, NonFiniteValuesBuiltInMemory) {
  // JSON text cannot hold NaN, but a json built in memory can.
  json j = valid_scene_json();
  j["nodes"][1]["x"][2] = std::numeric_limits<double>::quiet_NaN();
  try {
    scene_from_json(j, "mem");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.item(), "nodes[1].x[2]");
    EXPECT_NE(e.reason().find("not finite"), std::string::npos);
  }
  j = valid_scene_json();
  j["elements"][0]["mass"] = std::numeric_limits<double>::infinity();
  EXPECT_THROW(scene_from_json(j, "mem"), InputError);
  j = valid_scene_json();
  j["gravity"] = json::array({0.0, 0.0, -std::numeric_limits<double>::infinity()});
  try {
    scene_from_json(j, "mem");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.item(), "gravity[2]");
  }
}

TEST(SceneFromJson, DefaultsAndMasses) {
  json j = valid_scene_json();
  j["nodes"][2]["mass"] = 0.25;
  j["elements"][1]["mass"] = 0.5;  // joins 1 and 2
  j["gravity"] = json::array({0.0, 0.0, -10.0});
  const Structure s = scene_from_json(j, "mem");
  EXPECT_EQ(s.num_nodes(), 3);
  EXPECT_EQ(s.num_free_nodes(), 2);
  EXPECT_TRUE(s.fixed[0]);
  EXPECT_FALSE(s.fixed[1]);
  const Eigen::VectorXd m = s.lumped_mass();
  EXPECT_EQ(m[0], 0.0);
  EXPECT_EQ(m[1], 0.25);
  EXPECT_EQ(m[2], 0.5);
  const Eigen::Matrix3Xd loads = s.gravity_loads();
  EXPECT_EQ(loads(2, 2), -5.0);
  EXPECT_EQ(loads(2, 1), -2.5);
  EXPECT_EQ(loads(0, 1), 0.0);
  // Lengths sqrt(1.25), sqrt(2), sqrt(1.25).
  EXPECT_NEAR(s.mean_element_length(), (2.0 * std::sqrt(1.25) + std::sqrt(2.0)) / 3.0, 1e-15);

  j.erase("gravity");
  const Structure no_gravity = scene_from_json(j, "mem");
  EXPECT_FALSE(no_gravity.has_gravity());
  EXPECT_EQ(no_gravity.gravity_loads().cwiseAbs().maxCoeff(), 0.0);
}

TEST(Validate, NearlyCoincidentNodesAreZeroLength) {
  Structure s;
  s.add_node({1.0, 0.0, 0.0}, true);
  s.add_node({1.0 + 4.0 * std::numeric_limits<double>::epsilon(), 0.0, 0.0});
  s.add_node({0.0, 2.0, 0.0});
  s.add_element(0, 2, ElementKind::Cable);
  s.add_element(1, 2, ElementKind::Cable);
  EXPECT_NO_THROW(validate(s, "mem"));
  s.add_element(1, 0, ElementKind::Strut);
  try {
    validate(s, "mem");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.item(), "elements[2]");
  }
}

TEST(SceneRoundTrip, NumbersBitForBitAndUnknownFieldsKept) {
  const double awkward[] = {0.1, 1.0 / 3.0, -0.0, 5e-324, 1.7976931348623157e308, -2.2250738585072014e-308,
                            123456789.123456789, 1e-300, M_PI, -std::nextafter(1.0, 2.0)};
  Structure s;
  s.name = "round \"trip\" ü";
  s.gravity = Eigen::Vector3d(0.1, -1.0 / 3.0, -9.80665);
  for (int i = 0; i < 10; ++i) {
    const Eigen::Vector3d x(awkward[i] * 1e-10 + i, awkward[(i + 3) % 10] * 1e-10 - i, awkward[(i + 7) % 10]);
    s.add_node(x, i % 4 == 0, i % 3 == 0 ? 0.0 : awkward[i % 2] * (i + 1));
  }
  for (int i = 0; i < 10; ++i)
    s.add_element(i, (i + 1) % 10, i % 2 ? ElementKind::Cable : ElementKind::Strut, i == 3 ? 1.0 / 7.0 : 0.0);
  s.add_element(0, 5, ElementKind::Strut);
  s.extra["block_ids"] = json::array({"a", "b"});
  s.node_extra[3]["label"] = "knee";
  s.element_extra[7]["material"] = json{{"name", "dyneema"}, {"diameter", 0.002}};
  validate(s, "mem");

  TempDir dir;
  const std::string path = (dir / "scene.scene.json").string();
  write_scene_file(s, path);
  const Structure r = read_scene_file(path);

  EXPECT_EQ(r.name, s.name);
  ASSERT_EQ(r.num_nodes(), s.num_nodes());
  ASSERT_EQ(r.num_elements(), s.num_elements());
  for (int k = 0; k < 3; ++k) EXPECT_TRUE(same_bits(r.gravity[k], s.gravity[k]));
  for (int i = 0; i < s.num_nodes(); ++i) {
    for (int k = 0; k < 3; ++k)
      EXPECT_TRUE(same_bits(r.positions(k, i), s.positions(k, i))) << i << "," << k << " " << s.positions(k, i);
    EXPECT_TRUE(same_bits(r.node_mass[i], s.node_mass[i]));
    EXPECT_EQ(r.fixed[i], s.fixed[i]);
    EXPECT_EQ(r.node_extra[i], s.node_extra[i]);
  }
  for (int e = 0; e < s.num_elements(); ++e) {
    EXPECT_EQ(r.elements[e].a, s.elements[e].a);
    EXPECT_EQ(r.elements[e].b, s.elements[e].b);
    EXPECT_EQ(r.elements[e].kind, s.elements[e].kind);
    EXPECT_TRUE(same_bits(r.elements[e].mass, s.elements[e].mass));
    EXPECT_EQ(r.element_extra[e], s.element_extra[e]);
  }
  EXPECT_EQ(r.extra, s.extra);
  // The negative zero survives as such.
  EXPECT_TRUE(std::signbit(r.positions(2, 9)) == std::signbit(s.positions(2, 9)));

  // Writing the read scene again gives the same text.
  const std::string again = (dir / "again.scene.json").string();
  write_scene_file(r, again);
  EXPECT_EQ(read_file(path), read_file(again));
  // The header keys of docs/FORMATS.md come first.
  EXPECT_EQ(read_file(path).find("\"format\""), 4u);
}

TEST(WriteTextFileAtomically, ReplacesAndLeavesNoTemporaryFiles) {
  TempDir dir;
  const fs::path target = dir / "out.json";
  write_text_file_atomically(target.string(), "first\n");
  write_text_file_atomically(target.string(), "second\n");
  EXPECT_EQ(read_file(target), "second\n");
  int files = 0;
  for ([[maybe_unused]] const auto& entry : fs::directory_iterator(dir.path())) ++files;
  EXPECT_EQ(files, 1);
  // A plain file's permissions, not mkstemp's 0600.
  EXPECT_NE(fs::status(target).permissions() & fs::perms::owner_read, fs::perms::none);
  const mode_t mask = ::umask(0);
  ::umask(mask);
  EXPECT_EQ(static_cast<unsigned>(fs::status(target).permissions()), 0666u & ~static_cast<unsigned>(mask));

  const fs::path nowhere = dir / "missing-dir" / "out.json";
  try {
    write_text_file_atomically(nowhere.string(), "x");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), nowhere.string());
  }
  EXPECT_FALSE(fs::exists(nowhere));
  EXPECT_THROW(write_text_file_atomically(dir.path().string(), "x"), InputError);
}

// A pipe given as the output receives the text and stays a pipe (a rename
// would have replaced it with a regular file).
TEST(WriteTextFileAtomically, WritesIntoAPipeInPlace) {
  TempDir dir;
  const fs::path fifo = dir / "pipe";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  // The reading end is open before the write (non-blocking, so nothing waits
  // either way); the text fits in the pipe's buffer.
  const int reader = ::open(fifo.c_str(), O_RDONLY | O_NONBLOCK);
  ASSERT_GE(reader, 0);
  write_text_file_atomically(fifo.string(), "through the pipe\n");
  char buffer[64] = {};
  const ssize_t got = ::read(reader, buffer, sizeof buffer - 1);
  ::close(reader);
  EXPECT_EQ(std::string(buffer, got > 0 ? static_cast<std::size_t>(got) : 0), "through the pipe\n");
  EXPECT_TRUE(fs::is_fifo(fifo));
}

}  // namespace
}  // namespace tensegrity
