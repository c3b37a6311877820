#pragma once
// The stress QP of Eq. 4 at fixed geometry, with the project's force scale:
//
//   min_sigma  |A sigma + f_g|^2 + w^2 (c^T sigma - t)^2 + mu |sigma|^2
//   s.t.       lower <= sigma <= upper           (ForceScale: sign margins)
//
// c^T sigma = t is the normalisation of ForceScale (mean cable force = F0),
// present only without gravity (under gravity the load sets the scale and the
// term is absent); w weights it; mu is the paper's weak regulariser (it picks
// the smallest forces among equally good ones) and is applied without biasing
// the residual (the solution is polished on the final free set). A bound-constrained sparse
// least-squares kernel of our own: the symbolic analysis of the normal matrix is
// done once per topology, and each solve is warm-started from the previous
// forces (Algorithm 1 passes them in).
//
// Method, in three phases (one file each):
//  - projected Newton with an active set (stress_qp_projected_newton.cpp).
//    With N = A^T A + w^2 c c^T + mu I and g = N sigma - b the gradient of
//    half the objective, the held set W is the forces at a bound whose
//    gradient points out of the box; each step solves N_FF d_F = -g_F on the
//    free set and takes the best (by the exact decrease of the quadratic) of
//    the projected step, Armijo backtracking along the projection arc, and d
//    truncated at its first bound. The rank-one normalisation term is kept
//    sparse through the quasi-definite augmented matrix
//      K = [ A^T A + mu I   c      ]   (held rows/columns replaced by N_ii e_i,
//          [ c^T           -1/w^2  ]    so the sparsity pattern never changes),
//    analysed once per topology, refactorized only when W changes, and each
//    solve with it iteratively refined against N.
//  - an interior-point phase with crossover (stress_qp_interior_point.cpp):
//    when the active set changes a few forces per step (near-mechanisms with
//    many forces at a bound) a Mehrotra predictor-corrector method on the same
//    pattern finds the optimum's neighbourhood; bounds whose slack is below
//    their multiplier are snapped, and projected Newton resumes from there.
//  - a polish (stress_qp_polish.cpp): on the final free set, conjugate
//    gradients preconditioned by the factorization minimise the objective
//    without the mu term, so that a tensegrity reaches a residual at rounding
//    level along near-null directions of A as well; with polish_to_optimum,
//    an active-set method on the mu-free objective from that free set.
//
// Status: `Optimal` means the KKT conditions of the mu-free objective hold to
// the tolerance (a free force has zero gradient, a force at a bound a gradient
// pointing out of the box) and, with certify_optimum, that a lower bound
// proves the optimum's objective at least a quarter of the returned one; only
// then is a positive residual a proof that the geometry is not a tensegrity.
// `IterationLimit`, `Stalled` and `Uncertified` are no such proof.
//
// Limits: where [A; w c^T] has a null space only mu picks among equally good
// forces, and double precision fixes that choice to about eps / mu relative;
// the residual is unaffected.
//
// Units: forces and gradients in N (A is dimensionless: unit-vector columns).
#include <Eigen/Core>
#include <memory>
#include <string>

#include "formulations/equilibrium.hpp"
#include "formulations/force_scale.hpp"

