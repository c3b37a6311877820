#include "solvers/ipopt/ipopt_solver.hpp"

#include <coin/IpIpoptApplication.hpp>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "formulations/equilibrium.hpp"
#include "formulations/force_scale.hpp"
#include "formulations/minimal_geometry_change_nlp.hpp"
#include "kernels/stress_qp.hpp"
#include "model/errors.hpp"
#include "model/known_keys.hpp"
#include "model/verify.hpp"
#include "solvers/ipopt/dimensionless_eq5.hpp"
#include "solvers/option_reader.hpp"
#include "solvers/standing_check.hpp"
#include "solvers/trace_recorder.hpp"

namespace tensegrity {
namespace {

// The project's own key among the native Ipopt options.
constexpr const char* kStartKey = "start";
constexpr const char* kPrestressKey = "prestress";
// prestress=cap keeps the capped run's answer only when its change is smaller
// by more than round-off (the two runs often end at the same optimum).
constexpr double kSignificantlySmaller = 1e-9;
// Ipopt's `tol` (its scaled optimality error), or --tol when smaller.
constexpr double kOptimalityTolerance = 1e-12;
// Ipopt's constraint tolerance is this share of the solution file's (in the
// same units), a margin for the difference between the two measures.
constexpr double kToleranceShare = 0.1;
// Consecutive iterates optimal to round-off (Eq5Runner) after which a run
// ends: where Ipopt's own test can pass it passes at the first (Ipopt's
// acceptable_iter counts the same way).
constexpr int kRoundOffIterations = 5;
// ... and whose relative residual and dual infeasibility are within these
// factors of --tol and of Ipopt's `tol`, where rounding holds the iterates on
// the largest gravity towers (docs/BACKENDS.md, optimal to round-off).
constexpr double kRoundOffResidualFactor = 10.0;
constexpr double kRoundOffDualFactor = 10.0;
// Conjugate-gradient steps of the stress QP's force polish, enough for the
// residual's last digits at forces 1e6 times the node weights.
constexpr int kForcePolishSteps = 100;
// The stress QP's regulariser mu for the polish: its default first, then a
// larger one, which leaves the residual unbiased (the QP's polish drops it)
// but conditions its factorization better. On the 140-layer gravity tower
// (forces up to 5.7e5 N) the polish ends at relative residual 1.19e-8 with
// the default and at 5.5e-9 with 1e-8 (docs/BACKENDS.md, optimal to round-off).
constexpr double kForcePolishRegularisers[] = {StressQpOptions{}.mu, 1e-8};
// Ipopt's Search_Direction_Becomes_Too_Small (ApplicationReturnStatus).
constexpr int kSearchDirectionTooSmall = 3;
// prestress=cap: the held optimum's multiplier of the cable-sum row above
// which the cap binds (lambda > 0: lowering the mean cable force would move
// the geometry farther), so the capped problem needs no run of its own.
constexpr double kCapBindsMultiplier = 0.0;
// The MUMPS ordering for Eq. 5's KKT matrix: 6 = QAMD, the ordering made for
// quasi-dense rows such as the force-scale row (docs/BACKENDS.md compares them).
constexpr int kQuasiDenseOrdering = 6;
// start=auto: the run from the scene gets this many Ipopt iterations, or this
// many times the warm run's when that is more. From the scene Ipopt either
// reaches its own optimum within a few times the warm run's iterations or
// wanders at large inertia corrections for hundreds (docs/BACKENDS.md).
constexpr int kColdIterationsAtLeast = 100;
constexpr int kColdIterationsPerWarmIteration = 5;
// start=auto and eq5-newton: the warm run gets at most this many: from an
// equilibrium Ipopt converges in tens of iterations or not at all, and the run
// from the scene then needs the time.
constexpr int kWarmIterationsAtMost = 300;
// ... and at most this share of the time limit (start=eq5-newton: of the time
// left after eq5-newton), so that a warm run wandering at a high cost per
// iteration (the 40-layer tower without gravity: 0.44 s an
// iteration from the equilibrium, 0.06 s from the scene) leaves the run from
// the scene its time.
constexpr double kWarmTimeShare = 0.5;
// start=auto: a warm answer that moves the scene by less than this share of
// the mean element length is the scene itself to round-off (the change cannot
// be negative), so no run from the scene can end closer.
constexpr double kNegligibleChangeOverLength = 1e-9;

// start=eq5-newton from a local optimum: Ipopt's default bound push (1e-2)
// and barrier (0.1) would move every force at its sign margin into the
// interior and cost tens of iterations coming back, so it starts at the point
// with a barrier of the optimum's order (docs/BACKENDS.md).
constexpr double kOptimumStartBarrier = 1e-8;
constexpr double kOptimumStartPush = 1e-10;
const char* const kPolishKept[] = {"kept", "objective_stationary"};
// From eq5-newton's closest verified iterate Ipopt starts at alternating-gn's
// equilibrium instead: on the stress test (`stress-test --solvers ipopt
// --time-limit 20`) from the iterate it ended 5.42 m from the scene on
// prism-8 with a length ratio of 1e3, where from the equilibrium and then the
// scene it ends 0.0162 m away, and on prism-12-gravity with 1e4 its
// fallbacks then ran out of iterations.
constexpr const char* kPolishClosestIterate = "closest_iterate";
// ... and there also from eq5-newton's multipliers, held as they are: Ipopt's
// defaults would push every bound multiplier to 1e-3 and every slack to
// 1e-3 of its bound, undoing the optimum it starts at.
constexpr double kWarmStartPush = 1e-12;
const std::vector<IpoptOption> kWarmStartOptions = {{"warm_start_init_point", std::string("yes")},
                                                    {"warm_start_bound_push", kWarmStartPush},
                                                    {"warm_start_bound_frac", kWarmStartPush},
                                                    {"warm_start_slack_bound_push", kWarmStartPush},
                                                    {"warm_start_slack_bound_frac", kWarmStartPush},
                                                    {"warm_start_mult_bound_push", kWarmStartPush}};

// What eq5-newton's details say about its answer, read once from the
// solution file's form of them (backends do not include each other).
struct Eq5NewtonAnswer {
  std::string polish;  // empty without details
  bool prestress_held = false;

