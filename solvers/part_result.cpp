#include "solvers/part_result.hpp"

#include <utility>

#include "model/verify.hpp"

namespace tensegrity {

SolveResult make_part_result(const Structure& part, const FreeNodeMap& map, const Eigen::VectorXd& q,
                             const Eigen::VectorXd& sigma, Status status, std::string message, double tolerance,
                             TraceRecorder& recorder) {
  SolveResult r;
  r.positions = part.positions;
  map.scatter(q, r.positions);
  r.forces = sigma;
  const Verification v = verify(part, r.positions, r.forces, tolerance);
  r.stats.iterations = static_cast<int>(recorder.trace().size()) - 1;
  r.stats.seconds = recorder.seconds();
  r.stats.residual = v.residual;
  r.stats.relative_residual = v.relative_residual;
  r.stats.geometry_change = v.geometry_change;
  r.status = status;
  r.message = std::move(message);
  r.trace = std::move(recorder.trace());
  return r;
}

}  // namespace tensegrity