namespace tensegrity {

struct StressQpOptions {
  double mu = 1e-10;                 // regulariser weight (dimensionless: A has unit columns)
  double normalisation_weight = 1.0; // w
  int max_iterations = 100;          // active-set / projected-Newton iterations
  // Relative projected-gradient tolerance, relative to
  // max(F0, |sigma|_inf, |f_g|_inf). Never taken below 32 eps sqrt(m + 1),
  // the rounding level of the gradient itself.
  double optimality_tolerance = 1e-13;
  int max_polish_steps = 30;         // polish steps (conjugate-gradient solves) on the final free set
  // The polish as a complete active-set method (Lawson-Hanson style: bounds
  // join the held set and, at each free set's optimum, the most inward-pointing
  // held bound is released) instead of a polish of the final free set alone.
  // Reaches the mu-free optimum on near-mechanisms, where projected Newton
  // stops on a wrong active set, at the price of more steps (raise
  // max_polish_steps with it). Off by default: Algorithm 1 re-solves at once
  // after a geometry change, and needs only the polish of the free set.
  bool polish_to_optimum = false;
  // Centre the mu term on the (projected) warm start instead of the origin:
  // among equally good forces, those closest to the warm start. On
  // near-mechanisms the pull towards the origin moves many forces along
  // near-null directions of A at every solve; centred on the warm start, a
  // re-solve after a small geometry change only corrects the residual
  // (solvers/alternating/alternating_solver.hpp, qp_proximal). No effect on a
  // cold start.
  bool proximal = false;
  // After this many projected-Newton iterations without settling, one
  // Mehrotra interior-point phase (see stress_qp.cpp); negative: never.
  int interior_point_after = 20;
  // Certify an optimum with a positive residual before calling it Optimal:
  // one least-squares step on the free set, unconstrained, gives forces
  // sigma' at which the gradient vanishes on the free set; when the gradient
  // at sigma' also points out of the box at every held bound, the objective
  // at sigma' bounds the objective of every force vector in the box from
  // below (weak duality, with the residual at sigma' as the dual point). On
  // an ill-conditioned free set (near-mechanisms) a tiny gradient does not
  // mean a small distance to the optimum, and this bound is what tells the
  // two apart. One conjugate-gradient solve per call; off by default since
  // only a claim of infeasibility needs it.
  bool certify_optimum = false;
  // Give up after this many projected-Newton steps (status IterationLimit,
  // without the polish) when the relative residual, the largest free-node
  // residual over the largest free-node load (over |sigma|_inf without
  // loads; a load shift counts as a load), is still above give_up_residual.
  // For a caller that only asks whether a geometry already is a tensegrity:
  // far from one, the rest of the solve buys nothing it needs. Negative: never.
  int give_up_after = -1;
  double give_up_residual = 1e-2;
  // End the interior-point phase early once its iterates' relative residual
  // has settled far from a tensegrity: with the dual residual met, it moved
  // by under 1 % over two iterations in which the mean complementarity fell
  // fourfold, and it is above ten times give_up_residual. The crossover and
  // projected Newton follow as usual, and give_up_after judges the residual
  // there: the mu term can hold the phase's iterates that far from forces
  // that stand (gravity prisms with 0.1 % node noise settle at 0.26), and the
  // steps after the crossover, centred on it, reach them. For a caller that
  // only asks whether a geometry is a tensegrity; off by default.
  bool end_interior_point_when_settled = false;
  // End projected Newton once the best point visited has lowered the
  // regularised objective by no more than a relative 1e-3 over this many
  // steps past the interior-point phase, or from the start without one
  // (status Stalled; the best point and the polish follow as usual). For a
  // caller that only asks whether a geometry is a tensegrity: on
  // near-mechanisms the steps after the phase can go on to the step cap
  // without lowering it. Negative: never.
  int end_when_stalled_after = -1;
  // Solve with K through the node space instead of factorizing it: with D
  // the diagonal of K's force block less A^T A's (mu, plus the interior-point
  // phase's barrier terms; held forces drop out), B = [A; w c^T] and
  //   M = I + B D^{-1} B^T    (3 n_free (+1) square, 3x3 node blocks),
  // K's free block is D + B^T B and its inverse D^{-1} - D^{-1} B^T M^{-1} B D^{-1}
  // (Woodbury). M has the node graph's pattern, sparser to factorize than
  // A^T A's (elements sharing a node), and needs no analysis of A^T A: the
  // driver's check is 1.3-3.3 times faster on towers (docs/figures/
  // check-qp.md). Every solve is refined against the operator as with K.
  // Off by default: the other callers' iterates keep K's rounding.
  bool node_space = false;
  bool IsValid() const;              // mu > 0, w >= 0, give_up_residual > 0, the rest finite, counts >= 0
};

// Only Optimal is a claim about the optimum; the next three are "no proof
// either way", each saying why.
enum class StressQpStatus {
  Optimal,           // KKT conditions met (and certified when asked): the residual is the optimum's
  IterationLimit,    // max_iterations spent before the KKT conditions were met, or given up (give_up_after)
  Stalled,           // no step made progress (at rounding level) before the KKT conditions were met
  Uncertified,       // KKT conditions met, but certify_optimum found no lower bound near the objective
  NumericalFailure,  // a factorization failed, a value was not finite, or a degenerate element
};
const char* to_string(StressQpStatus status);

namespace stress_qp_detail {
struct SolveState;
}

struct StressQpResult {
  StressQpStatus status = StressQpStatus::NumericalFailure;
  std::string message;            // one line: why this status
  Eigen::VectorXd sigma;          // m, within the bounds
  double equilibrium_norm = 0.0;  // |A sigma + f_g| (N)
  double max_node_residual = 0.0; // max over free nodes of |f_i| (N)
  double normalisation_error = 0.0;  // c^T sigma - t (N)
  double objective = 0.0;         // |A sigma + f_g|^2 + w^2 (c^T sigma - t)^2 (no mu term)
  int iterations = 0;             // projected-Newton steps taken
  int factorizations = 0;         // numeric factorizations of K (the dominant cost)
  int polish_steps = 0;           // polish steps (conjugate-gradient solves) taken
  int active_bounds = 0;          // forces at a bound
  // Largest violation of the KKT conditions of the objective without the mu
  // term (free forces: zero gradient; forces at a bound: gradient pointing out
  // of the box, allowed the mu term's pull there), relative to the scale of
  // the tolerance above.
  double kkt_error = 0.0;
  // With certify_optimum: a proven lower bound on `objective` over the box
  // (-infinity when none was found; `objective` itself at rounding level).
  // Otherwise 0, which bounds any objective.
  double objective_lower_bound = 0.0;
  bool optimal = false;           // status == Optimal
  // Stopped at give_up_after (status IterationLimit): the forces are an
  // unfinished QP's, a few steps past its interior-point phase.
  bool gave_up = false;
};

class StressQp {
 public:
  // Keeps a reference to `eq` (which holds the geometry) and analyses the
  // sparsity pattern once. A change of A's pattern (not expected: Equilibrium
  // keeps it per topology) is detected and triggers a new analysis.
  StressQp(const Equilibrium& eq, const ForceScale& scale, StressQpOptions options = {});
  ~StressQp();
  StressQp(const StressQp&) = delete;
  StressQp& operator=(const StressQp&) = delete;

