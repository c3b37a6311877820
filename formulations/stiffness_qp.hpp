#pragma once
// Stiffness scaling (paper section 3, "Stiffness Scaling"). Once form finding
// has produced a geometry x in equilibrium, the forces are still free along the
// self-stresses (and, with gravity, the prestress level). The user asks for a
// cable strain; through each cable's material it becomes a target force t_c,
// and the forces are chosen by the convex QP
//
//   min_sigma  1/2 sum_e w_e (sigma_e - t_e)^2
//   s.t.       A(x) sigma + f_g = 0                (equilibrium, hard)
//              lower_e <= sigma_e <= upper_e        (signs / material range)
//
// with w = 1 on cables and (by default) 0 on struts: strut forces follow from
// equilibrium. Units: N. KKT conditions, with multipliers lambda (3 n_free) of
// the equilibrium rows and z = z_lower - z_upper of the bounds:
//
//   w .* (sigma - t) + A^T lambda - z = 0,
//   z_e >= 0 where sigma_e = lower_e, z_e <= 0 where sigma_e = upper_e, else 0.
//
// Ipopt solves it in design/stiffness_solver.hpp; the exact active-set solve
// below polishes its answer to machine precision.
#include <Eigen/Core>
#include <vector>

#include "formulations/equilibrium.hpp"
#include "model/structure.hpp"

namespace tensegrity {

struct StiffnessProblem {
  Eigen::VectorXd target;  // m (N); only read where weight > 0
  Eigen::VectorXd weight;  // m, >= 0
  Eigen::VectorXd lower;   // m (N), may be -inf
  Eigen::VectorXd upper;   // m (N), may be +inf
};

// Cables: weight 1, target from `cable_targets` (m entries, strut entries
// ignored), bounds [margin, +inf); struts: weight `strut_weight`, target 0,
// bounds (-inf, -margin]. Tighten the cable bounds to a material's force range
// afterwards when rest lengths must exist.
StiffnessProblem make_stiffness_problem(const Structure& s, const Eigen::VectorXd& cable_targets, double margin,
                                        double strut_weight = 0.0);

double stiffness_objective(const StiffnessProblem& p, const Eigen::VectorXd& sigma);

// Which bound an element sits on: -1 lower, +1 upper, 0 none.
using ActiveSet = std::vector<int>;

struct ActiveSetSolution {
  bool ok = false;                 // a consistent, finite solution was found
  Eigen::VectorXd sigma;           // m (N); active entries exactly at their bound
  Eigen::VectorXd lambda;          // 3 n_free
  Eigen::VectorXd z;               // m, bound multipliers (zero off the active set)
  double equilibrium_norm = 0.0;   // |A sigma + f_g| (N)
};

// The equality-constrained QP with the active bounds held fixed, solved exactly
// by the null-space method (dense rank-revealing QR of the free columns of A;
// rank-deficient A, e.g. rigid-body modes without fixed nodes, is handled). Does
// not check the inactive bounds or the signs of z: the caller does.
ActiveSetSolution solve_on_active_set(const Equilibrium& eq, const StiffnessProblem& p, const ActiveSet& active);

struct StiffnessKkt {
  double stationarity = 0.0;      // max |w (sigma - t) + A^T lambda - z| over inactive elements (N)
  double wrong_sign = 0.0;        // max of the wrong-signed part of z on active bounds (N)
  double bound_violation = 0.0;   // max amount sigma leaves [lower, upper] (N)
  double equilibrium_norm = 0.0;  // |A sigma + f_g| (N)
  int active = 0;                 // elements within `active_tolerance` of a bound
  Eigen::VectorXd lambda, z;
};

// Independent KKT check at sigma: bounds within `active_tolerance` (N) count as
// active; lambda is the least-squares solution of the stationarity rows of
// the inactive elements, z the remaining gradient on the active ones.
StiffnessKkt stiffness_kkt(const Equilibrium& eq, const StiffnessProblem& p, const Eigen::VectorXd& sigma,
                           double active_tolerance);

}  // namespace tensegrity
