#pragma once
// The paper's alternating scheme (section 3, Algorithm 1) as two backends that
// share one outer loop:
//
//   repeat
//     sigma = argmin Eq. 4 at the current geometry     (StressQp, warm-started)
//     stop when the relative residual <= tolerance     (Converged)
//     position phase                                   (decreases |f(x, sigma)|^2)
//   until the position phase moved the free nodes by less than epsilon_cvg
//
// "alternating" (faithful): the position phase is Algorithm 1's inner loop.
//   With a distance budget gamma_acc = gamma, at most i_max steps along Eq. 6,
//   dx = s d, d = -g / |g|, g = (df/dx)^T f (the descent sign), each step
//   length s found by a line search on Eq. 4's objective at fixed sigma that
//   accepts only an Armijo decrease, capped by gamma_acc; gamma_acc -= s.
//   g and J d are matrix-free products (J is symmetric, so g = J f and
//   J d = -J g / |g|; Equilibrium::jacobian_positions_product) at the geometry
//   the accepted trial left in Equilibrium: J is never assembled. J d serves
//   the Cauchy step alone, so an accepted SDC constant step (below) skips it.
//
//   Step lengths (the paper leaves the line search open). step_length =
//   cauchy: the first trial is the minimiser of the linearised
//   |f + s J d|^2 (the Cauchy step), capped by gamma_acc, then halving until
//   Armijo holds. step_length = sdc: the monotone SDC rule of De Asmundis,
//   di Serafino, Hager, Toraldo and Zhang (2014): in cycles of
//   sdc_cauchy_steps + sdc_constant_steps steps, the first are Cauchy steps
//   and the rest first try Yuan's step computed from the last two Cauchy
//   steps (falling back to the Cauchy step when it misses the Armijo
//   decrease), which breaks steepest descent's zigzag. (The paper's SDC
//   computes Yuan's step at the first constant step, from that step's and the
//   previous Cauchy step; here it comes from the last two steps of the Cauchy
//   phase, so that phase needs at least two steps.) SDC converges in about
//   half the outer iterations and on more strongly perturbed scenes, but it
//   travels further along the flat directions of a near-mechanism: on the
//   perturbed octahedra of tests/backend_suite_test.cpp, with gamma = 0.1
//   and i_max = 100, it moves the nodes 4-6x as far as Ipopt's Eq. 5 optimum
//   (Cauchy: 1.00-1.08x), and 2x as far as Cauchy on the benchmark's
//   octahedron with the default gamma and i_max. Minimal
//   geometry change is what Eq. 5 asks for, so Cauchy steps come first.
//   step_length = adaptive (default): Cauchy steps until the scheme crawls,
//   that is until Eq. 4's objective is above crawl_ratio times its value
//   crawl_window outer iterations earlier; from then on SDC steps, at most
//   crawl_i_max per outer iteration (the result's message says where). On
//   the 80/500 tower steepest descent with Cauchy steps crawls at relative
//   residual 1e-7 .. 3e-5 (the stress QP deflates the top module's forces to
//   the sign margin, ~1e-3 of its neighbours', so its position gradient is
//   ~1e-3 of theirs and its curvature ~1e-6); the switch took it
//   from 0 to 16 of the 20 noisy plain-tower trials in 20 s. Scenes that
//   converge without crawling take the same iterates as with cauchy.
//   crawl_i_max = 100 rather than 500: with warm stress solves of one or two
//   factorizations, a QP every 100 steps lets the forces follow the geometry
//   instead of descending on stale forces, which converged the gravity tower
//   at 10 % noise in 11-15 s instead of 19-32 s with 25-35 % less geometry
//   change (README, "alternating").
//   Measured on tests/alternating_solver_test.cpp's prism grids (80 scenes
//   each, 2000 outer iterations, 1 % / 5 % / 15 % noise, proximal QP):
//   cauchy 80 / 80 / 65 converge, adaptive 80 / 80 / 78 (crawl_i_max 500;
//   with 100: 76 in 2000, 78 in the faithful budget), sdc 80 / 80 / 73,
//   sdc with gamma = 0.1, i_max = 100 80 / 80 / 76 (geometric-mean geometry
//   change against cauchy at 1 / 5 %: sdc +1 / +2 %, with gamma = 0.1
//   +4 / +8 %). The scenes left at 15 % stall at local
//   minima of Eq. 4 (the position gradient vanishes at a non-zero residual
//   the stress QP cannot lower) or crawl; Ipopt fails on three of them too.
//
//   Stress solves: every QP after the first is centred on the previous
//   forces (qp_proximal, StressQpOptions::proximal). The paper's weak
//   regulariser pulls towards zero forces; on near-mechanisms that pull moves
//   many forces along near-null directions of A at every warm solve, so the
//   QP ran into its 100-iteration cap with its active set changing and the
//   forces Algorithm 1 worked with were not Eq. 4's minimisers. Centred on
//   the previous forces, the first solve still picks the smallest forces
//   (cold, or warm from the driver's forces, which its own cold solve
//   picked; then centred on them) and later ones only correct the residual. With it the faithful scheme
//   converges on the perturbed characters (docs/ROBUSTNESS.md); without it
//   duck and puppy ended at relative residual 1e-7 .. 1e-4 after 2000 outer
//   iterations and scorpion never got below 1e-5 in 20 s. On the 80/500
//   towers the warm QP now takes a few factorizations (stress_qp.hpp:
//   pinning, monotone warm starts) and the gravity tower mostly converges,
//   but on the plain tower the steepest-descent steps converge sublinearly
//   (relative residual ~1/k) and 20 s are not enough.
//
// "alternating-gn": the position phase is one damped Gauss-Newton
//   (Levenberg-Marquardt) step. By default it is a joint step in z = (q, sigma)
//   (f is linear in sigma) with the minimum weighted norm,
//     dz = -W J^T (J W J^T + lambda I)^{-1} r,
//   in dimensionless units (positions / L, forces / F0); r stacks f and the
//   force-scale normalisation row; W weighs positions 1, forces sigma_weight and
//   elements at their sign bound 0. f is linear in sigma, so when the step
//   keeps every sign the new forces are used as they are; a force that would
//   cross its bound is clipped and held there (qp_on_crossing: run the stress
//   QP instead, 3-10x slower on the 80/500 towers for the same result); when a
//   trial fails with forces that did not come from the QP, the QP
//   re-optimises them (and frees held forces) before the damping grows.
//   sigma_weight = 0 gives the positions-only Gauss-Newton step (QP every step).
//   Node moves are capped by a trust radius (max_step * L); a trial is accepted
//   only if Eq. 4's objective decreases, else lambda grows and the radius halves.
//   J W J^T is assembled in place into a preallocated pattern and factorized by
//   a sparse LDLT whose ordering and symbolic analysis are done once per part.
//
// Anchored step: with the same factorization, the step that reaches the
//   linearised equilibrium with the smallest |q + dq - q0| is tried first
//   (a Gauss-Newton step towards Eq. 5's minimal geometry change), accepted
//   if it achieves a quarter of its predicted decrease; else the plain step.
// Restarts: a GN run that stalls starts again from the input with other step
//   weights (AlternatingOptions::restarts); the result is the first that
//   converges (or the best).
//
// Defaults were chosen by sweeps over the perturbed prisms and octahedra of
// tests/alternating_solver_test.cpp and the 80/500 towers (most converged,
// then smallest geometry change, then least time); see the README.
//
// Both: the objective of Eq. 4, |f|^2 + w^2 (c^T sigma - t)^2, never increases
// from one outer iteration to the next (the QP result is kept only if it is no
// worse than the warm start). Lengths are relative to the part's mean element
// length L (Structure::mean_element_length) and forces to F0 (force_scale.hpp),
// so a scaled scene gives the same iterates scaled. Statuses: Converged
// (relative residual <= tolerance, signs right, verified by model/verify),
// MaxIterations, TimeLimit, Infeasible (a stall at a local minimum with a
// non-zero residual, or a gravity load on a part without fixed nodes).
// One TracePoint per outer iteration; its `objective` is Eq. 4's objective.
#include <memory>
#include <string_view>

