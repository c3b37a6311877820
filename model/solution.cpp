#include "model/solution.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <ostream>
#include <string>

#include "model/errors.hpp"
#include "model/format_keys.hpp"
#include "model/json_io.hpp"
#include "model/json_text.hpp"
#include "model/known_keys.hpp"
#include "model/scene_io.hpp"

namespace tensegrity {

using nlohmann::json;

nlohmann::json solution_to_json(const Solution& s) {
  json j = json::object();
  j["format"] = "tensegrity-solution";
  j["version"] = 1;
  j["scene"] = s.scene;
  j["solver"] = s.solver;
  j["status"] = std::string(to_string(s.status));
  json positions = json::array();
  for (Eigen::Index i = 0; i < s.positions.cols(); ++i)
    positions.push_back(json::array({s.positions(0, i), s.positions(1, i), s.positions(2, i)}));
  j["positions"] = std::move(positions);
  json forces = json::array();
  for (Eigen::Index e = 0; e < s.forces.size(); ++e) forces.push_back(s.forces[e]);
  j["forces"] = std::move(forces);
  j["stats"] = json{{"iterations", s.stats.iterations},
                    {"seconds", s.stats.seconds},
                    {"residual", s.stats.residual},
                    {"relative_residual", s.stats.relative_residual},
                    {"geometry_change", s.stats.geometry_change}};
  if (s.rest_lengths) {
    json rest = json::array();
    for (Eigen::Index e = 0; e < s.rest_lengths->size(); ++e) rest.push_back((*s.rest_lengths)[e]);
    j["rest_lengths"] = std::move(rest);
  }
  if (s.extra.is_object())
    for (auto it = s.extra.begin(); it != s.extra.end(); ++it)
      if (!j.contains(it.key())) j[it.key()] = *it;
  return j;
}

void write_solution(const Solution& s, std::ostream& out) { out << to_json_text(solution_to_json(s)); }

void write_solution_file(const Solution& s, const std::string& path) {
  write_text_file_atomically(path, to_json_text(solution_to_json(s)));
}

namespace {

Eigen::VectorXd per_element_numbers(const json& j, const char* key, int m, const std::string& path) {
  const json& v = j.at(key);
  if (!v.is_array()) throw InputError(path, key, "expected an array of numbers, got " + std::string(v.type_name()));
  if (static_cast<int>(v.size()) != m)
    throw InputError(path, key, "expected one number per scene element (" + std::to_string(m) + "), got " +
                                    std::to_string(v.size()));
  Eigen::VectorXd values(m);
  for (int e = 0; e < m; ++e)
    values[e] = json_finite_number(v[e], path, std::string(key) + "[" + std::to_string(e) + "]");
  return values;
}

}  // namespace

const std::vector<std::string_view>& solution_keys() {
  static const std::vector<std::string_view> keys = {
      "format", "version", "scene", "solver", "status", "positions", "forces", "stats", "rest_lengths",
      // Written by solve (a backend's message, native code and details) and by relax.
      "message", "native_code", "details", "gravity", "max_displacement", "max_displacement_node", "relative_max_displacement",
      "size", "slack_cables", "cables_outside_measured_range"};
  return keys;
}

const std::vector<std::string_view>& solution_stats_keys() {
  static const std::vector<std::string_view> keys = {"iterations", "seconds", "residual", "relative_residual",
                                                     "geometry_change"};
  return keys;
}

Solution read_solution_file(const std::string& path, const Structure& scene) {
  const json j = read_json_file(path);
  json_expect_header(j, "tensegrity-solution", path);
  KeyChecker keys(path);
  keys.check(j, solution_keys(), "");
  for (const char* key : {"status", "positions", "forces", "stats"})
    if (!j.contains(key)) throw InputError(path, key, std::string("missing required field \"") + key + "\"");

  Solution s;
  if (j.contains("scene")) s.scene = json_string(j.at("scene"), path, "scene");
  if (j.contains("solver")) s.solver = json_string(j.at("solver"), path, "solver");
  const std::string status_text = json_string(j.at("status"), path, "status");
  const auto status = status_from_string(status_text);
  if (!status)
    throw InputError(path, "status", "unknown status \"" + status_text +
                                         "\" (expected converged, max_iterations, infeasible, "
                                         "numerical_error or time_limit)");
  s.status = *status;

  const int n = scene.num_nodes();
  const json& positions = j.at("positions");
  if (!positions.is_array())
    throw InputError(path, "positions", "expected an array of positions, got " + std::string(positions.type_name()));
  if (static_cast<int>(positions.size()) != n)
    throw InputError(path, "positions", "expected one position per scene node (" + std::to_string(n) + "), got " +
                                            std::to_string(positions.size()));
  s.positions.resize(3, n);
  for (int i = 0; i < n; ++i)
    s.positions.col(i) = json_vector3(positions[i], path, "positions[" + std::to_string(i) + "]");

  s.forces = per_element_numbers(j, "forces", scene.num_elements(), path);
  if (j.contains("rest_lengths")) s.rest_lengths = per_element_numbers(j, "rest_lengths", scene.num_elements(), path);

  const json& stats = j.at("stats");
  if (!stats.is_object()) throw InputError(path, "stats", "expected an object, got " + std::string(stats.type_name()));
  keys.check(stats, solution_stats_keys(), "stats");
  for (const char* key : {"iterations", "seconds", "residual", "relative_residual", "geometry_change"})
    if (!stats.contains(key))
      throw InputError(path, std::string("stats.") + key, std::string("missing required field \"") + key + "\"");
  const json& iterations = stats.at("iterations");
  if (!iterations.is_number_integer() || iterations.get<std::int64_t>() < 0 ||
      iterations.get<std::int64_t>() > std::numeric_limits<int>::max())
    throw InputError(path, "stats.iterations", "expected a non-negative integer, got " + iterations.dump());
  s.stats.iterations = iterations.get<int>();
  s.stats.seconds = json_finite_number(stats.at("seconds"), path, "stats.seconds");
  s.stats.residual = json_finite_number(stats.at("residual"), path, "stats.residual");
  s.stats.relative_residual = json_finite_number(stats.at("relative_residual"), path, "stats.relative_residual");
  s.stats.geometry_change = json_finite_number(stats.at("geometry_change"), path, "stats.geometry_change");

  // Keys of other commands (relax's "message"...) and unknown ones are carried through.
  static const std::vector<std::string_view> kRead = {"format",    "version", "scene", "solver",      "status",
                                                      "positions", "forces",  "stats", "rest_lengths"};
  for (auto it = j.begin(); it != j.end(); ++it)
    if (std::find(kRead.begin(), kRead.end(), it.key()) == kRead.end()) s.extra[it.key()] = *it;
  keys.report();
  return s;
}

}  // namespace tensegrity