  explicit Eq5NewtonAnswer(const SolveResult& eq5_newton) {
    if (eq5_newton.details.size() != 1 || !eq5_newton.details.front()) return;
    const nlohmann::json d = eq5_newton.details.front()->to_json();
    polish = d.value("polish", std::string());
    prestress_held = d.value("prestress_held", false);
  }
  // A local optimum of the problem Ipopt solves: its polish kept (or the
  // stationary stop), and with `capped` not the held polish that eq5-newton
  // falls back to, an optimum of the held problem only.
  bool at_local_optimum(bool capped) const {
    if (capped && prestress_held) return false;
    return std::find(std::begin(kPolishKept), std::end(kPolishKept), polish) != std::end(kPolishKept);
  }
  // Its closest verified iterate: a point on the way of polishes that met no
  // stopping test, not where one ended.
  bool at_intermediate_iterate() const { return polish == kPolishClosestIterate; }
};

// eq5-newton's multipliers at its answer, where it has them for the part.
const SolverDetails* optimum_multipliers(const SolveResult& eq5_newton) {
  if (eq5_newton.details.size() != 1 || !eq5_newton.details.front()) return nullptr;
  const SolverDetails& d = *eq5_newton.details.front();
  return d.eq5_row_multipliers.size() > 0 ? &d : nullptr;
}

// The answer another backend (alternating-gn, eq5-newton) reaches from the
// part's geometry, or an empty result when it does not converge within the
// same settings. `backend_options`: that backend's own.
SolveResult backend_start(const Structure& part, const SolveOptions& options, const char* backend,
                          const OptionPairs& backend_options = {}) {
  SolveOptions start_options = options;
  start_options.backend_options = backend_options;
  start_options.verbose = false;
  DriverControls controls;
  controls.skip_if_in_equilibrium = false;  // the driver has checked the part already
  SolveResult start = make_solver(backend)->Solve(part, start_options, controls);
  if (start.status != Status::Converged) return {};
  return start;
}

// An application for reading Ipopt's option registry (never run).
Ipopt::SmartPtr<Ipopt::IpoptApplication> make_registry_application() {
  Ipopt::SmartPtr<Ipopt::IpoptApplication> app = new Ipopt::IpoptApplication(false, false);
  std::istringstream no_option_file;
  app->Initialize(no_option_file);
  return app;
}

// The valid values of a registered option, in the words of OptionReader.
std::string valid_values(const Ipopt::RegisteredOption& reg) {
  switch (reg.Type()) {
    case Ipopt::OT_Integer:
      return "an integer in [" + (reg.HasLower() ? std::to_string(reg.LowerInteger()) : std::string("-inf")) + ", " +
             (reg.HasUpper() ? std::to_string(reg.UpperInteger()) : std::string("inf")) + "]";
    case Ipopt::OT_Number: {
      ValueRange range;
      if (reg.HasLower()) range.low = reg.LowerNumber(), range.low_open = reg.LowerStrict();
      if (reg.HasUpper()) range.high = reg.UpperNumber(), range.high_open = reg.UpperStrict();
      return "a number in " + range.text();
    }
    default: {
      std::string names;
      for (const auto& entry : reg.GetValidStrings()) names += (names.empty() ? "" : ", ") + entry.value_;
      return names;
    }
  }
}

// Why `key` is refused: the closest of the project's keys and Ipopt's own
// (several hundred, so they are named, not listed), when it is a typo of one.
std::string unknown_key_reason(Ipopt::IpoptApplication& app, const std::string& key) {
  std::vector<std::string_view> known = {kStartKey, kPrestressKey};
  for (const auto& [name, option] : app.RegOptions()->RegisteredOptionsList()) known.push_back(name);
  const std::string intended = misspelled_key(key, known);
  const std::string valid = "valid: start, prestress, or any option of Ipopt's own list, e.g. tol, max_iter, "
                            "mu_strategy, linear_solver";
  return intended.empty() ? "unknown option (" + valid + ")"
                          : "unknown option (did you mean '" + intended + "'?; " + valid + ")";
}

// `key=value` typed by Ipopt's own registry; OptionError when Ipopt does not
// know the key or rejects the value.
IpoptOption typed_native_option(Ipopt::IpoptApplication& app, const std::string& key, const std::string& value) {
  auto fail = [&](const std::string& reason) { throw OptionError("ipopt", key, value, reason); };
  Ipopt::SmartPtr<const Ipopt::RegisteredOption> reg = app.RegOptions()->GetOption(key);
  if (Ipopt::IsNull(reg)) fail(unknown_key_reason(app, key));
  IpoptOption option{key, value};
  bool accepted = false;
  switch (reg->Type()) {
    case Ipopt::OT_Integer: {
      int parsed = 0;
      const auto [end, ec] = std::from_chars(value.data(), value.data() + value.size(), parsed);
      if (ec != std::errc() || end != value.data() + value.size())
        fail("not an integer (valid: " + valid_values(*reg) + ")");
      accepted = app.Options()->SetIntegerValue(key, parsed);
      option.value = parsed;
      break;
    }
    case Ipopt::OT_Number: {
      char* end = nullptr;
      const double parsed = std::strtod(value.c_str(), &end);
      if (value.empty() || end != value.c_str() + value.size() || !std::isfinite(parsed))
        fail("not a finite number (valid: " + valid_values(*reg) + ")");
      accepted = app.Options()->SetNumericValue(key, parsed);
      option.value = parsed;
      break;
    }
    default: accepted = app.Options()->SetStringValue(key, value); break;
  }
  if (!accepted) fail("out of range (valid: " + valid_values(*reg) + ")");
  return option;
}

}  // namespace

IpoptOptions IpoptOptions::FromPairs(const OptionPairs& pairs) {
  Ipopt::SmartPtr<Ipopt::IpoptApplication> app = make_registry_application();
  IpoptOptions o;
  for (const auto& [key, value] : pairs) {
    if (key == kStartKey) {
      if (value == "auto") o.start = IpoptStart::Auto;
      else if (value == "scene") o.start = IpoptStart::Scene;
      else if (value == "alternating-gn") o.start = IpoptStart::AlternatingGn;
      else if (value == "eq5-newton") o.start = IpoptStart::Eq5Newton;
      else throw OptionError("ipopt", key, value, "not a start (valid: auto, scene, alternating-gn, eq5-newton)");
      continue;
    }
    if (key == kPrestressKey) {
      if (value == "equal") o.prestress = IpoptPrestress::Equal;
      else if (value == "cap") o.prestress = IpoptPrestress::Cap;
      else throw OptionError("ipopt", key, value, "not a prestress row (valid: equal, cap)");
      continue;
    }
    o.native[key] = value;
    o.typed.push_back(typed_native_option(*app, key, value));
  }
  return o;
}

bool IpoptOptions::IsValid(std::string* why) const {
  try {
    FromPairs(native);  // `start` and `prestress` are enums and always valid
  } catch (const OptionError& e) {
    if (why) *why = e.what();
    return false;
  }
  return true;
}

namespace {

// Ipopt's scaled stopping test met but not model/verify's (rounding of the
// rows on large scenes): a stress solve at `positions`, warm-started from
// `forces`, with each regulariser of kForcePolishRegularisers until one
// verifies. True, with `forces` and `check` replaced, when polished forces
// verify.
bool polish_forces(const Structure& part, const ForceScale& scale, const Eigen::Matrix3Xd& positions,
                   double tolerance, Eigen::VectorXd& forces, Verification& check) {
  Equilibrium eq(part);
  eq.set_positions(positions);
  for (const double regulariser : kForcePolishRegularisers) {
    StressQpOptions qp_options;
    qp_options.max_polish_steps = kForcePolishSteps;
    qp_options.mu = regulariser;
    StressQp qp(eq, scale, qp_options);
    Eigen::VectorXd polished = qp.solve(forces).sigma;
    if (polished.size() != part.num_elements() || !polished.allFinite()) continue;
    const Verification v = verify(part, positions, polished, tolerance);
    if (!v.ok) continue;
    forces = std::move(polished);
    check = v;
    return true;
  }
  return false;
}

// One Ipopt run of Eq. 5 and its independent check.
struct Eq5Run {
  Status status = Status::NumericalError;
  std::string message;
  int return_code = 0;
  int iterations = 0;
  Eigen::Matrix3Xd positions;
  Eigen::VectorXd forces;
  double cable_sum_multiplier = std::numeric_limits<double>::quiet_NaN();  // DimensionlessEq5's
  Verification check;
  bool ok() const { return status == Status::Converged && check.ok; }
};

// A start point of a run: positions and forces.
struct Eq5Start {
  const Eigen::Matrix3Xd& positions;
  const Eigen::VectorXd& forces;
  // Eq. 5's multipliers at that point (SolverDetails), or null.
  const SolverDetails* multipliers = nullptr;
};

// The forces of a start at the scene, computed when first asked for: a run
// from another backend's answer does not need them, and under gravity they
// cost a stress QP at the scene's geometry (on the 10-layer gravity tower a
// third of a solve from eq5-newton's answer).
class SceneForces {
 public:
  explicit SceneForces(std::function<Eigen::VectorXd()> compute) : compute_(std::move(compute)) {}
  const Eigen::VectorXd& get() const {
    if (!forces_) forces_ = compute_();
    return *forces_;
  }

