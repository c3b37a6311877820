#pragma once
// The stress QP of Eq. 4 at fixed geometry, with the project's force scale:
//
//   min_sigma  |A sigma + f_g|^2 + w^2 (c^T sigma - t)^2 + mu |sigma|^2
//   s.t.       lower <= sigma <= upper           (ForceScale: sign margins)
//
// c^T sigma = t is the normalisation of ForceScale (mean cable force = F0);
// w weights it; mu is the paper's weak regulariser (it picks the smallest forces
// among equally good ones) and is applied without biasing the residual (the
// solution is polished on the final free set). A bound-constrained sparse
// least-squares kernel of our own: the symbolic analysis of the normal matrix is
// done once per topology, and each solve is warm-started from the previous
// forces (Algorithm 1 passes them in).
//
// Method: projected Newton with an active set. With N = A^T A + w^2 c c^T +
// mu I and g = N sigma - b the gradient of half the objective, the held set W
// is the forces at a bound whose gradient points out of the box; each step
// solves N_FF d_F = -g_F on the free set F and then takes the best (by the
// exact decrease of the quadratic) of: the projected step P(sigma + d), an
// Armijo backtracking along the projection arc, and d truncated at the first
// bound it meets (always a decrease; it makes the blocking bound active).
// Free forces at a bound whose Newton component points out of the box are
// pinned there and the step is solved again on the smaller free set (else the
// projection clips them, the step is no Newton step for the others and the
// iteration jams). From a cold start a few non-monotone projected steps,
// taken only from a new best point and safeguarded by a return to the best
// point, let the projection predict many bound changes at once; warm starts
// are monotone (near the optimum of a degenerate QP such a step is far off)
// and their first step holds every force the warm start puts at a bound (the
// previous active set, usually still right after a small move: one
// factorization instead of a pinning round per inward-pointing gradient).
// The active set has settled when an unclipped full Newton step is followed
// by the same W. The rank-one normalisation term is
// kept sparse through the quasi-definite augmented matrix
//
//   K = [ A^T A + mu I   c      ]      (held rows/columns replaced by N_ii e_i,
//       [ c^T           -1/w^2  ]       so the sparsity pattern never changes),
//
// whose pattern (and that of A^T A) is built and AMD-analysed once; a step
// only refreshes values and calls factorize(), and reuses the factorization
// while the held set is unchanged. Each solve with K is iteratively refined
// against N (the near-null directions of A^T A, damped only by mu, would
// otherwise cost ~6 digits). Once the active set has settled, the free
// forces are polished by iterated Tikhonov steps (sigma_F += argmin
// |M_F d - r|^2 + mu |d|^2, M = [A; w c^T]) with the same factorization, so
// that the returned forces minimise the objective without the mu term to
// rounding accuracy: a geometry that is a tensegrity reaches a relative
// residual near machine precision.
//
// Near-mechanisms with many forces at a bound make the active set change a
// few forces per step; after interior_point_after steps without settling (or
// when no progress is possible) one Mehrotra predictor-corrector
// interior-point phase on the same pattern (diagonal barrier terms added to
// K) finds the optimum's neighbourhood, bounds whose slack is below their
// multiplier are snapped (crossover), mu is re-centred on that point, and
// projected Newton resumes. The polish is judged by the exact change of the
// residual objective (a difference of objectives is lost in rounding where
// the residual does not vanish).
//
// Limits: where [A; w c^T] has a null space (more forces than conditions)
// only mu picks among equally good forces, and double precision fixes that
// choice to about eps / mu (~1e-6 relative for mu = 1e-10); the residual
// is unaffected. Degenerate infeasible scenes (near-null directions of A^T A
// next to active bounds) can take ~5-15 factorizations even when warm.
//
// Units: forces and gradients in N (A is dimensionless: unit-vector columns).
#include <Eigen/Core>
#include <memory>

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
  int max_polish_steps = 30;         // iterated-Tikhonov steps on the final free set (stops when
                                     // the residual falls by less than 1 % in a step)
  // Centre the mu term on the (projected) warm start instead of the origin:
  // among equally good forces, those closest to the warm start. On
  // near-mechanisms the pull towards the origin moves many forces along
  // near-null directions of A at every solve; centred on the warm start, a
  // re-solve after a small geometry change only corrects the residual
  // (alternating.hpp: the faithful scheme converges on puppy and scorpion).
  // No effect on a cold start.
  bool proximal = false;
  // After this many projected-Newton iterations without settling, one
  // Mehrotra interior-point phase (see stress_qp.cpp); negative: never.
  int interior_point_after = 20;
  bool IsValid() const;              // mu > 0, w >= 0, all finite, counts >= 0
};

struct StressQpResult {
  Eigen::VectorXd sigma;          // m, within the bounds
  double equilibrium_norm = 0.0;  // |A sigma + f_g| (N)
  double max_node_residual = 0.0; // max over free nodes of |f_i| (N)
  double normalisation_error = 0.0;  // c^T sigma - t (N)
  double objective = 0.0;         // |A sigma + f_g|^2 + w^2 (c^T sigma - t)^2 (no mu term)
  int iterations = 0;             // projected-Newton steps taken
  int factorizations = 0;         // numeric factorizations of K (the dominant cost)
  int polish_steps = 0;           // iterated-Tikhonov steps taken
  int active_bounds = 0;          // forces at a bound
  // Largest violation of the KKT conditions of the objective without the mu
  // term (free forces: zero gradient; forces at a bound: gradient pointing out
  // of the box), each allowed mu |sigma_i|, relative to the scale of the
  // tolerance above.
  double kkt_error = 0.0;
  bool optimal = false;           // KKT conditions met within the tolerance
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

  const ForceScale& scale() const { return scale_; }
  const StressQpOptions& options() const { return options_; }

 private:
  struct Impl;
  StressQpResult solve_from(const Eigen::VectorXd& sigma0, bool warm_start);
  const Equilibrium& eq_;
  ForceScale scale_;
  StressQpOptions options_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace tensegrity
