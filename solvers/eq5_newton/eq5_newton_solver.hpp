#pragma once
// The `eq5-newton` backend: alternating-gn's equilibrium, then Newton steps on
// the KKT conditions of Eq. 5 (formulations/minimal_geometry_change_nlp.hpp)
// from there, so that the answer is a local optimum of the geometry change.
//
//   1. alternating-gn (solvers/alternating) with its default options reaches
//      a verified equilibrium from the scene. When it does not (stalled, out
//      of its default budget), the polish below starts from its last
//      iterate, and when that polish is not kept, from the scene's geometry
//      with the stress QP's forces there (fallback_starts). Where neither is
//      kept, or alternating-gn ran out of time, spent an iteration budget the
//      caller set or proved the part infeasible, its result is the answer.
//   2. A primal-dual interior-point Newton method (interior_newton.hpp) on the
//      dimensionless Eq. 5 (scaled_eq5.hpp) starts from that equilibrium: the
//      objective still measures the change from the scene, and under gravity
//      the mean cable force is at most Eq. 5's kappa n_c W (prestress=cap,
//      a bound with its own slack; when that polish came close, KKT error
//      below 1e-6, but was not kept, a second one holds it there) or held
//      there (prestress=equal).
//   3. The Newton answer is kept when it is closer to the scene than the
//      start (any answer, where the start is no equilibrium) and either its
//      KKT test passed and model/verify accepts it, or the stationary stop
//      of interior_newton.hpp ended it (the objective stopped changing while
//      the KKT error crawled) and its last iterate, projected onto the
//      constraints, verifies (`polish: objective_stationary`, an approximate
//      local optimum), or, when no polish does either, its line search
//      stalled or its budget ran out and the last iterate, projected the
//      same way, verifies (`polish: stalled_projected` or
//      `max_iterations_projected`, a closer equilibrium, not a local
//      optimum); otherwise the answer is alternating-gn's result, and the
//      details say why the polish was not kept. Where the answer is not a
//      (approximate) local optimum, the Newton iterate closest to the scene
//      that verifies, of any polish, replaces it when it is closer
//      (`polish: closest_iterate`, an equilibrium, not a local optimum).
//   4. A kept polish that ended at its projected last iterate (stalled or
//      out of budget) is followed by fresh polishes from that point (new
//      barrier, multipliers and filter), up to `restarts`, while each is
//      kept and the last gained at least 1 % of the geometry change.
//
// Options (`--option key=value`): newton_iterations (1 .. 100000, default
// 1000: far from the optimum, on towers without gravity, a polish takes
// hundreds), initial_barrier (mu at the start, (0, 1), default 1e-6),
// optimality_tolerance (dual infeasibility and complementarity, (0, 1),
// default 1e-10), proximal_weight (rho on the forces, (0, 1), default 1e-10;
// when that polish is not kept on a part below 4000 elements it is retried
// once at 1e-8),
// barrier (mehrotra | monotone: the barrier parameter's rule, default mehrotra),
// prestress (cap | equal: under gravity the cable-sum row bounded above by
// kappa n_c W, or held at it; default cap, as the other backends),
// stationary_stop (on | off: the stationary stop above, default on),
// restarts (0 .. 100, default 5: the fresh polishes of step 4, each with
// its own newton_iterations), fallback_starts (on | off: the polishes of
// step 1 without alternating-gn's equilibrium, default on),
// regularised_steps (retry | on | off: the steps keep the KKT matrix's
// delta_c instead of refining it away) and progress_filter (retry | on |
// off: Mehrotra's rule falls back to the monotone one where a point makes
// no progress), interior_newton.hpp. With `retry`, the default of both, the
// polishes of steps 1, 2 and 4 run again with the safeguard on parts below
// 4000 elements where they reached no (approximate) local optimum, first
// with regularised steps, then with the progress filter, and the better
// answer is kept.
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

#include "solvers/solver.hpp"

