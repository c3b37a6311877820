#pragma once
// `tensegrity compare`: every backend on one scene, one row each, and their
// traces on one time axis.
//
// Trace columns mean the same for every backend (docs/OUTPUTS.md):
//   seconds            wall time since the backend's start (s)
//   iteration          0 is the common start point, then the backend's own count
//   residual           max free-node net force (N)
//   relative_residual  residual / load scale (docs/FORMATS.md)
//   geometry_change    |x - x_scene| (m)
//   backend_objective  backend-specific: each backend's own objective, not comparable
// The start point (iteration 0, 0 s) is the same for every backend: the scene's
// geometry with the least-squares forces of the stress QP (Eq. 4) there. The
// backends' own iteration-0 records differ (some start from other forces), so
// they are replaced by it.
#include <string>
#include <vector>

#include "solvers/solver.hpp"

namespace tensegrity::cli {

struct CompareRow {
  std::string solver;
  Status status = Status::NumericalError;
  std::string message;
  double median_seconds = 0.0;   // median over the repeats
  int iterations = 0;
  double relative_residual = 0.0;
  double geometry_change = 0.0;  // norm over all coordinates (m)
  double largest_node_move = 0.0;  // max over nodes of |x_i - x_scene,i| (m)
  bool verified = false;           // model/verify at the tolerance
  std::vector<TracePoint> trace;   // normalised as above
};

// The common start point's record (iteration 0, 0 s).
TracePoint start_point(const Structure& scene, const SolveOptions& options);
// The backend's trace with its own iteration-0 records replaced by `start`, and
// the verified final result appended when the trace ends before it.
std::vector<TracePoint> normalised_trace(const std::vector<TracePoint>& trace, const TracePoint& start,
                                         const SolveResult& final_result);

std::string compare_csv(const std::vector<CompareRow>& rows);
std::string compare_trace_csv(const std::vector<CompareRow>& rows);
std::string compare_json(const std::string& scene_name, double tolerance, int repeat,
                         const std::vector<CompareRow>& rows);
std::string compare_table(const std::vector<CompareRow>& rows);
// Relative residual (log scale) and geometry change against time (log scale),
// one line per backend; PNG or SVG by the extension.
void write_compare_plot(const std::string& scene_name, const std::vector<CompareRow>& rows, const std::string& path);

}  // namespace tensegrity::cli
