#pragma once
// The driver's check whether a scene already stands (DriverControls):
// before any backend runs, the stress QP (Eq. 4) at the part's own geometry;
// a part whose forces there verify is returned unchanged.
#include "kernels/stress_qp.hpp"
#include "model/structure.hpp"
#include "solvers/solver.hpp"

namespace tensegrity {

// The stress QP's options in that check: its interior-point phase first, and
// a give-up a few projected-Newton steps past it far from an equilibrium
// (docs/BACKENDS.md, "The check whether a scene already stands").
StressQpOptions standing_check_qp_options();

// The check's forces at the part's own geometry (N) where its stress QP ran to
// its end, whether or not they verify; empty where it gave up. Solved through
// K (node_space off), whose rounding ipopt's start on degenerate scenes was
// measured with.
Eigen::VectorXd standing_check_forces(const Structure& part, const SolveOptions& options);

}  // namespace tensegrity
