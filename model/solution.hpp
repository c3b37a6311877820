#pragma once
// A solution file (docs/FORMATS.md): positions per node (m), axial force per element
// (N, positive = tension), status and stats.
#include <Eigen/Core>
#include <iosfwd>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "model/status.hpp"
#include "model/structure.hpp"

namespace tensegrity {

struct SolutionStats {
  int iterations = 0;
  double seconds = 0.0;
  double residual = 0.0;           // max net force on a free node (N)
  double relative_residual = 0.0;  // residual / load scale (docs/FORMATS.md)
  double geometry_change = 0.0;    // |x - x_scene| over all coordinates (m)
};

struct Solution {
  std::string scene;
  std::string solver;
  Status status = Status::NumericalError;
  Eigen::Matrix3Xd positions;      // 3 x n
  Eigen::VectorXd forces;          // m
  SolutionStats stats;
  std::optional<Eigen::VectorXd> rest_lengths;  // m, once a material is applied
  nlohmann::json extra = nlohmann::json::object();  // further keys, written as is
};

nlohmann::json solution_to_json(const Solution& s);
void write_solution(const Solution& s, std::ostream& out);
// Writes to a temporary file beside `path` and renames, so a failed write
// leaves no partial output. "-" means standard output.
void write_solution_file(const Solution& s, const std::string& path);

// Reads and validates a solution against its scene (node and element counts).
Solution read_solution_file(const std::string& path, const Structure& scene);

}  // namespace tensegrity
