#pragma once
// The stiffness-scaling QP (formulations/stiffness_qp.hpp) solved by Ipopt (an
// interior-point method; the QP is convex), then polished: the bounds Ipopt
// ends on are held fixed and the remaining equality-constrained QP is solved
// exactly, which puts the equilibrium residual at round-off. The polished
// point is kept only when it satisfies every bound and the multiplier signs.
// Ipopt runs through the one adapter, kernels/ipopt_solve.hpp.
#include <Eigen/Core>
#include <string>

#include "formulations/stiffness_qp.hpp"
#include "model/status.hpp"
#include "model/structure.hpp"

namespace tensegrity {

struct StiffnessOptions {
  double tolerance = 1e-10;     // relative equilibrium residual (model/verify) for Converged
  int max_iterations = 3000;    // Ipopt iterations
  bool polish = true;
  bool verbose = false;         // Ipopt's own log on stderr
};

struct StiffnessResult {
  Status status = Status::NumericalError;
  std::string message;
  Eigen::VectorXd sigma;              // m (N)
  Eigen::VectorXd lambda;             // 3 n_free, equilibrium multipliers
  Eigen::VectorXd bound_multipliers;  // m, z = z_lower - z_upper
  double objective = 0.0;             // 1/2 sum w (sigma - t)^2 (N^2)
  double residual = 0.0;              // max free-node net force (N), model/verify
  double relative_residual = 0.0;     // over the load scale (docs/FORMATS.md, Solution file)
  double max_target_deviation = 0.0;  // max over weighted elements |sigma - t| (N)
  int iterations = 0;                 // Ipopt iterations
  int active_bounds = 0;
  bool polished = false;
  double seconds = 0.0;
};

// Solves at the given geometry (3 x n; fixed nodes at their scene positions).
// `start` (m forces, e.g. the form-finding result) is optional. Never throws on
// solver failure: Infeasible when Ipopt proves the constraints inconsistent
// (or a free node with weight has no element), MaxIterations when Ipopt's
// iteration budget runs out, NumericalError otherwise.
StiffnessResult solve_stiffness_qp(const Structure& s, const Eigen::Matrix3Xd& positions,
                                   const StiffnessProblem& problem, const StiffnessOptions& options = {},
                                   const Eigen::VectorXd* start = nullptr);

}  // namespace tensegrity
