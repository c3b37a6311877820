#include "solvers/eq5_newton/eq5_newton_solver.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include "formulations/equilibrium.hpp"
#include "formulations/force_scale.hpp"
#include "formulations/minimal_geometry_change_nlp.hpp"
#include "kernels/stress_qp.hpp"
#include "model/verify.hpp"
#include "solvers/eq5_newton/interior_newton.hpp"
#include "solvers/eq5_newton/scaled_eq5.hpp"
#include "solvers/option_reader.hpp"
#include "solvers/trace_recorder.hpp"

namespace tensegrity {
namespace {

constexpr int kLargestNewtonIterations = 100000;
// A capped polish that ends with a KKT error below this (dimensionless) came
// close: the held one is tried next. One that ends far off is not retried, so
// a hopeless polish on a large scene costs its budget once.
constexpr double kCameCloseKktError = 1e-6;
// The proximal weight of the retry when a polish with a smaller one is not kept.
constexpr double kSteadyProximalWeight = 1e-8;
// Parts from this many elements get no such retry, nor the retries with a
// safeguard: on the gravity tower family from 4,640 elements the polish is
// kept with neither weight, after tens of seconds each.
constexpr int kRetryElements = 4000;
// A polish that stalls or spends its budget far from its optimum ends at its
// projected last iterate; a fresh polish from there (new barrier, multipliers
// and filter) often gets much closer. Each only after one that gained at
// least this share of the geometry change; at most this many (the option's range).
constexpr double kRestartGain = 1e-2;
constexpr int kLargestRestarts = 100;
// A converged polish whose objective exceeds the start's by more than this
// share ended at a local optimum farther from the scene (farther_than_start).
constexpr double kFartherObjective = 1e-6;
// ... and by more than this (dimensionless |q - q0|^2 / L^2: a change of 1e-6
// mean element lengths), for a start at the scene itself.
constexpr double kFartherObjectiveFloor = 1e-12;

// details.polish_start's values.
constexpr const char* kFromEquilibrium = "equilibrium";
constexpr const char* kFromLastIterate = "last_iterate";
constexpr const char* kFromScene = "scene";

std::string polish_name(Status s) {
  switch (s) {
    case Status::MaxIterations: return "max_iterations";
    case Status::TimeLimit: return "time_limit";
    case Status::Stalled: return "stalled";
    case Status::Converged: return "kept";
    default: return "numerical_error";
  }
}

// alternating-gn from the part's geometry with its default options (the
// driver has checked the part already, so without the shortcut).
SolveResult equilibrium_start(const Structure& part, const SolveOptions& options) {
  SolveOptions start_options = options;
  start_options.backend_options.clear();
  start_options.verbose = false;
  return make_solver("alternating-gn")->Solve(part, start_options, DriverControls{false});
}

TracePoint trace_point(const Verification& v, int iteration, double objective) {
  TracePoint p;
  p.iteration = iteration;
  p.evaluations = iteration;
  p.residual = v.residual;
  p.relative_residual = v.relative_residual;
  p.geometry_change = v.geometry_change;
  p.objective = objective;
  return p;
}

// Whether alternating-gn's equilibrium satisfies the cable-sum row of the
// Eq. 5 the user asked for: without a load its forces scale onto the
// normalisation; under gravity its level is the load's, within the cap or
// not, and a held row (prestress=equal) it meets only by chance. Only then
// is an optimum farther from the scene a worse answer than the start, also
// the held polish that stands in for the capped one.
bool start_is_a_point_of_eq5(const ForceScale& scale, bool prestress_cap, const Eigen::VectorXd& start_forces) {
  if (!scale.has_prestress_cap()) return true;
  return prestress_cap && !exceeds_prestress_cap(scale, start_forces);
}

// The iterate closest to the scene that model/verify accepts, over every
// polish of a solve: where no polish ends at a (approximate) local optimum
// its iterates can still pass equilibria much closer than the start (the
// octahedron grid: 1.82 m against alternating-gn's 2.65 m).
struct ClosestIterate {
  bool found = false;
  Eigen::Matrix3Xd positions;
  Eigen::VectorXd forces;
  Verification check;

