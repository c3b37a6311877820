#pragma once
// Eq. 4 at fixed geometry by Ipopt, in residual form:
//
//   min_{sigma, r}  |r|^2 / F0^2
//   s.t.            A sigma + f_g = r        (3 n_free rows, N)
//                   c^T sigma = t            (without gravity: ForceScale's normalisation)
//                   lower <= sigma <= upper  (ForceScale: sign margins)
//
// The same optimum as the stress QP without its mu term (kernels/stress_qp.hpp).
// Why a second method: on large near-mechanisms (the equilibria of long
// towers without gravity, thousands of elements) A has many singular values
// far below sqrt(mu), the normal matrix A^T A of the stress QP squares its
// condition number, and the kernel's phases stop short of equilibria that
// exist. Ipopt factorizes the augmented system with A itself, with pivoting
// (MUMPS), and reaches them. It finds forces, not proofs: only the stress
// QP's certified optimum may call a geometry infeasible.
//
// Units: sigma in N; Ipopt works with sigma / F0 and r / F0.
#include <Eigen/Core>
#include <functional>
#include <string>

#include "formulations/equilibrium.hpp"
#include "formulations/force_scale.hpp"
#include "model/status.hpp"

namespace tensegrity {

struct StressQpIpoptResult {
  Status status = Status::NumericalError;  // Ipopt's outcome (kernels/ipopt_solve.hpp)
  std::string message;
  Eigen::VectorXd sigma;  // m, within the bounds; empty when Ipopt returned no point
  double measure = 0.0;   // the caller's measure of sigma (infinity when there is none)
  int iterations = 0;
};

// The caller's measure of forces at this geometry (e.g. verify()'s relative residual).
using ForceMeasure = std::function<double(const Eigen::VectorXd& sigma)>;

// Solves at the equilibrium's current geometry from sigma0 (projected onto
// the bounds; the reference forces where it is unusable), within
// time_limit_s seconds of wall time. Every iterate's forces are measured; the
// solve stops (Converged) at the first whose measure is at most stop_below,
// and returns the best measured forces (or Ipopt's final point when none was
// measured: in its restoration phase iterates are not visible).
StressQpIpoptResult solve_stress_qp_with_ipopt(const Equilibrium& eq, const ForceScale& scale,
                                               const Eigen::VectorXd& sigma0, double time_limit_s,
                                               const ForceMeasure& measure, double stop_below);

}  // namespace tensegrity