 private:
  std::function<Eigen::VectorXd()> compute_;
  mutable std::optional<Eigen::VectorXd> forces_;
};

// What every run of one part solve shares: the part, its problem, the
// settings and the trace, whose iteration and evaluation counts continue
// from run to run.
struct Eq5Runner {
  const Structure& part;
  const SolveOptions& options;
  const ForceScale& scale;
  const SceneForces& sigma0;
  double max_free_weight;
  IpoptSettings settings;  // without max_iter: each run sets its own
  TraceRecorder& recorder;
  double optimality_tol = 0.0;  // Ipopt's `tol`, the user's when given

  int next_iteration() const { return recorder.trace().empty() ? 0 : recorder.trace().back().iteration + 1; }
  int evaluations() const { return recorder.trace().empty() ? 0 : recorder.trace().back().evaluations; }

  // Runs `nlp` from `start` (the scene with sigma0 when null) for at most
  // `max_iterations`, and until `stop_at_seconds` of the solve's clock (a
  // TimeLimit status then, as at the time limit). `record_first`: whether
  // its iteration 0 is a new record (not when it repeats the point the trace
  // ends at).
  // `first_options` go before every other setting, so that the user's own
  // values of the same options win.
  Eq5Run run(MinimalGeometryChangeNlp& nlp, const Eq5Start* start, int max_iterations, bool record_first,
             double stop_at_seconds = std::numeric_limits<double>::infinity(),
             const std::vector<IpoptOption>& first_options = {}) {
    DimensionlessEq5 problem(nlp, start != nullptr ? start->forces : sigma0.get());
    if (start != nullptr) problem.set_start(nlp.equilibrium().free_nodes().gather(start->positions), start->forces);
    if (start != nullptr && start->multipliers != nullptr)
      problem.set_start_multipliers(start->multipliers->eq5_row_multipliers,
                                    start->multipliers->eq5_force_bound_multipliers);
    IpoptSettings run_settings = settings;
    run_settings.options.insert(run_settings.options.begin(), IpoptOption{"max_iter", max_iterations});
    run_settings.options.insert(run_settings.options.begin(), first_options.begin(), first_options.end());
    const int iteration_offset = next_iteration() - (record_first ? 0 : 1);
    const int evaluation_offset = evaluations();
    int optimal_iterations = 0;  // consecutive, see optimal_to_round_off
    run_settings.on_iteration = [&](const IpoptIteration& it) {
      TracePoint p = problem.trace_point(it, max_free_weight);
      if (record_first || it.iteration > 0) {
        p.iteration += iteration_offset;
        p.evaluations += evaluation_offset;
        recorder.record(p);
      }
      if (recorder.out_of_time() || recorder.seconds() > stop_at_seconds) return IterationControl::StopForTimeLimit;
      optimal_iterations = optimal_to_round_off(it, p) ? optimal_iterations + 1 : 0;
      return optimal_iterations >= kRoundOffIterations ? IterationControl::StopSatisfied : IterationControl::Continue;
    };
    const IpoptSolveResult native = solve_with_ipopt(problem, run_settings);
    Eq5Run r;
    r.status = native.status;
    r.message = native.message;
    if (native.status == Status::Converged && optimal_iterations >= kRoundOffIterations) {
      r.message = "Ipopt: optimal to round-off, below what its absolute constraint tolerance can confirm";
    } else if (native.return_code == kSearchDirectionTooSmall && optimal_iterations > 0) {
      // Ipopt's tiny-step exit at an iterate already optimal to round-off
      // (the same test as the early stop): the optimum, not a failure.
      r.status = Status::Converged;
      r.message = "Ipopt: search direction too small at an optimum to round-off";
    }
    r.return_code = native.return_code;
    r.iterations = native.iterations;
    if (problem.has_final_point() && problem.final_point().allFinite()) {
      r.positions = nlp.positions(problem.final_point());
      r.forces = nlp.forces(problem.final_point());
      r.cable_sum_multiplier = problem.cable_sum_multiplier();
    } else {
      r.positions = start != nullptr ? start->positions : part.positions;
      r.forces = start != nullptr ? start->forces : sigma0.get();
    }
    r.check = verify(part, r.positions, r.forces, options.tolerance);
    if (r.status == Status::Converged && !r.check.ok && r.check.all_finite && r.check.wrong_signs == 0 &&
        polish_forces(part, scale, r.positions, options.tolerance, r.forces, r.check))
      r.message += " (forces polished by the stress QP)";
    return r;
  }