  void offer(const Eigen::Matrix3Xd& p, const Eigen::VectorXd& f, const Verification& v) {
    if (!v.ok || (found && v.geometry_change >= check.geometry_change)) return;
    found = true;
    positions = p;
    forces = f;
    check = v;
  }
};

// One Newton polish from alternating-gn's equilibrium, with its answer
// verified when the Newton test passed.
struct PolishRun {
  InteriorNewtonOutcome outcome;
  bool cap_slack = false;          // the cap was a bound (with its slack)
  bool verified_rejected = false;  // the Newton test passed, model/verify did not
  // The Newton test passed at a local optimum no closer to the scene than
  // alternating-gn's equilibrium (a long polish can wander to another one),
  // where that equilibrium is itself a point of this Eq. 5.
  bool farther_than_start = false;
  Eigen::Matrix3Xd positions;
  Eigen::VectorXd forces;
  Verification check;
  double objective = 0.0;
  // The projected iterate of the stationary stop, or of a polish that
  // stalled or spent its budget, verified and is closer to the scene than
  // alternating-gn's equilibrium (interior_newton.hpp).
  bool projected = false;
  // What it ran with, for a restart from its answer.
  Eq5NewtonOptions settings;
  PrestressRow row = PrestressRow::Equal;
  // Projected after a stall or at the budget: a closer equilibrium, not a KKT point.
  bool last_iterate_projected() const { return projected && outcome.last_iterate_projected; }
  bool kept() const {
    return (outcome.status == Status::Converged || projected) && !verified_rejected && !farther_than_start;
  }
};

// The polish of Eq. 5 with the cable-sum row `row`; every accepted step is
// recorded after the records already in `recorder`.
PolishRun polish(const Structure& part, const SolveOptions& options, const Eq5NewtonOptions& newton,
                 const ForceScale& scale, PrestressRow row, const SolveResult& start, bool start_balances,
                 TraceRecorder& recorder, ClosestIterate& closest) {
  MinimalGeometryChangeNlp nlp(part, scale, row);
  ScaledEq5 problem(nlp);
  Eigen::VectorXd z0(nlp.num_variables());
  z0.head(nlp.num_positions()) = nlp.equilibrium().free_nodes().gather(start.positions);
  z0.tail(nlp.num_forces()) = start.forces;

  // docs/FORMATS.md (Solution file) asks |f_i| <= tolerance * load scale (the largest free-node
  // weight under gravity, else max |sigma| >= F0); the Newton test bounds
  // |f / F0|_inf, a tenth of that for the three components of a node.
  const double max_free_weight = part.max_free_node_weight();
  const double load_over_force =
      max_free_weight > 0.0 ? std::min(1.0, max_free_weight / scale.reference_force) : 1.0;
  InteriorNewtonSettings settings;
  settings.max_iterations = newton.newton_iterations;
  settings.optimality_tolerance = newton.optimality_tolerance;
  settings.constraint_tolerance = 0.1 * options.tolerance * load_over_force / std::sqrt(3.0);
  settings.initial_barrier = newton.initial_barrier;
  settings.proximal_weight = newton.proximal_weight;
  settings.predictor_corrector = newton.predictor_corrector;
  settings.progress_filter = newton.progress_filter == Safeguard::On;
  settings.regularised_steps = newton.regularised_steps == Safeguard::On;
  settings.stationary_stop = newton.stationary_stop;
  settings.time_limit_s = std::max(0.0, options.time_limit_s - recorder.seconds());

  PolishRun run;
  run.cap_slack = problem.has_cap_slack();
  run.settings = newton;
  run.row = row;
  auto positions_and_forces = [&](const Eigen::VectorXd& y) {
    const Eigen::VectorXd z = problem.to_si(y);
    run.positions = nlp.positions(z);
    run.forces = nlp.forces(z);
  };
  const int first_record = static_cast<int>(recorder.trace().size()) - 1;
  run.outcome =
      solve_interior_newton(problem, problem.to_scaled(z0), settings, [&](int iteration, const Eigen::VectorXd& y) {
        positions_and_forces(y);
        const Verification v = verify(part, run.positions, run.forces, options.tolerance);
        closest.offer(run.positions, run.forces, v);
        recorder.record(trace_point(v, first_record + iteration, problem.objective(y)));
      });
  const bool stationary = run.outcome.stationary_projected || run.outcome.last_iterate_projected;
  if (run.outcome.status != Status::Converged && !stationary) return run;
  positions_and_forces(run.outcome.y);
  run.check = verify(part, run.positions, run.forces, options.tolerance);
  run.objective = problem.objective(run.outcome.y);
  // Never farther than the start: a point that is not closer to the scene
  // than alternating-gn's equilibrium is not an answer (where the start is
  // no equilibrium, every verified point is).
  const double start_objective = problem.objective(problem.to_scaled(z0));
  const bool closer = !start_balances || run.objective < start_objective;
  if (stationary) {
    run.projected = run.check.ok && closer;
    return run;
  }
  run.verified_rejected = !run.check.ok;
  // Where alternating-gn already ends at the optimum the two agree only to
  // the polish's tolerance, so only an optimum farther by more is a worse one.
  const bool clearly_farther =
      run.objective > (1.0 + kFartherObjective) * start_objective + kFartherObjectiveFloor;
  run.farther_than_start = start_balances && run.check.ok && clearly_farther &&
                           start_is_a_point_of_eq5(scale, newton.prestress_cap, start.forces);
  return run;
}

// A kept polish that ended at a local optimum or at the stationary stop's
// approximate one, not at a projected last iterate.
bool reached_optimum(const PolishRun& run) { return run.kept() && !run.last_iterate_projected(); }

bool came_close(const InteriorNewtonOutcome& outcome) {
  return std::max({outcome.dual_infeasibility, outcome.constraint_violation, outcome.complementarity}) <
         kCameCloseKktError;
}

// Counts summed over the polishes; the KKT residuals are the last one's.
void add_counts(const InteriorNewtonOutcome& outcome, Eq5NewtonDetails& details) {
  details.newton_iterations += outcome.iterations;
  details.factorizations += outcome.factorizations;
  details.inertia_corrections += outcome.inertia_corrections;
  details.second_order_corrections += outcome.second_order_corrections;
  details.dual_infeasibility = outcome.dual_infeasibility;
  details.constraint_violation = outcome.constraint_violation;
  details.complementarity = outcome.complementarity;
}

// The multipliers of a KKT point in the NLP's terms (solver.hpp): the
// scaled rows and force bounds both carry 1 / F0. Not of the stationary
// stop's approximate optimum, whose residual dual infeasibility sends Ipopt
// along the forces' nearly free directions.
void record_multipliers(const PolishRun& run, double reference_force, Eq5NewtonDetails& details) {
  details.eq5_row_multipliers = run.outcome.lambda / reference_force;
  details.eq5_force_bound_multipliers = run.outcome.bound_multipliers.head(run.forces.size()) / reference_force;
}

// The KKT residuals of an earlier polish whose answer stays (the counts keep summing).
void keep_residuals(const Eq5NewtonDetails& earlier, Eq5NewtonDetails& details) {
  details.dual_infeasibility = earlier.dual_infeasibility;
  details.constraint_violation = earlier.constraint_violation;
  details.complementarity = earlier.complementarity;
}

// A verified Newton answer as the solve's result, with the trace so far.
SolveResult verified_answer(std::string message, const Eigen::Matrix3Xd& positions, const Eigen::VectorXd& forces,
                            const Verification& check, TraceRecorder& recorder,
                            std::shared_ptr<Eq5NewtonDetails> details) {
  SolveResult result;
  result.status = Status::Converged;
  result.message = std::move(message);
  result.positions = positions;
  result.forces = forces;
  result.trace = std::move(recorder.trace());
  result.stats.iterations = static_cast<int>(result.trace.size()) - 1;
  result.stats.seconds = recorder.seconds();
  result.stats.residual = check.residual;
  result.stats.relative_residual = check.relative_residual;
  result.stats.geometry_change = check.geometry_change;
  result.details = {std::move(details)};
  return result;
}

// Replaces `run`, a kept polish that ended at its projected last iterate, by
// fresh polishes from that point with the same settings and cable-sum row
// while each is kept (a verified answer closer than its start), time is left
// and the last one gained kRestartGain; stops at the first local optimum.
void restart_from_projected_points(const Structure& part, const SolveOptions& options, const ForceScale& scale,
                                   TraceRecorder& recorder, ClosestIterate& closest, Eq5NewtonDetails& details,
                                   PolishRun& run) {
  double gain = 1.0;
  for (int r = 0; r < run.settings.restarts && run.kept() && run.last_iterate_projected() && gain >= kRestartGain &&
                  recorder.seconds() < options.time_limit_s;
       ++r) {
    SolveResult from;
    from.positions = run.positions;
    from.forces = run.forces;
    const Eq5NewtonDetails before = details;
    constexpr bool kVerifiedStart = true;  // the kept run's projected point
    PolishRun next = polish(part, options, run.settings, scale, run.row, from, kVerifiedStart, recorder, closest);
    add_counts(next.outcome, details);
    ++details.restarts;
    if (!next.kept()) {
      keep_residuals(before, details);
      return;
    }
    gain = 1.0 - next.check.geometry_change / run.check.geometry_change;
    run = std::move(next);
  }
}

// Where the polish that gave the answer started, for its message.
std::string polish_start_description(const Eq5NewtonDetails& details, const SolveResult& start) {
  const std::string iterations = std::to_string(details.start_iterations) + " iterations";
  if (details.polish_start == kFromEquilibrium) return "alternating-gn's equilibrium (" + iterations + ")";
  const std::string how = iterations + ", " + start.message;
  const std::string scene = "the scene's geometry with its stress QP's forces";
  if (details.polish_start == kFromScene) return scene + " (" + how + ")";
  return "alternating-gn's last iterate" + (details.scene_polish ? ", then " + scene : std::string()) + " (" + how +
         ")";
}

// The stress QP's forces at the scene's geometry, with Eq. 5's own
// cable-sum row (under gravity the mean cable force held at the cap), so
// that the start meets that row; `fallback` when the QP gives no finite forces.
Eigen::VectorXd scene_forces(const Structure& part, const ForceScale& scale, const Eigen::VectorXd& fallback) {
  const Equilibrium eq(part);
  StressQp qp(eq, scale.has_prestress_cap() ? held_at_prestress_cap(scale) : scale);
  StressQpResult r = qp.solve(Eigen::VectorXd());
  if (r.sigma.size() != part.num_elements() || !r.sigma.allFinite()) return fallback;
  return std::move(r.sigma);
}

// Whether a polish runs although alternating-gn ended without a verified
// equilibrium: the interior Newton method needs no feasible start, only a
// finite one, and time left. Not after a proof of infeasibility, nor when
// alternating-gn spent an iteration budget the caller set (that budget is
// the whole solve's).
bool polishes_without_equilibrium(const Eq5NewtonOptions& newton, const SolveResult& start,
                                  const SolveOptions& options, double seconds) {
  const bool callers_budget_spent = start.status == Status::MaxIterations && options.max_iterations > 0;
  return newton.fallback_starts && start.status != Status::Infeasible && start.status != Status::TimeLimit &&
         !callers_budget_spent && seconds < options.time_limit_s && start.positions.allFinite() &&
         start.forces.allFinite() && start.forces.size() > 0;
}

// The closest verified iterate as the answer: an equilibrium closer to the
// scene than every other candidate, not a local optimum.
SolveResult closest_iterate_result(const ClosestIterate& closest, const std::string& polish_stop,
                                   const std::string& polish_start, TraceRecorder& recorder,
                                   std::shared_ptr<Eq5NewtonDetails> details) {
  const bool from_equilibrium = details->polish_start == kFromEquilibrium;
  std::string message = std::string(from_equilibrium ? "equilibrium closer to the scene than alternating-gn's"
                                                     : "equilibrium") +
                        ", not a local optimum of Eq. 5: the closest verified Newton iterate (the polish stopped: " +
                        polish_stop + ") of " + std::to_string(details->newton_iterations) +
                        " Newton iterations from " + polish_start;
  recorder.record(trace_point(closest.check, static_cast<int>(recorder.trace().size()), 0.0));
  return verified_answer(std::move(message), closest.positions, closest.forces, closest.check, recorder,
                         std::move(details));
}

Safeguard read_safeguard(OptionReader& reader, const char* key) {
  const std::string value = reader.choice(key, "retry", {"retry", "on", "off"});
  return value == "on" ? Safeguard::On : value == "off" ? Safeguard::Off : Safeguard::Retry;
}

}  // namespace

Eq5NewtonOptions Eq5NewtonOptions::FromPairs(const OptionPairs& pairs) {
  OptionReader reader(pairs, "eq5-newton");
  Eq5NewtonOptions o;
  o.newton_iterations = reader.integer("newton_iterations", o.newton_iterations, 1, kLargestNewtonIterations);
  o.initial_barrier = reader.number("initial_barrier", o.initial_barrier, ValueRange::open(0.0, 1.0));
  o.optimality_tolerance =
      reader.number("optimality_tolerance", o.optimality_tolerance, ValueRange::open(0.0, 1.0));
  o.proximal_weight = reader.number("proximal_weight", o.proximal_weight, ValueRange::open(0.0, 1.0));
  o.predictor_corrector = reader.choice("barrier", "mehrotra", {"mehrotra", "monotone"}) == "mehrotra";
  o.prestress_cap = reader.choice("prestress", "cap", {"cap", "equal"}) == "cap";
  o.stationary_stop = reader.choice("stationary_stop", "on", {"on", "off"}) == "on";
  o.restarts = reader.integer("restarts", o.restarts, 0, kLargestRestarts);
  o.fallback_starts = reader.choice("fallback_starts", "on", {"on", "off"}) == "on";
  o.regularised_steps = read_safeguard(reader, "regularised_steps");
  o.progress_filter = read_safeguard(reader, "progress_filter");
  reader.reject_unknown();
  return o;
}

bool Eq5NewtonOptions::IsValid(std::string* why) const {
  auto fail = [&](const char* reason) {
    if (why) *why = reason;
    return false;
  };
  if (newton_iterations < 1 || newton_iterations > kLargestNewtonIterations)
    return fail("newton_iterations must be in [1, 100000]");
  if (!(initial_barrier > 0.0 && initial_barrier < 1.0)) return fail("initial_barrier must be in (0, 1)");
  if (!(optimality_tolerance > 0.0 && optimality_tolerance < 1.0))
    return fail("optimality_tolerance must be in (0, 1)");
  if (!(proximal_weight > 0.0 && proximal_weight < 1.0)) return fail("proximal_weight must be in (0, 1)");
  if (restarts < 0 || restarts > kLargestRestarts) return fail("restarts must be in [0, 100]");
  return true;
}

nlohmann::json Eq5NewtonDetails::to_json() const {
  nlohmann::json j = {{"start_iterations", start_iterations},
                      {"start_geometry_change", start_geometry_change},
                      {"polish", polish},
                      {"newton_iterations", newton_iterations},
                      {"factorizations", factorizations},
                      {"inertia_corrections", inertia_corrections},
                      {"second_order_corrections", second_order_corrections},
                      {"dual_infeasibility", dual_infeasibility},
                      {"constraint_violation", constraint_violation},
                      {"complementarity", complementarity}};
  if (prestress_cap_slack >= 0.0) j["prestress_cap_slack"] = prestress_cap_slack;
  if (prestress_held) j["prestress_held"] = true;
  if (steady_retry) j["steady_retry"] = true;
  if (restarts > 0) j["restarts"] = restarts;
  if (!polish_start.empty()) j["polish_start"] = polish_start;
  if (scene_polish) j["scene_polish"] = true;
  if (regularised_retry) j["regularised_retry"] = true;
  if (progress_retry) j["progress_retry"] = true;
  return j;
}

SolveResult Eq5NewtonSolver::DoSolve(const PartProblem& part_problem, const Eq5NewtonOptions& newton) const {
  const Structure& part = part_problem.part;
  const SolveOptions& options = part_problem.options;
  TraceRecorder recorder(options.time_limit_s);
  auto details = std::make_shared<Eq5NewtonDetails>();

  // 1. alternating-gn's equilibrium, through the registry (backends do not
  // include each other). The nested driver reports to no observer, so its
  // records are passed on here and start this solve's trace.
  const IterationObserver* observer = current_iteration_observer();
  SolveResult start = equilibrium_start(part, options);
  if (observer != nullptr && *observer)
    for (const TracePoint& p : start.trace) (*observer)(p);
  details->start_iterations = start.stats.iterations;
  const Verification start_check = verify(part, start.positions, start.forces, options.tolerance);
  details->start_geometry_change = start_check.geometry_change;
  const int start_records = static_cast<int>(start.trace.size());
  recorder.trace() = start.trace;
  const bool start_balances = start.status == Status::Converged && start_check.ok;
  auto finish_with_start = [&](std::string why) {
    SolveResult r = std::move(start);
    r.message = std::string(start_balances ? "alternating-gn's equilibrium (" : "alternating-gn's result (") +
                r.message + "); " + why;
    r.trace = std::move(recorder.trace());
    r.stats.iterations = static_cast<int>(r.trace.size()) - 1;
    r.stats.seconds = recorder.seconds();
    r.details = {details};
    return r;
  };
  if (!start_balances && !polishes_without_equilibrium(newton, start, options, recorder.seconds()))
    return finish_with_start("no Newton polish");

  // 2. Newton on Eq. 5's KKT conditions from there. Under gravity with
  // prestress=cap, when the polish with the cap as a bound came close but was
  // not kept (a nearly active cap slows it down), a second one holds the mean
  // cable force at the cap (a point of the capped problem too), as ipopt's
  // prestress=cap also keeps the held optimum.
  const ForceScale scale = make_force_scale(part, options.margin_fraction, options.prestress_factor);
  ClosestIterate closest;
  auto polish_sequence = [&](const Eq5NewtonOptions& settings, const SolveResult& from, bool balances) {
    PolishRun run = polish(part, options, settings, scale,
                           settings.prestress_cap ? PrestressRow::Cap : PrestressRow::Equal, from, balances,
                           recorder, closest);
    add_counts(run.outcome, *details);
    details->prestress_held = false;
    if ((!run.kept() || run.last_iterate_projected()) && run.cap_slack && came_close(run.outcome)) {
      const Eq5NewtonDetails before = *details;
      PolishRun held = polish(part, options, settings, scale, PrestressRow::Equal, from, balances, recorder, closest);
      add_counts(held.outcome, *details);
      // A capped polish's projected last iterate stays unless the held one does better.
      if (!run.kept() || (held.kept() && held.check.geometry_change < run.check.geometry_change)) {
        run = std::move(held);
        details->prestress_held = true;
      } else {
        keep_residuals(before, *details);
      }
    }
    return run;
  };
  // A small proximal weight lets the forces follow the self-stresses quickly,
  // but on degenerate scenes (elements of very different lengths, nearly
  // coincident nodes) its steps can stall; there the steadier weight of
  // kSteadyProximalWeight is tried once more from the same start. Not on
  // large parts, where a polish that is not kept has already cost seconds.
  // A held polish that ended stationary is only a fallback's answer (the
  // capped optimum can lie much closer): the retry runs then too, and the
  // closer of the two answers is kept.
  auto polish_with_steady_retry = [&](const Eq5NewtonOptions& settings, const SolveResult& from, bool balances) {
    PolishRun run = polish_sequence(settings, from, balances);
    const bool stationary_fallback = run.projected && (details->prestress_held || run.last_iterate_projected());
    if ((!run.kept() || stationary_fallback) && settings.proximal_weight < kSteadyProximalWeight &&
        part.num_elements() < kRetryElements && recorder.seconds() < options.time_limit_s) {
      Eq5NewtonOptions steady = settings;
      steady.proximal_weight = kSteadyProximalWeight;
      const Eq5NewtonDetails before = *details;
      PolishRun retry = polish_sequence(steady, from, balances);
      details->steady_retry = true;
      if (stationary_fallback && !(retry.kept() && retry.check.geometry_change < run.check.geometry_change)) {
        // The first answer stays, with its own KKT residuals; the counts sum both.
        details->prestress_held = before.prestress_held;
        keep_residuals(before, *details);
      } else {
        run = std::move(retry);
      }
    }
    return run;
  };
  // Without an equilibrium to start from, the scene's own geometry with its
  // stress QP's forces (ipopt's start) is the other one: on near-degenerate
  // scenes each of the two reaches optima the other does not. Then the
  // restarts from a projected answer.
  auto polish_from_starts = [&](const Eq5NewtonOptions& settings) {
    PolishRun run = polish_with_steady_retry(settings, start, start_balances);
    details->polish_start = start_balances ? kFromEquilibrium : kFromLastIterate;
    if (!start_balances && !run.kept() && recorder.seconds() < options.time_limit_s) {
      SolveResult scene_start;
      scene_start.positions = part.positions;
      scene_start.forces = scene_forces(part, scale, start.forces);
      PolishRun from_scene = polish_with_steady_retry(settings, scene_start, false);
      details->scene_polish = true;
      if (from_scene.kept()) {
        run = std::move(from_scene);
        details->polish_start = kFromScene;
      }
    }
    restart_from_projected_points(part, options, scale, recorder, closest, *details, run);
    return run;
  };
  PolishRun run = polish_from_starts(newton);
  // Where no polish (nor restart) reached a (approximate) local optimum, the
  // same polishes once more with a safeguard (interior_newton.hpp): on
  // near-degenerate scenes they reach optima the plain polishes do not.
  auto retry_with = [&](Safeguard Eq5NewtonOptions::*safeguard, bool& ran) {
    if (newton.*safeguard != Safeguard::Retry || reached_optimum(run) ||
        part.num_elements() >= kRetryElements || recorder.seconds() >= options.time_limit_s)
      return;
    Eq5NewtonOptions guarded = newton;
    guarded.*safeguard = Safeguard::On;
    const Eq5NewtonDetails before = *details;
    PolishRun retry = polish_from_starts(guarded);
    ran = true;
    const bool better = reached_optimum(retry) ||
                        (retry.kept() && (!run.kept() || retry.check.geometry_change < run.check.geometry_change));
    if (better) {
      run = std::move(retry);
    } else {
      details->polish_start = before.polish_start;
      details->prestress_held = before.prestress_held;
      keep_residuals(before, *details);
    }
  };
  retry_with(&Eq5NewtonOptions::regularised_steps, details->regularised_retry);
  retry_with(&Eq5NewtonOptions::progress_filter, details->progress_retry);
  details->polish = run.verified_rejected          ? "rejected_by_verification"
                    : run.farther_than_start       ? "farther_than_start"
                    : run.last_iterate_projected() ? polish_name(run.outcome.status) + "_projected"
                    : run.projected                ? "objective_stationary"
                                                   : polish_name(run.outcome.status);

  // 3. Keep the Newton answer only when it is a verified KKT point, or the
  // verified projection after the stationary stop, a stall or the budget,
  // closer than the start. Where it is not a local optimum, the closest
  // verified iterate of any polish is the answer when it is closer still.
  const bool optimum = reached_optimum(run);
  const double to_beat = run.kept()         ? run.check.geometry_change
                         : start_balances ? start_check.geometry_change
                                          : std::numeric_limits<double>::infinity();
  if (!optimum && closest.found && closest.check.geometry_change < to_beat) {
    details->polish = "closest_iterate";
    return closest_iterate_result(closest, run.outcome.message, polish_start_description(*details, start), recorder,
                                  details);
  }
  if (!run.kept()) {
    if (static_cast<int>(recorder.trace().size()) > start_records)
      recorder.record(trace_point(start_check, static_cast<int>(recorder.trace().size()), 0.0));
    return finish_with_start(
        run.verified_rejected    ? "the Newton polish failed verification and was not kept"
        : run.farther_than_start ? "the Newton polish ended at a local optimum farther from the scene and was not kept"
                                 : "the Newton polish stopped (" + run.outcome.message + ") and was not kept");
  }
  if (run.cap_slack)
    details->prestress_cap_slack = std::max(0.0, scale.prestress_cap - scale.normalisation_row.dot(run.forces));
  if (run.outcome.status == Status::Converged) record_multipliers(run, scale.reference_force, *details);
  const char* projected_answer = start_balances
                                     ? "equilibrium closer to the scene than alternating-gn's, not a local optimum"
                                     : "equilibrium, not a local optimum";
  const char* answer = run.last_iterate_projected() ? projected_answer
                       : run.projected              ? "approximate local optimum"
                                                    : "local optimum";
  std::string message = std::string(answer) + " of Eq. 5" +
                        std::string(details->prestress_held ? " held at the prestress cap" : "") + ": " +
                        run.outcome.message + " after " + std::to_string(details->newton_iterations) +
                        " Newton iterations" +
                        (details->restarts > 0 ? " (" + std::to_string(details->restarts) +
                                                   (details->restarts == 1 ? " restart)" : " restarts)")
                                             : "") +
                        " from " + polish_start_description(*details, start);
  if (static_cast<int>(recorder.trace().size()) == start_records)
    recorder.record(trace_point(run.check, start_records, run.objective));
  return verified_answer(std::move(message), run.positions, run.forces, run.check, recorder, std::move(details));
}

std::unique_ptr<Solver> make_eq5_newton_solver() { return std::make_unique<Eq5NewtonSolver>(); }

}  // namespace tensegrity
