#pragma once
// The first attempt of `alternating-gn`: Gauss-Newton steps on Eq. 5 in
// z = (q, sigma) that keep every force strictly inside its sign bound.
//
// Dimensionless (positions / L, forces / F0, ForceScale). Each step solves the
// linearised equilibrium with the smallest weighted change
//
//   min |q + dq - q0|^2 + sum_e dsigma_e^2 / w_e   s.t.  f + J dq + A dsigma = 0
//                                                        (and the normalisation),
//   w_e = force_weight * (s_e / F0)^2,   s_e = the slack of sigma_e to its bound,
//
// i.e. dq = q0 - q + J^T y, dsigma = W A^T y with (J J^T + A W A^T) y = rhs:
// one NormalMatrix factorization (3 n_free unknowns, node-block pattern,
// symbolic analysis once). Forces far from their bound are cheap to change
// (force_weight >> 1: the geometry moves little, as Eq. 5 wants); a force
// near its bound becomes expensive in proportion to its slack squared
// (affine scaling), and a step uses at most boundary_fraction of any slack,
// so the sign conditions hold at every iterate without an active set or QP.
// The pull towards q0 (the anchor) is kept while each step cuts Eq. 4's
// objective by anchor_until or more; after that the plain least-change step
// (anchor dropped) converges quadratically on the residual. Steps are
// accepted on Eq. 4's objective (Armijo, halving), so it never increases.
//
// Start: +F0 on cables, -F0 on struts (reference_forces), not the stress
// QP: QP forces sit at their bounds, where the affine weights freeze them
// and the geometry would have to move instead. When the caller has no QP
// forces at the input geometry a force-only step first checks whether the
// input already is a tensegrity (then the geometry is returned unchanged).
//
// Returns Converged (verified), or Stalled / MaxIterations / TimeLimit / NumericalError
// for the caller to fall back on the alternating iteration.
#include "solvers/solver.hpp"

namespace tensegrity {

struct InteriorGaussNewtonOptions {
  int max_iterations = 40;         // 0: skip this attempt
  double force_weight = 3e3;       // w_e / (s_e / F0)^2
  double boundary_fraction = 0.99; // share of a force's slack one step may use
  double anchor_until = 0.3;       // keep the anchor while phi_new <= anchor_until * phi
  double max_step = 0.25;          // largest node move per step (units of L)
  double lambda = 1e-12;           // damping relative to the mean diagonal of the normal matrix
  double margin_fraction = 0.0;    // sign margin / F0; 0 = SolveOptions::margin_fraction
  // Levenberg-Marquardt damping: after a step the line search had to shorten,
  // lambda grows tenfold; after a full step it shrinks tenfold, down to lambda.
  // Off: lambda returns to its floor after every accepted step.
  bool adaptive_damping = false;
  // Progress test (0: off): every progress_window steps the relative residual
  // must have fallen to progress_ratio of its value a window earlier, or the
  // attempt ends `stalled`.
  int progress_window = 0;
  double progress_ratio = 0.9;
  bool IsValid() const;
};

// The second attempt of `alternating-gn`, run when the first does not
// converge: forces a hundred times cheaper than moves, adaptive damping and
// a progress test. Tall slender structures (the 160-layer tower) have
// near-mechanisms that only many small geometry steps resolve: there the
// first attempt stalls and this one converges linearly.
InteriorGaussNewtonOptions patient_interior_options();

// The last attempt of `alternating-gn`, run when the alternating runs after
// the interior attempts do not converge either: forces a hundred times dearer
// than in the first attempt (30), so that the geometry carries the change. A
// load the structure was not shaped for (the gravity tower loaded sideways)
// needs forces many times the start's, which the affine weights of the
// cheaper-force attempts grow too slowly; moving the geometry reaches an
// equilibrium in a few steps, farther from the input (Eq. 5's polish, in
// eq5-newton or ipopt, then brings it back).
InteriorGaussNewtonOptions stiff_force_interior_options();

SolveResult solve_interior_gauss_newton(const Structure& part, const SolveOptions& options,
                                        const InteriorGaussNewtonOptions& interior);

}  // namespace tensegrity