  // Ipopt's own test compares the constraint violation with an absolute
  // tolerance a tenth of the one asked, in units of the load, which on large
  // gravity towers lies at the round-off of the equilibrium rows and of the
  // cable-sum row (kappa n_c in units of F0): Ipopt then sits at the optimum
  // until its iteration budget runs out (the 20-layer tower: optimal from
  // iteration 99, stopped at 2000). So iterates that are optimal by Ipopt's
  // measures (dual infeasibility and barrier parameter) and in equilibrium
  // by the solution file's own measure end the run when Ipopt has not
  // stopped by itself within kRoundOffIterations of them.
  bool optimal_to_round_off(const IpoptIteration& it, const TracePoint& p) const {
    return it.x != nullptr && it.dual_infeasibility <= kRoundOffDualFactor * optimality_tol &&
           it.barrier_parameter <= optimality_tol &&
           p.relative_residual <= kRoundOffResidualFactor * options.tolerance;
  }

  // A record of the kept answer, when the trace ends elsewhere.
  void record_answer(const Eq5Run& r) {
    TracePoint p;
    p.iteration = next_iteration();
    p.evaluations = evaluations();
    p.residual = r.check.residual;
    p.relative_residual = r.check.relative_residual;
    p.geometry_change = r.check.geometry_change;
    recorder.record(p);
  }
};

// Start forces at `positions` that satisfy Eq. 5's own prestress row: the
// stress QP, warm-started from `warm` (cold when empty), with the mean cable
// force held at the cap under gravity. Both the driver's stress QP and
// alternating-gn leave that level to the load (on the 20-layer gravity tower
// with 1 % noise the row violated by 1.6e3 in units of F0, on the scorpion
// of the minimal blocks by 5e2), and from such a start Ipopt first moves far
// away to restore the row (9 m on that tower). `fallback` when the QP gives
// no finite forces.
Eigen::VectorXd eq5_start_forces(const Structure& part, const Eigen::Matrix3Xd& positions, const ForceScale& scale,
                                 const Eigen::VectorXd& warm, const Eigen::VectorXd& fallback) {
  Structure at = part;
  at.positions = positions;
  const Equilibrium eq(at);
  StressQp qp(eq, scale.has_prestress_cap() ? held_at_prestress_cap(scale) : scale);
  StressQpResult r = qp.solve(warm);
  if (r.sigma.size() != part.num_elements() || !r.sigma.allFinite()) return fallback;
  return std::move(r.sigma);
}

// The closer of two runs to the scene among those that converged and verify
// (`a` unless `b` is closer by more than round-off, or when neither does).
const Eq5Run& closer(const Eq5Run& a, const Eq5Run& b) {
  if (!b.ok()) return a;
  if (!a.ok()) return b;
  return b.check.geometry_change < (1.0 - kSignificantlySmaller) * a.check.geometry_change ? b : a;
}

}  // namespace

SolveResult IpoptSolver::DoSolve(const PartProblem& part_problem, const IpoptOptions& ipopt_options) const {
  const Structure& part = part_problem.part;
  const SolveOptions& options = part_problem.options;
  TraceRecorder recorder(options.time_limit_s);
  const ForceScale scale = make_force_scale(part, options.margin_fraction, options.prestress_factor);
  const double max_free_weight = part.max_free_node_weight();

  MinimalGeometryChangeNlp nlp(part, scale);
  // The start's forces satisfy the problem's own prestress row. Without
  // gravity the stress QP of the driver's check does, and where it runs to
  // its end its forces are the better start on degenerate scenes
  // (docs/BACKENDS.md, "The check whether a scene already stands"); computed
  // here, so that the answer does not depend on whether the driver checked.
  const bool held_start = scale.has_prestress_cap();
  const SceneForces sigma0([&]() -> Eigen::VectorXd {
    if (!held_start) {
      Eigen::VectorXd checked = standing_check_forces(part, options);
      if (checked.size() == part.num_elements()) return checked;
    }
    return eq5_start_forces(part, part.positions, scale, Eigen::VectorXd(), reference_forces(part, scale));
  });

  // Ipopt's constraint violation is the max-norm of f / F0; docs/FORMATS.md asks
  // |f_i| <= tolerance * load scale, where the load scale is the largest
  // free-node weight with gravity and otherwise max |sigma| >= F0 (mean cable
  // force = F0). A tenth of that, for the three components of a node.
  const double load_over_force =
      max_free_weight > 0.0 ? std::min(1.0, max_free_weight / scale.reference_force) : 1.0;
  const double constraint_tolerance = kToleranceShare * options.tolerance * load_over_force / std::sqrt(3.0);

  // A warm start's forces: under gravity the stress QP's at its geometry with
  // the level held at the cap (its own forces leave the level to the load).
  auto warm_start_forces = [&](const SolveResult& start) -> Eigen::VectorXd {
    return held_start ? eq5_start_forces(part, start.positions, scale, start.forces, start.forces) : start.forces;
  };
  Eq5Runner runner{part, options, scale, sigma0, max_free_weight, {}, recorder};
  IpoptSettings& settings = runner.settings;
  settings.verbose = options.verbose;
  settings.set("linear_solver", "mumps");
  settings.set("mumps_pivot_order", kQuasiDenseOrdering);
  settings.set("hessian_approximation", "exact");
  settings.set("mu_strategy", "adaptive");
  // Tight: on scenes that need no change the barrier leaves a drift of order mu.
  runner.optimality_tol = std::min(kOptimalityTolerance, options.tolerance);
  settings.set("tol", runner.optimality_tol);
  settings.set("constr_viol_tol", constraint_tolerance);
  settings.set("acceptable_tol", 1e-8);
  settings.set("acceptable_constr_viol_tol", constraint_tolerance);
  settings.set("acceptable_iter", 5);
  // Ipopt relaxes bounds by this (y is O(1) near the margins) and projects the
  // result back onto them afterwards; that projection moves forces, so it must
  // stay below what the residual test can see.
  settings.set("bound_relax_factor", 0.1 * constraint_tolerance);
  // No max_cpu_time: Ipopt 3.11 measures the CPU time of the whole process, so
  // with solves on other threads it stops early (two busy threads: after half
  // the budget). The wall-clock limit is checked in every iteration instead.
  settings.options.insert(settings.options.end(), ipopt_options.typed.begin(), ipopt_options.typed.end());
  for (const IpoptOption& o : ipopt_options.typed)
    if (o.name == "tol" && std::holds_alternative<double>(o.value)) runner.optimality_tol = std::get<double>(o.value);
  const int budget = options.iteration_budget(kDefaultIterationBudget);

  // The held problem from the chosen start(s).
  std::string start_note;
  Eq5Run held;
  int ipopt_iterations = 0;  // of every run
  auto details = std::make_shared<IpoptDetails>();
  // start=eq5-newton under gravity with prestress=cap: eq5-newton's answer is
  // a point of the capped problem already, which Ipopt then solves directly.
  bool capped_directly = false;
  if (ipopt_options.start == IpoptStart::Scene) {
    held = runner.run(nlp, nullptr, budget, true);
    ipopt_iterations = held.iterations;
  } else if (ipopt_options.start == IpoptStart::Eq5Newton) {
    const bool capped = ipopt_options.prestress == IpoptPrestress::Cap && scale.has_prestress_cap();
    const SolveResult optimum =
        backend_start(part, options, "eq5-newton", {{kPrestressKey, capped || !held_start ? "cap" : "equal"}});
    const bool have_optimum = optimum.positions.cols() == part.num_nodes();
    if (have_optimum) {
      for (const TracePoint& p : optimum.trace) recorder.record(p);
      const Eq5NewtonAnswer answer(optimum);
      const bool at_optimum = answer.at_local_optimum(capped);
      SolveResult equilibrium_instead;
      if (answer.at_intermediate_iterate()) equilibrium_instead = backend_start(part, options, "alternating-gn");
      const bool from_equilibrium_instead = equilibrium_instead.positions.cols() == part.num_nodes();
      const SolveResult& point = from_equilibrium_instead ? equilibrium_instead : optimum;
      std::vector<IpoptOption> at_point;
      if (at_optimum)
        at_point = {{"mu_init", kOptimumStartBarrier}, {"bound_push", kOptimumStartPush},
                    {"bound_frac", kOptimumStartPush}, {"bound_mult_init_method", std::string("mu-based")}};
      // Away from an optimum (alternating-gn's equilibrium or a projected
      // last iterate) the forces leave the level to the load, as in start=auto.
      const Eigen::VectorXd forces = at_optimum ? optimum.forces : warm_start_forces(point);
      const SolverDetails* multipliers = at_optimum ? optimum_multipliers(optimum) : nullptr;
      if (multipliers != nullptr) at_point.insert(at_point.end(), kWarmStartOptions.begin(), kWarmStartOptions.end());
      const Eq5Start from{point.positions, forces, multipliers};
      capped_directly = capped;
      std::optional<MinimalGeometryChangeNlp> capped_nlp;
      if (capped) capped_nlp.emplace(part, scale, PrestressRow::Cap);
      // Half the time left after eq5-newton, so that the run from the scene
      // keeps the other half.
      const double stop_at = recorder.seconds() + kWarmTimeShare * (options.time_limit_s - recorder.seconds());
      held = runner.run(capped ? *capped_nlp : nlp, &from, std::min(budget, kWarmIterationsAtMost), false, stop_at,
                        at_point);
      start_note = from_equilibrium_instead
                       ? " (started from alternating-gn's equilibrium: eq5-newton's answer after " +
                             std::to_string(optimum.stats.iterations) + " iterations is an intermediate iterate)"
                       : std::string(" (started from eq5-newton's ") + (at_optimum ? "local optimum" : "equilibrium") +
                             " after " + std::to_string(optimum.stats.iterations) + " iterations)";
      ipopt_iterations = held.iterations;
      if (!held.ok() && !recorder.out_of_time() && !from_equilibrium_instead) {
        // No verified answer from eq5-newton's point: before the scene, the
        // equilibrium eq5-newton started from (unless that was the point), as
        // start=alternating-gn (on the stress test's length ratios of 1e4
        // Ipopt converges from there in under 200 iterations where from both
        // other points it does not).
        const SolveResult equilibrium = backend_start(part, options, "alternating-gn");
        if (equilibrium.positions.cols() == part.num_nodes() && equilibrium.positions != point.positions) {
          const Eigen::VectorXd equilibrium_forces = warm_start_forces(equilibrium);
          const Eq5Start from_equilibrium{equilibrium.positions, equilibrium_forces};
          const double until = recorder.seconds() + kWarmTimeShare * (options.time_limit_s - recorder.seconds());
          Eq5Run warm = runner.run(nlp, &from_equilibrium,
                                   std::min(kWarmIterationsAtMost, std::max(1, budget - ipopt_iterations)), false,
                                   until);
          ipopt_iterations += warm.iterations;
          if (warm.ok()) {
            held = std::move(warm);
            capped_directly = false;
            start_note = " (started from alternating-gn's equilibrium: from eq5-newton's answer Ipopt did not "
                         "converge)";
          }
        }
      }
    }
    if (!have_optimum || (!held.ok() && !recorder.out_of_time())) {
      // No answer from eq5-newton's point: the scene with the budget left,
      // kept when it verifies (or when there was no such point to run from).
      const int left = std::max(1, budget - ipopt_iterations);
      Eq5Run cold = runner.run(nlp, nullptr, left, true);
      ipopt_iterations += cold.iterations;
      details->cold_start_iterations = cold.iterations;
      if (!have_optimum || &closer(held, cold) == &cold) {
        held = std::move(cold);
        capped_directly = false;
        start_note.clear();
        details->cold_start_kept = true;
      }
    }
  } else {
    const SolveResult equilibrium = backend_start(part, options, "alternating-gn");
    const bool have_equilibrium = equilibrium.positions.cols() == part.num_nodes();
    Eq5Run warm;
    if (have_equilibrium) {
      for (const TracePoint& p : equilibrium.trace) recorder.record(p);
      const int warm_budget =
          ipopt_options.start == IpoptStart::Auto ? std::min(budget, kWarmIterationsAtMost) : budget;
      const double warm_until = ipopt_options.start == IpoptStart::Auto
                                    ? kWarmTimeShare * options.time_limit_s
                                    : std::numeric_limits<double>::infinity();
      const Eigen::VectorXd warm_forces = warm_start_forces(equilibrium);
      const Eq5Start from{equilibrium.positions, warm_forces};
      warm = runner.run(nlp, &from, warm_budget, false, warm_until);
      start_note = " (started from alternating-gn's equilibrium after " +
                   std::to_string(equilibrium.stats.iterations) + " iterations)";
    }
    if (ipopt_options.start == IpoptStart::AlternatingGn && have_equilibrium) {
      ipopt_iterations = warm.iterations;
      held = std::move(warm);
    } else if (have_equilibrium && warm.status == Status::TimeLimit && recorder.out_of_time()) {
      // No time left for a run from the scene: the warm run's last point.
      ipopt_iterations = warm.iterations;
      held = std::move(warm);
    } else if (!warm.ok()) {
      // start=auto without a warm answer: the scene with the whole budget.
      held = runner.run(nlp, nullptr, budget, true);
      ipopt_iterations = warm.iterations + held.iterations;
      start_note.clear();
      if (ipopt_options.start == IpoptStart::Auto) {
        details->cold_start_iterations = held.iterations;
        details->cold_start_kept = true;
      }
    } else {
      // start=auto with a warm answer: the scene too, with a budget that a
      // cold run converging to its own optimum needs and a wandering one
      // exceeds; the closer verified answer is kept.
      const int cold_budget = std::min(
          budget, std::max(kColdIterationsAtLeast, kColdIterationsPerWarmIteration * warm.iterations));
      Eq5Run cold;
      const bool warm_is_the_scene =
          warm.check.geometry_change <= kNegligibleChangeOverLength * part.mean_element_length();
      if (!recorder.out_of_time() && !warm_is_the_scene) {
        cold = runner.run(nlp, nullptr, cold_budget, true);
        details->cold_start_iterations = cold.iterations;
      }
      ipopt_iterations = warm.iterations + cold.iterations;
      // On a tie the scene's answer: the prestress cap below may continue
      // differently from two optima of the same change.
      const bool cold_kept = &closer(cold, warm) == &cold;
      details->cold_start_kept = cold_kept;
      held = cold_kept ? std::move(cold) : std::move(warm);
      if (cold_kept) start_note = " (started from the scene; the start at alternating-gn's equilibrium ended no closer)";
      else runner.record_answer(held);
    }
  }
  details->return_code = held.return_code;

  SolveResult result;
  result.native_code = held.return_code;
  result.status = held.status;
  result.message = held.message + start_note;
  result.positions = held.positions;
  result.forces = held.forces;
  Verification v = held.check;
  if (scale.has_prestress_cap() && !capped_directly) details->cable_sum_multiplier = held.cable_sum_multiplier;
  // A held optimum whose multiplier shows the cap binding is already a KKT
  // point of the capped problem; over the stress test the restart from such
  // a point ended closer in 1 of 435 solves (docs/BACKENDS.md).
  details->prestress_cap_binds =
      scale.has_prestress_cap() && !capped_directly && held.ok() && held.cable_sum_multiplier > kCapBindsMultiplier;
  if (ipopt_options.prestress == IpoptPrestress::Cap && scale.has_prestress_cap() && !capped_directly && held.ok() &&
      !details->prestress_cap_binds && !recorder.out_of_time()) {
    // The capped problem restarted at the held optimum: a feasible start, so
    // Ipopt stays near it instead of wandering as it does from the scene.
    MinimalGeometryChangeNlp capped_nlp(part, scale, PrestressRow::Cap);
    const Eq5Start from{held.positions, held.forces};
    const Eq5Run capped = runner.run(capped_nlp, &from, budget, false);
    ipopt_iterations += capped.iterations;
    if (&closer(held, capped) == &capped) {
      result.positions = capped.positions;
      result.forces = capped.forces;
      v = capped.check;
      details->prestress_cap_kept = true;
      result.message += " (mean cable force below the cap)";
    } else {
      runner.record_answer(held);
    }
  }
  details->iterations = ipopt_iterations;
  result.stats.iterations = recorder.trace().empty() ? 0 : recorder.trace().back().iteration;
  result.details = {details};
  if (!v.all_finite) {
    result.status = Status::NumericalError;
    result.positions = part.positions;
    result.forces = sigma0.get();
    v = verify(part, result.positions, result.forces, options.tolerance);
  }
  result.stats.seconds = recorder.seconds();
  result.stats.residual = v.residual;
  result.stats.relative_residual = v.relative_residual;
  result.stats.geometry_change = v.geometry_change;
  result.trace = std::move(recorder.trace());
  return result;
}

nlohmann::json IpoptDetails::to_json() const {
  nlohmann::json j = {{"return_code", return_code}, {"iterations", iterations}};
  if (prestress_cap_kept) j["prestress_cap_kept"] = true;
  if (std::isfinite(cable_sum_multiplier)) {
    j["cable_sum_multiplier"] = cable_sum_multiplier;
    j["prestress_cap_binds"] = prestress_cap_binds;
  }
  if (cold_start_iterations >= 0) {
    j["cold_start_iterations"] = cold_start_iterations;
    j["cold_start_kept"] = cold_start_kept;
  }
  return j;
}

std::unique_ptr<Solver> make_ipopt_solver() { return std::make_unique<IpoptSolver>(); }

}  // namespace tensegrity