namespace tensegrity {

// A safeguard of the polish (interior_newton.hpp): never, in a further run
// of the polishes where those before reached no optimum, or in every polish.
enum class Safeguard { Off, Retry, On };

struct Eq5NewtonOptions {
  int newton_iterations = 1000;
  double initial_barrier = 1e-6;
  double optimality_tolerance = 1e-10;
  double proximal_weight = 1e-10;
  bool predictor_corrector = true;
  bool prestress_cap = true;  // false: the mean cable force held at the cap (prestress=equal)
  bool stationary_stop = true;
  int restarts = 5;
  bool fallback_starts = true;
  Safeguard regularised_steps = Safeguard::Retry;
  Safeguard progress_filter = Safeguard::Retry;

  static Eq5NewtonOptions FromPairs(const OptionPairs& pairs);
  bool IsValid(std::string* why = nullptr) const;
};

// The solution file's "details" of an eq5-newton part solve (docs/FORMATS.md).
struct Eq5NewtonDetails : SolverDetails {
  int start_iterations = 0;          // alternating-gn's iterations
  double start_geometry_change = 0;  // of alternating-gn's equilibrium (m)
  // "kept": the Newton answer is the result; "objective_stationary": the
  // projected iterate of the stationary stop is; "stalled_projected",
  // "max_iterations_projected": the projected last iterate of a polish that
  // stalled or spent its budget is; "closest_iterate": the closest
  // verified Newton iterate is; "not_run": alternating-gn
  // did not converge; otherwise the Newton stop that was not kept
  // ("max_iterations", "stalled", "numerical_error", "time_limit",
  // "rejected_by_verification", "farther_than_start": a local optimum no
  // closer to the scene than alternating-gn's equilibrium).
  std::string polish = "not_run";
  int newton_iterations = 0;
  int factorizations = 0;
  int inertia_corrections = 0;
  int second_order_corrections = 0;
  double dual_infeasibility = 0;     // dimensionless KKT residuals at the last Newton point
  double constraint_violation = 0;
  double complementarity = 0;
  // Under gravity with prestress=cap: kappa n_c W - c^T sigma at the answer
  // (N; 0 when the cap binds), negative when not applicable.
  double prestress_cap_slack = -1.0;
  // With prestress=cap: the polish with the cap as a bound was not kept, and a
  // second one held the mean cable force at the cap (the counts above sum both).
  bool prestress_held = false;
  // The polish with proximal_weight below 1e-8 was not kept and was run again
  // with 1e-8 (the counts above sum both).
  bool steady_retry = false;
  // Fresh polishes started from the projected last iterate of a polish that
  // stalled or spent its budget (the counts above sum them all).
  int restarts = 0;
  // Where the polishes started: "equilibrium" (alternating-gn's), or, where
  // alternating-gn ended without one, "last_iterate" (its last iterate) or
  // "scene" (the scene's geometry with its stress QP's forces); empty when no
  // polish ran. With "last_iterate" and "scene" it is that of the answer's
  // polish; a closest_iterate answer can come from either.
  std::string polish_start;
  // The polish from the scene's geometry ran (its counts are in the sums above).
  bool scene_polish = false;
  // No polish reached a (approximate) local optimum, and the polishes ran
  // again with regularised steps (regularised_retry), then also with the
  // progress filter (progress_retry); the counts above sum every run, and
  // polish_start is that of the run whose answer stays.
  bool regularised_retry = false;
  bool progress_retry = false;
  nlohmann::json to_json() const override;
};

class Eq5NewtonSolver : public SolverWithOptions<Eq5NewtonOptions> {
 public:
  std::string_view name() const override { return "eq5-newton"; }

 protected:
  SolveResult DoSolve(const PartProblem& problem, const Eq5NewtonOptions& options) const override;
};

std::unique_ptr<Solver> make_eq5_newton_solver();

}  // namespace tensegrity
