// Solution files: every double survives a write/read bit for bit, the keys of
// docs/FORMATS.md are always there, and a file that does not fit its scene is an
// InputError naming the item.
#include <gtest/gtest.h>
#include <unistd.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <string>

#include "model/errors.hpp"
#include "model/reference_scenes.hpp"
#include "model/solution.hpp"
#include "model/status.hpp"

namespace tensegrity {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

bool same_bits(double a, double b) { return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b); }

class TempDir {
 public:
  TempDir() : path_(fs::temp_directory_path() / ("tensegrity-solution-io-" + std::to_string(::getpid()))) {
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  std::string operator/(const std::string& name) const { return (path_ / name).string(); }

 private:
  fs::path path_;
};

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

void write_text(const std::string& path, const std::string& text) { std::ofstream(path, std::ios::binary) << text; }

// Finite doubles drawn from every exponent, including subnormals.
double random_finite_double(std::mt19937_64& rng) {
  for (;;) {
    const double d = std::bit_cast<double>(rng());
    if (std::isfinite(d)) return d;
  }
}

TEST(SolutionNumbers, NlohmannShortestOutputRoundTrips) {
  std::mt19937_64 rng(12345);
  int checked = 0;
  for (int k = 0; k < 200000; ++k) {
    const double d = random_finite_double(rng);
    const double back = json::parse(json(d).dump()).get<double>();
    ASSERT_TRUE(same_bits(d, back)) << json(d).dump();
    ++checked;
  }
  for (const double d : {0.1, 1.0 / 3.0, -0.0, 5e-324, std::numeric_limits<double>::max(),
                         std::numeric_limits<double>::min(), std::nextafter(1.0, 0.0), 9007199254740993.0}) {
    EXPECT_TRUE(same_bits(d, json::parse(json(d).dump()).get<double>())) << json(d).dump();
  }
  // Integral doubles stay doubles in the text ("2.0", not "2").
  EXPECT_EQ(json(2.0).dump(), "2.0");
  EXPECT_EQ(checked, 200000);
}

Structure test_scene() {
  PrismParameters p;
  p.n = 4;
  p.fix_bottom = true;
  return make_regular_prism(p);
}

Solution test_solution(const Structure& scene) {
  std::mt19937_64 rng(7);
  Solution s;
  s.scene = scene.name;
  s.solver = "alternating";
  s.status = Status::MaxIterations;
  s.positions = scene.positions;
  for (int i = scene.num_nodes() / 2; i < scene.num_nodes(); ++i)
    for (int k = 0; k < 3; ++k) s.positions(k, i) = random_finite_double(rng);
  s.forces.resize(scene.num_elements());
  for (int e = 0; e < scene.num_elements(); ++e) s.forces[e] = random_finite_double(rng);
  s.forces[0] = -0.0;
  s.forces[1] = 5e-324;
  s.stats = {17, 0.000123456789, 1.0 / 3.0, 2.5e-13, 0.1};
  s.rest_lengths = Eigen::VectorXd::LinSpaced(scene.num_elements(), 0.1, 1.7);
  s.extra["pipeline"] = json::array({"forces", "form"});  // an unknown key, kept
  return s;
}

TEST(SolutionFile, WriteThenReadIsBitIdentical) {
  const Structure scene = test_scene();
  const Solution s = test_solution(scene);
  TempDir dir;
  const std::string path = dir / "a.solution.json";
  write_solution_file(s, path);
  const Solution r = read_solution_file(path, scene);

  EXPECT_EQ(r.scene, s.scene);
  EXPECT_EQ(r.solver, s.solver);
  EXPECT_EQ(r.status, s.status);
  ASSERT_EQ(r.positions.cols(), s.positions.cols());
  for (int i = 0; i < s.positions.cols(); ++i)
    for (int k = 0; k < 3; ++k) EXPECT_TRUE(same_bits(r.positions(k, i), s.positions(k, i))) << i << " " << k;
  ASSERT_EQ(r.forces.size(), s.forces.size());
  for (int e = 0; e < s.forces.size(); ++e) EXPECT_TRUE(same_bits(r.forces[e], s.forces[e])) << e;
  EXPECT_EQ(r.stats.iterations, 17);
  EXPECT_TRUE(same_bits(r.stats.seconds, s.stats.seconds));
  EXPECT_TRUE(same_bits(r.stats.residual, s.stats.residual));
  EXPECT_TRUE(same_bits(r.stats.relative_residual, s.stats.relative_residual));
  EXPECT_TRUE(same_bits(r.stats.geometry_change, s.stats.geometry_change));
  ASSERT_TRUE(r.rest_lengths.has_value());
  for (int e = 0; e < s.forces.size(); ++e) EXPECT_TRUE(same_bits((*r.rest_lengths)[e], (*s.rest_lengths)[e]));
  EXPECT_EQ(r.extra, s.extra);

  // The same text through write_solution.
  std::ostringstream out;
  write_solution(s, out);
  EXPECT_EQ(out.str(), read_text(path));
}

TEST(SolutionFile, DocumentedKeysArePresent) {
  const Structure scene = test_scene();
  Solution s = test_solution(scene);
  s.rest_lengths.reset();
  const json j = json::parse([&] {
    std::ostringstream out;
    write_solution(s, out);
    return out.str();
  }());
  EXPECT_EQ(j.at("format"), "tensegrity-solution");
  EXPECT_EQ(j.at("version"), 1);
  EXPECT_EQ(j.at("scene"), scene.name);
  EXPECT_EQ(j.at("solver"), "alternating");
  EXPECT_EQ(j.at("status"), "max_iterations");
  ASSERT_EQ(j.at("positions").size(), static_cast<std::size_t>(scene.num_nodes()));
  for (const json& x : j.at("positions")) EXPECT_EQ(x.size(), 3u);
  EXPECT_EQ(j.at("forces").size(), static_cast<std::size_t>(scene.num_elements()));
  for (const char* key : {"iterations", "seconds", "residual", "relative_residual", "geometry_change"})
    EXPECT_TRUE(j.at("stats").contains(key)) << key;
  EXPECT_TRUE(j.at("stats").at("iterations").is_number_integer());
  EXPECT_FALSE(j.contains("rest_lengths"));
}

TEST(SolutionStatus, DocumentedStringsRoundTrip) {
  const std::pair<Status, const char*> names[] = {{Status::Converged, "converged"},
                                                   {Status::MaxIterations, "max_iterations"},
                                                   {Status::Infeasible, "infeasible"},
                                                   {Status::NumericalError, "numerical_error"},
                                                   {Status::TimeLimit, "time_limit"}};
  for (const auto& [status, name] : names) {
    EXPECT_EQ(to_string(status), name);
    EXPECT_EQ(status_from_string(name), status);
  }
  EXPECT_FALSE(status_from_string("Converged").has_value());
  EXPECT_FALSE(status_from_string("").has_value());
}

void expect_input_error(const std::string& path, const Structure& scene, const std::string& item,
                        const std::string& reason) {
  try {
    read_solution_file(path, scene);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), path);
    EXPECT_EQ(e.item(), item);
    EXPECT_NE(e.reason().find(reason), std::string::npos) << e.reason();
  }
}

