#pragma once
// The paper's alternating scheme (Sec. 3, Algorithm 1) as two backends that
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
//   dx = s d, d = -g / |g|, g = (df/dx)^T f, each step length s found by a
//   line search on Eq. 4's objective at fixed sigma that accepts only an
//   Armijo decrease, capped by gamma_acc; gamma_acc -= s. g and J d are
//   matrix-free products (J is symmetric); J is never assembled.
//   The paper leaves the line search open; step_length chooses the first
//   trial: `cauchy` (minimiser of the linearised |f + s J d|^2, then halving),
//   `sdc` (the monotone SDC rule of De Asmundis, di Serafino, Hager, Toraldo
//   and Zhang 2014: Cauchy steps alternating with Yuan's constant steps, which
//   breaks steepest descent's zigzag), or `adaptive` (Cauchy steps until Eq. 4's
//   objective stops falling by crawl_ratio over crawl_window outer iterations,
//   then SDC steps with at most crawl_i_max inner steps per outer iteration).
//   Cauchy steps come first because they move the geometry least, which is
//   what Eq. 5 asks for. Warm stress solves are centred on the previous forces
//   (qp_proximal): the paper's weak regulariser pulls towards zero forces, which
//   on near-mechanisms moves many forces along near-null directions of A at
//   every solve; centred on the previous forces a re-solve only corrects the
//   residual.
//
// "alternating-gn": the position phase is one damped Gauss-Newton
//   (Levenberg-Marquardt) step, by default a joint step in z = (q, sigma) with
//   the minimum weighted norm, dz = -W J^T (J W J^T + lambda I)^{-1} r, in
//   units of L and F0; W weighs positions 1, forces sigma_weight and forces at
//   their sign bound 0. A force that would cross its bound is clipped and held
//   (qp_on_crossing: run the stress QP instead). Node moves are capped by a
//   trust radius max_step * L; a trial is accepted only if Eq. 4's objective
//   decreases. J W J^T is assembled into a fixed pattern and factorized by a
//   sparse LDLT analysed once per part. The step anchored at the input geometry
//   (towards Eq. 5's minimal change) is tried first. An interior-point attempt
//   (interior_gauss_newton.hpp) runs before it; a run that stalls (objective
//   not below stall_ratio of its value stall_window outer iterations earlier)
//   restarts from the input with other step weights (restarts).
//
// Both: Eq. 4's objective never increases from one outer iteration to the
// next. Lengths are relative to the part's mean element length L and forces to
// F0 (force_scale.hpp), so a scaled scene gives the same iterates scaled.
// Stalled is a stop at a local minimum of Eq. 4 with a non-zero residual (the
// paper notes it can happen): no proof that no tensegrity exists. One
// TracePoint per outer iteration; its `objective` is Eq. 4's objective.
#include <Eigen/Core>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

#include "solvers/alternating/interior_gauss_newton.hpp"
#include "solvers/solver.hpp"

namespace tensegrity {

// The faithful variant's outer-iteration budget when SolveOptions::max_iterations
// is 0. Algorithm 1 has no cap of its own (it stops on epsilon_cvg) and its
// outer iterations are cheap, so the time limit is what usually bounds it.
inline constexpr int kFaithfulIterationBudget = 100000;

// Restarts of a stalled Gauss-Newton run (the length of its schedule).
inline constexpr int kMaxRestarts = 5;

enum class FaithfulStepLength { Cauchy, Sdc, Adaptive };

// Options of both variants. Lengths in units of L, forces in units of F0.
struct AlternatingOptions {
  // Faithful variant (Algorithm 1).
  double gamma = 0.05;           // distance budget per outer iteration
  int i_max = 50;                // inner gradient steps per outer iteration
  FaithfulStepLength step_length = FaithfulStepLength::Adaptive;
  int crawl_window = 200;        // adaptive: outer iterations over which ...
  double crawl_ratio = 0.8;      // ... the objective must fall below this factor, else SDC steps
  int crawl_i_max = 100;         // adaptive: inner steps per outer iteration once SDC steps began
  int sdc_cauchy_steps = 4;      // SDC cycle: Cauchy steps (Yuan's step needs two) ...
  int sdc_constant_steps = 4;    // ... then steps that try Yuan's step
  bool qp_proximal = true;       // warm stress solves centre mu on the previous forces
  // Both variants.
  double epsilon_cvg = 1e-12;    // stop: outer position update below this
  double mu = 1e-10;             // stress QP regulariser (StressQpOptions::mu)
  double margin = 0.0;           // sign margin / F0; 0 = SolveOptions::margin_fraction
  // Gauss-Newton variant.
  double max_step = 0.25;        // trust radius: largest node move per step
  double sigma_weight = 10.0;    // weight of force changes in the joint step (0: positions only)
  double lambda = 1e-8;          // initial LM damping, relative to the mean diagonal of J W J^T
  bool qp_every_step = false;    // run the stress QP after every step
  bool qp_on_crossing = false;   // run it when a force would cross its bound (else: clip, hold it)
  bool move_bound_forces = false;  // let forces held at a sign bound move in the joint step
  bool anchor = true;            // try the step anchored at the input geometry first
  int restarts = 5;              // runs after a stall, with the weights of the restart schedule
  int stall_window = 200;        // a run has stalled when its objective is not below ...
  double stall_ratio = 0.9;      // ... this factor of its value stall_window outer iterations earlier
  InteriorGaussNewtonOptions interior;  // interior.max_iterations = 0 skips the interior attempt
  // The second interior attempt, when the first does not converge on a part
  // of at least interior_retry_elements elements (below that the fallback's
  // stress QP is cheap and finds smaller geometry changes);
  // interior_retry.max_iterations = 0 skips it.
  InteriorGaussNewtonOptions interior_retry = patient_interior_options();
  int interior_retry_elements = 4000;
  // The last attempt, when the alternating runs do not converge either; the
  // runs leave it interior_last_resort.max_iterations of the iteration budget
  // (at most a tenth). interior_last_resort.max_iterations = 0 skips it.
  InteriorGaussNewtonOptions interior_last_resort = stiff_force_interior_options();