  // Solves at the equilibrium's current geometry, warm-started from sigma0
  // (projected onto the bounds first; non-finite entries or a wrong size fall
  // back to the cold start). Never throws; failures give optimal = false with
  // finite forces.
  StressQpResult solve(const Eigen::VectorXd& sigma0);
  // Cold start from the reference forces (+F0 cables, -F0 struts, projected).
  StressQpResult solve();

  // Shifts the data of the following solves: f_g + load (N, 3 n_free; empty:
  // no shift) and t + target (N; ignored without the normalisation). The
  // inner problem in the forces of an augmented Lagrangian on the residual
  // vector (multipliers lambda, penalty rho) is this QP with load F0 lambda_f /
  // rho; the reported residuals are then those of the shifted data.
  void set_shift(const Eigen::VectorXd& load, double target);

  // Switches the polish for the following solves (StressQpOptions::
  // polish_to_optimum, max_polish_steps) without a new analysis of the pattern.
  void set_polish(bool to_optimum, int max_steps) {
    options_.polish_to_optimum = to_optimum;
    options_.max_polish_steps = max_steps;
  }
  // Switches StressQpOptions::interior_point_after for the following solves.
  void set_interior_point_after(int steps) { options_.interior_point_after = steps; }

  const ForceScale& scale() const { return scale_; }
  const StressQpOptions& options() const { return options_; }

 private:
  struct Impl;
  StressQpResult solve_from(const Eigen::VectorXd& sigma0, bool warm_start);
  StressQpResult report(stress_qp_detail::SolveState& st);
  bool certified(stress_qp_detail::SolveState& st, StressQpResult& result);
  const Equilibrium& eq_;
  ForceScale scale_;
  StressQpOptions options_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace tensegrity
