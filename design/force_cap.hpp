#pragma once
// Why a stiffness design is impossible: when the stiffness QP has no feasible
// point (equilibrium at the form-found geometry with every cable inside its
// material's measured force range), the strain the user asked for is not the
// cause: the constraints do not depend on the targets. This linear program
// measures how far the geometry is from buildable with these materials:
//
//   t* = min_{sigma, t}  t
//        s.t.  A(x) sigma + f_g = 0,  lower <= sigma,
//              sigma_c <= t * cap_c   for every capped cable c,
//
// cap_c the largest force of cable c's material (N). t* <= 1 means a design
// exists; t* > 1 means every equilibrium overloads some cable to at least
// t* times its material's maximum. The "tightest" cables are those whose cap
// constraint carries the largest multipliers at the optimum (the multipliers
// sum to 1: the share of the bottleneck each cable is responsible for).
// Solved by Ipopt through the one adapter, kernels/ipopt_solve.hpp.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "formulations/stiffness_qp.hpp"
#include "model/status.hpp"
#include "model/structure.hpp"

namespace tensegrity {

struct ForceCapResult {
  Status status = Status::NumericalError;  // Converged when the LP was solved
  std::string message;
  double ratio = 0.0;                      // t*
  Eigen::VectorXd sigma;                   // m (N), an optimal force vector
  std::vector<int> tightest;               // capped cables, largest multiplier first (multiplier > 1e-6)
  std::vector<double> share;               // their multipliers (sum to about 1)
};

// `lower`, `upper` (m, N): the sign bounds (cables [margin, +inf), struts
// (-inf, -margin]); `cap` (m, N): the material maximum of each capped cable,
// +inf for elements without a cap. Never throws on solver failure.
ForceCapResult smallest_force_cap(const Structure& s, const Eigen::Matrix3Xd& positions, const Eigen::VectorXd& lower,
                                  const Eigen::VectorXd& upper, const Eigen::VectorXd& cap);

}  // namespace tensegrity