#include "solvers/interior_gauss_newton.hpp"
#include "solvers/solver.hpp"

namespace tensegrity {

// The faithful variant's outer-iteration budget when SolveOptions::max_iterations
// is 0. Algorithm 1 itself has no cap (it stops on epsilon_cvg) and its outer
// iterations are cheap (a warm stress QP, typically one or two
// factorizations, and at most i_max matrix-free gradient steps), but steepest
// descent crawls: on the perturbed characters at 3-10 % node noise the
// faithful scheme needs thousands of outer iterations; with crawl_i_max =
// 100 it runs ~900 per second on scorpion at 10 % noise and several
// thousand per second on small prisms, so the common 2000 stopped it short
// and 20000 (sessions 5-7) stopped prisms at 30 % noise after 1-2 s, well
// before their time limit. The time limit bounds it too.
inline constexpr int kFaithfulIterationBudget = 100000;

// The faithful variant's line-search rule (see above).
enum class FaithfulStepLength { Cauchy, Sdc, Adaptive };

struct AlternatingOptions {
  // Faithful variant (Algorithm 1).
  double gamma = 0.05;           // distance budget per outer iteration, in units of L
  int i_max = 50;                // inner gradient steps per outer iteration
  FaithfulStepLength step_length = FaithfulStepLength::Adaptive;
  int crawl_window = 200;        // adaptive: outer iterations over which (<= 10000) ...
  double crawl_ratio = 0.8;      // ... the objective must fall below this factor (in (0, 1]), else SDC steps
  int crawl_i_max = 100;         // adaptive: inner steps per outer iteration once SDC steps began (<= 10000)
  int sdc_cauchy_steps = 4;      // SDC cycle: Cauchy steps (>= 2: Yuan's step needs two) ...
  int sdc_constant_steps = 4;    // ... then steps that try Yuan's step (>= 1)
  bool qp_proximal = true;       // warm stress solves centre mu on the previous forces (StressQpOptions::proximal)
  // Both variants.
  double epsilon_cvg = 1e-12;    // stall: outer position update below this (units of L)
  double mu = 1e-10;             // stress QP regulariser (StressQpOptions::mu)
  double margin = 0.0;           // sign margin / F0; 0 = SolveOptions::margin_fraction
  // Gauss-Newton variant.
  double max_step = 0.25;        // trust radius: largest node move per step (units of L)
  double sigma_weight = 10.0;    // weight of force changes in the joint step (0: positions only)
  double lambda = 1e-8;          // initial LM damping, relative to the mean diagonal of J W J^T
  bool qp_every_step = false;    // run the stress QP after every step, not only when a sign bound is crossed
  bool qp_on_crossing = false;   // run it when a force would cross its bound (else: clip, hold it there)
  bool move_bound_forces = false;  // let forces held at a sign bound move in the joint step
  bool anchor = true;            // try the step anchored at the input geometry first (see above)
  int restarts = 5;              // after a stall, runs again from the input with sigma_weight x10,
                                 // lambda x1e5, sigma_weight x3, max_step x0.2, sigma_weight x0.1
  // Gauss-Newton variant: the interior attempt that runs first
  // (interior_gauss_newton.hpp; interior.max_iterations = 0 skips it).
  InteriorGaussNewtonOptions interior;
};

// Reads the backend options ("gamma", "i_max", "step_length" (adaptive|cauchy|sdc),
// "crawl_window", "crawl_ratio", "crawl_i_max",
// "sdc_cauchy_steps", "sdc_constant_steps", "qp_proximal", "epsilon_cvg",
// "mu", "margin";
// with gauss_newton also "max_step", "sigma_weight", "lambda", "qp_every_step",
// "qp_on_crossing", "move_bound_forces", "anchor", "restarts", and for the
// interior attempt "interior_iterations", "interior_force_weight",
// "interior_boundary_fraction", "interior_anchor_until"). Throws
// InputError for unknown keys or malformed values.
AlternatingOptions read_alternating_options(const SolveOptions& options, bool gauss_newton);

class AlternatingSolver : public Solver {
 public:
  explicit AlternatingSolver(bool gauss_newton) : gauss_newton_(gauss_newton) {}
  std::string_view name() const override { return gauss_newton_ ? "alternating-gn" : "alternating"; }
  SolveResult solve_part(const Structure& part, const SolveOptions& options) const override;
  void check_options(const SolveOptions& options) const override;
  // Same with the options already parsed (tests, benchmarks, sweeps).
  SolveResult solve_part(const Structure& part, const SolveOptions& options,
                         const AlternatingOptions& alternating) const;

 private:
  bool gauss_newton_;
};

std::unique_ptr<Solver> make_alternating_solver();
std::unique_ptr<Solver> make_alternating_gn_solver();

}  // namespace tensegrity