  bool IsValid(std::string* why = nullptr) const;
};

// `--option` keys of `alternating`: gamma, i_max, step_length
// (adaptive|cauchy|sdc), crawl_window, crawl_ratio, crawl_i_max,
// sdc_cauchy_steps, sdc_constant_steps, qp_proximal, epsilon_cvg, mu, margin.
struct FaithfulAlternatingOptions : AlternatingOptions {
  static FaithfulAlternatingOptions FromPairs(const OptionPairs& pairs);
};

// `--option` keys of `alternating-gn`: max_step, sigma_weight, lambda,
// qp_every_step, qp_on_crossing, move_bound_forces, anchor, restarts,
// stall_window, stall_ratio, interior_iterations, interior_force_weight,
// interior_boundary_fraction, interior_anchor_until, interior_retry_iterations,
// interior_retry_elements, interior_last_resort_iterations, epsilon_cvg, mu,
// margin.
struct GaussNewtonAlternatingOptions : AlternatingOptions {
  static GaussNewtonAlternatingOptions FromPairs(const OptionPairs& pairs);
};

// What a part solve did beyond the common result fields: the solution file's
// "details" (docs/FORMATS.md lists the keys). A non-optimal stress solve is
// one whose QP stopped before certifying its KKT conditions (iteration cap,
// numerical failure); the scheme then keeps the better of its warm start and
// the QP's forces.
struct AlternatingDetails : SolverDetails {
  bool gauss_newton = false;          // which variant: selects the keys written
  int stress_solves = 0;              // stress QP (Eq. 4) solves, all runs
  int non_optimal_stress_solves = 0;  // of them, not certified optimal
  int stalls = 0;                     // runs stopped by the stall test
  // alternating: the outer iteration SDC steps began at (adaptive step lengths), -1: never.
  int sdc_from_iteration = -1;
  // alternating-gn: runs after the first (restarts from the input geometry) and
  // the steps of the interior attempt (0 when skipped).
  int restarts = 0;
  int interior_iterations = 0;
  // Under gravity: the free run converged above the prestress cap, and the
  // answer comes from a run with the cable sum held at the cap.
  bool held_at_prestress_cap = false;

  // Adds the counters of one Gauss-Newton run (a restart unless it is the first).
  void add_run(const AlternatingDetails& run, bool restart);
  nlohmann::json to_json() const override;
};

class AlternatingSolver : public SolverWithOptions<FaithfulAlternatingOptions> {
 public:
  std::string_view name() const override { return "alternating"; }

 protected:
  SolveResult DoSolve(const PartProblem& problem, const FaithfulAlternatingOptions& options) const override;
};

class AlternatingGnSolver : public SolverWithOptions<GaussNewtonAlternatingOptions> {
 public:
  std::string_view name() const override { return "alternating-gn"; }

 protected:
  SolveResult DoSolve(const PartProblem& problem, const GaussNewtonAlternatingOptions& options) const override;
};

// One part with parsed options, for tests and benchmarks that sweep option
// values without going through the driver (no prechecks, no verification).
SolveResult solve_faithful_part(const Structure& part, const SolveOptions& options,
                                const AlternatingOptions& alternating);
SolveResult solve_gauss_newton_part(const Structure& part, const SolveOptions& options,
                                    const AlternatingOptions& alternating);

std::unique_ptr<Solver> make_alternating_solver();
std::unique_ptr<Solver> make_alternating_gn_solver();

}  // namespace tensegrity