TEST(SolutionFile, BadFilesNameTheItem) {
  const Structure scene = test_scene();
  const Solution s = test_solution(scene);
  const json good = solution_to_json(s);
  TempDir dir;
  const std::string path = dir / "bad.solution.json";
  auto check = [&](const auto& edit, const std::string& item, const std::string& reason) {
    json j = good;
    edit(j);
    write_text(path, j.dump());
    SCOPED_TRACE(item + ": " + reason);
    expect_input_error(path, scene, item, reason);
  };
  check([](json& j) { j["format"] = "tensegrity-scene"; }, "format", "expected \"tensegrity-solution\"");
  check([](json& j) { j["version"] = 3; }, "version", "unsupported version 3");
  check([](json& j) { j["status"] = "done"; }, "status", "unknown status \"done\"");
  check([](json& j) { j.erase("forces"); }, "forces", "missing required field");
  check([](json& j) { j["positions"].erase(0); }, "positions", "one position per scene node (8), got 7");
  check([](json& j) { j["positions"][5] = json::array({1.0, 2.0}); }, "positions[5]", "exactly 3 numbers");
  check([](json& j) { j["forces"].push_back(1.0); }, "forces", "one number per scene element (16), got 17");
  check([](json& j) { j["forces"][3] = nullptr; }, "forces[3]", "expected a number, got null");
  check([](json& j) { j["stats"].erase("residual"); }, "stats.residual", "missing required field");
  check([](json& j) { j["stats"]["iterations"] = 1.5; }, "stats.iterations", "non-negative integer");
  check([](json& j) { j["stats"]["iterations"] = -1; }, "stats.iterations", "non-negative integer");
  check([](json& j) { j["rest_lengths"] = json::array({1.0}); }, "rest_lengths", "one number per scene element");

  // A non-finite number cannot be written as a JSON number: it becomes null,
  // and reading rejects it.
  Solution broken = s;
  broken.forces[2] = std::numeric_limits<double>::quiet_NaN();
  write_solution_file(broken, path);
  EXPECT_EQ(read_text(path).find("nan"), std::string::npos);
  expect_input_error(path, scene, "forces[2]", "got null");

  write_text(path, "{\"format\": \"tensegrity-solution\",\n \"version\": 1,\n \"forces\": [1e999]}");
  expect_input_error(path, scene, "line 3, column 13", "number overflow");
  expect_input_error(dir / "absent.solution.json", scene, "", "No such file");
}

}  // namespace
}  // namespace tensegrity
