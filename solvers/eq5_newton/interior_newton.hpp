#pragma once
// A primal-dual interior-point Newton method for Eq. 5 (scaled_eq5.hpp),
// meant to start close to the answer (alternating-gn's equilibrium).
//
// The sign bounds d(y) >= 0 carry a log barrier mu; each iteration is one
// Newton step on the perturbed KKT conditions
//
//   grad phi + J^T lambda - S^T v = 0,   c(y) = 0,   d .* v = mu,
//
// reduced to the symmetric system
//
//   [ H + S^T Sigma S + rho P + delta_w I   J^T        ] [ dy       ]   [ -grad phi + S^T mu / d ]
//   [ J                                     -delta_c I ] [ lambda+  ] = [ -c                     ]
//
// (Sigma = v / d, H the Hessian of phi + lambda^T c, P the projection on the
// forces). rho is a small proximal weight on the forces: Eq. 5 does not fix
// the forces along the self-stresses of A that keep c^T sigma, so without it
// the matrix is singular as mu -> 0; the step's right-hand side is the exact
// residual, so it changes the path, not the solution. delta_c keeps the
// matrix quasi-definite so that a sparse LDL^T without pivoting (Eigen's
// SimplicialLDLT, an elimination order from the structure analysed once) is
// stable; iterative refinement removes it from the solution (unless
// regularised_steps keeps it). The signs of D
// give the inertia: when it is not (n, mc), delta_w grows (as in Ipopt) until
// it is, so that the step minimises a model that is convex on the
// constraints' tangent space. Ipopt tries delta_w = 0 first at every
// iteration; after two consecutive shifted steps this method first tries a
// third of the last shift instead (while that is above 1e-8), which saves
// the failing factorizations of an indefinite stretch.
//
// Steps stay strictly inside the bounds (fraction to the boundary), are
// accepted by a filter line search on (|c|_1, phi - mu sum log d) (Waechter
// and Biegler 2006: Armijo on the barrier objective when the step is an
// objective step, one second-order correction against the Maratos effect,
// then halving; no restoration phase: a failed search ends `stalled`), and mu
// falls superlinearly (mu <- max(mu_min, min(0.2 mu, mu^1.5))) whenever the
// barrier problem is solved to 10 mu. Stop: dual infeasibility and
// complementarity below optimality_tolerance and every node row of c below
// constraint_tolerance, the cable-sum row below the larger of it and the
// row's rounding floor (ScaledEq5::cable_sum_row_floor; all dimensionless).
//
// Stationary stop: on large scenes with many self-stresses the forces drift
// along them with full steps, each step's bilinear term f = A(q) sigma leaving
// a residual of |dq| |dsigma|, so the KKT test is approached only linearly while
// the geometry no longer changes. When, at the barrier floor, the objective has
// changed by less than a relative 1e-5 over 10 iterations with every KKT
// residual below 1e-5, the run ends `stationary`, and its last iterate is
// projected onto c(y) = 0 (minimal-norm Newton steps in the metric I +
// Sigma, so that forces at their bounds stay put) to constraint_tolerance;
// where such a step leaves the bounds, again with a log barrier's Hessian
// added to the metric and steps cut to the fraction to the boundary.
#include <Eigen/Core>
#include <functional>
#include <limits>
#include <string>

#include "model/status.hpp"
#include "solvers/eq5_newton/scaled_eq5.hpp"

namespace tensegrity {

struct InteriorNewtonSettings {
  int max_iterations = 1000;
  double optimality_tolerance = 1e-10;
  double constraint_tolerance = 1e-10;
  double initial_barrier = 1e-6;   // mu at the start
  double proximal_weight = 1e-8;   // rho on the forces
  // mu from Mehrotra's predictor every iteration (with its second-order
  // correction) instead of the monotone rule.
  bool predictor_corrector = false;
  // With predictor_corrector: Mehrotra's rule only while each point is lower,
  // in |c|_1 or in phi, than every earlier point of that rule (a filter that
  // does not forget when mu changes); otherwise Ipopt's monotone rule from
  // 0.8 times the mean complementarity until a barrier problem is solved at a
  // point that is (Ipopt's adaptive mu globalization). Without it a polish
  // can trade |c|_1 for phi and back for hundreds of iterations, since the
  // line search's filter is cleared whenever mu changes.
  bool progress_filter = false;
  // Each step solves the KKT system with delta_c on the multipliers' block
  // left in, as Ipopt's steps keep its Jacobian regularisation, instead of
  // refining it away. Where the constraint Jacobian is nearly rank-deficient
  // (nearly coincident nodes, nearly parallel elements) the refined steps
  // carry multipliers of 1e4-1e9 and the line search stalls; the regularised
  // ones stay bounded. On the large towers the refined steps are needed to
  // meet the KKT test at all.
  bool regularised_steps = false;
  bool stationary_stop = true;  // the stationary stop above
  double time_limit_s = std::numeric_limits<double>::infinity();
};

struct InteriorNewtonOutcome {
  Status status = Status::NumericalError;
  std::string message;
  Eigen::VectorXd y;            // last accepted point (scaled)
  Eigen::VectorXd lambda;       // equality multipliers (scaled)
  Eigen::VectorXd bound_multipliers;  // v >= 0 of the bounds d(y) >= 0, at `lambda`'s point
  int iterations = 0;
  int factorizations = 0;
  int inertia_corrections = 0;  // factorizations repeated with a larger delta_w
  int second_order_corrections = 0;
  double dual_infeasibility = 0.0;
  double constraint_violation = 0.0;
  double complementarity = 0.0;
  // The stationary stop above ended the run (status Stalled) and `y` is its
  // last iterate projected onto the constraints to constraint_tolerance.
  bool stationary_projected = false;
  // The line search found no acceptable step (status Stalled) or the budget
  // ran out (MaxIterations), and `y` is the last iterate projected onto the
  // constraints in the same way: a point that may be closer to the scene
  // than the start, not a KKT point.
  bool last_iterate_projected = false;
};

// Called after every accepted step with the iteration number and the point.
using InteriorNewtonObserver = std::function<void(int iteration, const Eigen::VectorXd& y)>;

// `y0`: the start (scaled); forces closer to their bound than a tiny slack
// are moved inside first.
InteriorNewtonOutcome solve_interior_newton(ScaledEq5& problem, const Eigen::VectorXd& y0,
                                            const InteriorNewtonSettings& settings,
                                            const InteriorNewtonObserver& observer = {});

}  // namespace tensegrity
