// The driver shared by every backend: settings, parts, prechecks, merging,
// one independent verification, and the outcome as one status.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <string>

#include "formulations/components.hpp"
#include "formulations/equilibrium.hpp"
#include "formulations/force_scale.hpp"
#include "kernels/stress_qp.hpp"
#include "kernels/stress_qp_ipopt.hpp"
#include "model/json_text.hpp"
#include "model/errors.hpp"
#include "model/verify.hpp"
#include "solvers/solver.hpp"
#include "solvers/standing_check.hpp"
#include "solvers/trace_recorder.hpp"

namespace tensegrity {
namespace {

// Polish steps of the stress QP at fixed geometry (`forces`, the driver's
// shortcut) near an equilibrium: the 10-layer tower's takes about a hundred.
constexpr int kForcesPolishSteps = 2000;
// The relative residual of the first solve below which that polish runs,
// and `forces` asks Ipopt first (kernels/stress_qp_ipopt.hpp).
constexpr double kPolishToOptimumBelow = 1e-3;
// Below this the driver's check whether a scene already stands asks Ipopt
// too: about the geometric middle between the equilibria of the towers of
// `generate tower` without gravity (10 to 160 layers), which the check's
// stress QP leaves at 1.6e-6 to 5.7e-6 and Ipopt then confirms, and the
// as-generated towers, which do not stand and which it leaves at 6.3e-5
// (40 layers) to 5.1e-4, where Ipopt only costs time (on the 40-layer tower
// several times alternating-gn's whole solve).
constexpr double kIpoptInCheckBelow = 2e-5;
// Above kIpoptInCheckBelow the check's polish gets this many steps instead
// of kForcesPolishSteps: a scene that stands is found at once (the stress
// test's scorpion with a length ratio of 1,000, at 2.3e-4 after the QP,
// stands after 0.013 s of polish), while on the as-generated towers, which
// do not stand, the polish creeps through all of kForcesPolishSteps (on the
// 160-layer tower without gravity, to 2e-5 in seconds).
constexpr int kCheckShortPolishSteps = 30;
// The driver's check starts with the stress QP's interior-point phase
// instead of reaching it after the default 20 projected-Newton steps: from a
// cold start those steps change the active set a few forces at a time, and
// the phase is what finds the optimum's neighbourhood (the characters and the
// stored towers that stand then settle within 3 steps, against 21 to 23). It
// gives up on a scene whose stress QP still leaves a relative residual above
// kCheckGivesUpAbove kCheckGivesUpAfter steps past the phase: such a scene is
// to be solved, and the rest of the QP, for forces that are only the
// backend's start, costs more than the backend. Not at the phase's own point:
// its crossover guesses the active set, and on the gravity prisms with 0.1 %
// node noise, which stand, it is still above 1e-2 there. For the same reason
// the phase itself only ends early where its residual has settled far above
// kCheckGivesUpAbove (StressQpOptions::end_interior_point_when_settled), and
// those steps still judge.
constexpr int kCheckInteriorPointAfter = 0;
constexpr int kCheckGivesUpAfter = 5;
constexpr double kCheckGivesUpAbove = 1e-2;
// Past the phase the check's projected Newton ends once its best point has
// stopped improving for this many steps (StressQpOptions::
// end_when_stalled_after): on the as-generated towers without gravity, which
// do not stand, the best point is the phase's own, and the steps on to the
// cap of 100 cost several times alternating-gn's whole solve; on the towers'
// equilibria, which stand, the best point comes at the phase (80 and 160
// layers) or 11 steps past it (40 layers), below kIpoptInCheckBelow.
constexpr int kCheckStalledAfter = 10;
// StressQpOptions::interior_point_after: never.
constexpr int kNoInteriorPoint = -1;
// Projected-Newton steps of `forces`, whose answer is the point of the run:
// on the equilibria of large near-mechanisms (the 40-layer tower without
// gravity) the default cap stops it short. The driver's shortcut keeps the
// default: it only decides whether a scene already stands.
constexpr int kForcesCommandIterations = 1000;
// `forces` stops Ipopt's search (kernels/stress_qp_ipopt.hpp) at forces this
// far inside the tolerance, so that the answer verifies with a margin.
constexpr double kIpoptStopFraction = 0.1;

using Clock = std::chrono::steady_clock;

// The remaining budget a part gets is never below this, so that a part late in
// a solve still runs its first iteration and reports a status.
constexpr double kSmallestPartTimeLimit = 1e-3;  // s

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// Severity when parts end differently: the whole is as good as its worst part.
int severity(Status s) {
  switch (s) {
    case Status::Converged: return 0;
    case Status::MaxIterations: return 1;
    case Status::TimeLimit: return 2;
    case Status::Stalled: return 3;
    case Status::Infeasible: return 4;
    case Status::NumericalError: return 5;
  }
  return 5;
}

void validate_settings(const SolveOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw InputError("options", "settings", why);
}

bool has_support(const Structure& part) {
  return std::any_of(part.fixed.begin(), part.fixed.end(), [](bool f) { return f; });
}

// The internal forces of a part sum to zero, so a net weight on a part without
// supports can never be balanced: a proof of infeasibility.
bool unsupported_weight(const Structure& part) {
  if (!part.has_gravity() || has_support(part)) return false;
  const Eigen::Matrix3Xd loads = part.gravity_loads();
  return loads.rowwise().sum().norm() > 0.0;
}

SolveResult unchanged_part(const Structure& part, Eigen::VectorXd forces, Status status, std::string message) {
  SolveResult r;
  r.positions = part.positions;
  r.forces = std::move(forces);
  r.status = status;
  r.message = std::move(message);
  return r;
}

// The stress QP's effort in forces_at_own_geometry.
enum class FixedGeometryEffort {
  Check,       // the driver's check whether a scene already stands: the default cap, giving up far from one
  IpoptStart,  // the same, through K instead of the node space: ipopt's start (standing_check_forces)
  Command,     // `forces`, whose answer is the point of the run: kForcesCommandIterations
};

// The stress QP at the part's own geometry: Converged when it verifies,
// Infeasible when the QP's optimum leaves a residual (a proof at this
// geometry), MaxIterations when the QP spent its step cap or gave up,
// Stalled when it stopped short of a certified optimum otherwise.
// `gave_up`, if given, says whether the check gave up (give_up_after).
SolveResult forces_at_own_geometry(const Structure& part, const SolveOptions& options,
                                   FixedGeometryEffort effort = FixedGeometryEffort::Check,
                                   bool* gave_up = nullptr) {
  const auto t0 = Clock::now();
  const ForceScale scale = make_force_scale(part, options.margin_fraction);
  Equilibrium eq(part);
  eq.set_positions(part.positions);
  StressQpOptions qp_options;
  if (effort == FixedGeometryEffort::Command) {
    qp_options.certify_optimum = true;  // a claim of infeasibility needs the proof
    qp_options.max_iterations = kForcesCommandIterations;
  } else {
    qp_options = standing_check_qp_options();  // certifies too
    // On degenerate prisms ipopt's run from the scene depends on its start,
    // and K's rounding of the check's QP is the start measured there: with
    // the node space's, ipopt verified 6 fewer of the stress test's trials.
    if (effort == FixedGeometryEffort::IpoptStart) qp_options.node_space = false;
  }
  StressQp qp(eq, scale, qp_options);
  StressQpResult qr = qp.solve();
  if (gave_up) *gave_up = qr.gave_up;
  Verification v = verify(part, part.positions, qr.sigma, options.tolerance);
  const bool near_equilibrium =
      !v.ok && v.relative_residual <= kPolishToOptimumBelow && qr.status != StressQpStatus::NumericalFailure;
  const double ipopt_below = effort == FixedGeometryEffort::Command ? kPolishToOptimumBelow : kIpoptInCheckBelow;
  std::string found_by;
  // On large near-mechanisms the stress QP's normal matrix loses the
  // equilibrium that exists (kernels/stress_qp_ipopt.hpp): Ipopt on the
  // residual form is asked before the slower polish below.
  if (near_equilibrium && v.relative_residual <= ipopt_below && qr.status != StressQpStatus::Optimal) {
    const auto relative_residual = [&](const Eigen::VectorXd& sigma) {
      return verify(part, part.positions, sigma, options.tolerance).relative_residual;
    };
    const StressQpIpoptResult ir =
        solve_stress_qp_with_ipopt(eq, scale, qr.sigma, options.time_limit_s - seconds_since(t0),
                                   relative_residual, kIpoptStopFraction * options.tolerance);
    qr.iterations += ir.iterations;
    if (ir.sigma.size() == part.num_elements()) {
      const Verification iv = verify(part, part.positions, ir.sigma, options.tolerance);
      if (iv.relative_residual < v.relative_residual) {
        qr.sigma = ir.sigma;
        v = iv;
        found_by = " (forces from Ipopt on Eq. 4 in residual form)";
      }
    }
  }
  // Near an equilibrium the answer matters most and the QP is hardest (near-
  // mechanisms stop projected Newton on a wrong active set): the polish to
  // the optimum, an active-set method, finishes from there. Far from one
  // (a scene to be solved) it would only cost time.
  if (near_equilibrium && !v.ok) {
    const bool short_polish = effort != FixedGeometryEffort::Command && v.relative_residual > kIpoptInCheckBelow;
    qp.set_polish(true, short_polish ? kCheckShortPolishSteps : kForcesPolishSteps);
    // After a QP that made no more progress, the check's polish starts from
    // its best point: a second interior-point phase would only find the same
    // neighbourhood again (on the as-generated 40-layer tower, most of the
    // check's time). After one that met the KKT conditions the phase stays:
    // on degenerate prisms its forces are ipopt's better start.
    if (effort != FixedGeometryEffort::Command && qr.status == StressQpStatus::Stalled)
      qp.set_interior_point_after(kNoInteriorPoint);
    StressQpResult polished = qp.solve(qr.sigma);
    const Verification pv = verify(part, part.positions, polished.sigma, options.tolerance);
    if (polished.status != StressQpStatus::NumericalFailure && pv.relative_residual <= v.relative_residual) {
      polished.iterations += qr.iterations;
      qr = std::move(polished);
      v = pv;
      found_by.clear();
    }
  }
  // The certified optimum's residual is at least this much of the returned one.
  const double proven_fraction =
      qr.objective > 0.0 ? std::sqrt(std::max(0.0, qr.objective_lower_bound) / qr.objective) : 1.0;
  SolveResult r;
  if (v.ok) {
    r = unchanged_part(part, qr.sigma, Status::Converged, "already in equilibrium at the scene geometry" + found_by);
  } else if (qr.status == StressQpStatus::Optimal && v.relative_residual * proven_fraction > options.tolerance) {
    r = unchanged_part(part, qr.sigma, Status::Infeasible,
                       "the scene geometry is not a tensegrity (the stress QP's optimum has relative residual " +
                           message_number(v.relative_residual) + ", proven at least " +
                           message_number(v.relative_residual * proven_fraction) + "; " + qr.message + ")");
  } else if (qr.status != StressQpStatus::NumericalFailure) {
    // A spent step cap is a budget; no progress, or an optimum without its
    // certificate, is a stall.
    const Status no_proof = qr.status == StressQpStatus::IterationLimit ? Status::MaxIterations : Status::Stalled;
    r = unchanged_part(part, qr.sigma, no_proof,
                       "the stress QP stopped without a proof either way (relative residual " +
                           message_number(v.relative_residual) + "; " + qr.message + ")");
  } else {
    r = unchanged_part(part, qr.sigma, Status::NumericalError, "the stress QP failed: " + qr.message);
  }
  r.stats.iterations = qr.iterations;
  TracePoint start;
  start.relative_residual = v.relative_residual;
  start.residual = v.residual;
  r.trace.push_back(start);
  return r;
}

// A part's result that is missing, mis-sized or not finite becomes a
// NumericalError at the part's input.
void guard_shape(const Structure& part, SolveResult& r) {
  const bool shaped = r.positions.cols() == part.num_nodes() && r.forces.size() == part.num_elements();
  if (shaped && r.positions.allFinite() && r.forces.allFinite()) return;
  r.status = Status::NumericalError;
  r.message = "backend returned non-finite or missing values" + (r.message.empty() ? "" : " (" + r.message + ")");
  r.positions = part.positions;
  r.forces = Eigen::VectorXd::Zero(part.num_elements());
}

// The --verbose line of a backend without a log of its own, on standard error.
void print_iteration_line(const char* solver, const TracePoint& p, int part, int num_parts) {
  char where[32] = "";
  if (num_parts > 1) std::snprintf(where, sizeof where, " part %d/%d", part + 1, num_parts);
  std::fprintf(stderr,
               "%s:%s iteration %d: residual %.6e N, relative %.6e, geometry change %.6e m, objective %.6e, "
               "%d evaluations, %.3f s\n",
               solver, where, p.iteration, p.residual, p.relative_residual, p.geometry_change, p.objective,
               p.evaluations, p.seconds);
}

// Runs the solve of every part and merges the parts into one result; every
// backend record goes to `on_iteration` (if set) with the part's number.
template <class PartSolve>
SolveResult solve_by_parts(const Structure& scene, const SolveOptions& options, PartSolve part_solve,
                           const IterationCallback& on_iteration = {}) {
  const auto t0 = Clock::now();
  SolveResult total;
  total.status = Status::Converged;
  total.positions = scene.positions;
  total.forces = Eigen::VectorXd::Zero(scene.num_elements());

  const Partition partition = split_into_parts(scene);
  // Elements between two fixed nodes carry no equilibrium condition: give them
  // the reference force with the right sign.
  const double f0 = make_force_scale(scene, options.margin_fraction).reference_force;
  for (int e : partition.unattached_elements)
    total.forces[e] = scene.elements[e].kind == ElementKind::Cable ? f0 : -f0;

  std::string messages;
  // A free node that no element touches can only balance a zero load.
  if (scene.has_gravity()) {
    const Eigen::VectorXd mass = scene.lumped_mass();
    for (int i : partition.isolated_nodes) {
      if (mass[i] > 0.0) {
        total.status = Status::Infeasible;
        messages = "node " + std::to_string(i) + " carries weight but no element touches it";
        break;
      }
    }
  }
  for (std::size_t k = 0; k < partition.parts.size(); ++k) {
    const Part& part = partition.parts[k];
    SolveOptions part_options = options;
    part_options.time_limit_s = std::max(kSmallestPartTimeLimit, options.time_limit_s - seconds_since(t0));
    const double part_start = seconds_since(t0);
    const int part_number = static_cast<int>(k);
    const int num_parts = static_cast<int>(partition.parts.size());
    IterationObserver observer;
    if (on_iteration)
      observer = [&on_iteration, part_start, part_number, num_parts](const TracePoint& p) {
        TracePoint whole = p;
        whole.seconds += part_start;
        on_iteration(whole, part_number, num_parts);
      };
    const ScopedIterationObserver observing(observer ? &observer : nullptr);
    SolveResult r;
    try {
      r = part_solve(part.structure, part_options);
    } catch (const InputError&) {
      throw;  // bad settings are the caller's error, not a solver outcome
    } catch (const std::exception& e) {
      r = SolveResult{};
      r.status = Status::NumericalError;
      r.message = std::string("backend failed: ") + e.what();
    }
    guard_shape(part.structure, r);
    for (int i = 0; i < part.structure.num_nodes(); ++i)
      if (!part.structure.fixed[i]) total.positions.col(part.nodes[i]) = r.positions.col(i);
    for (int e = 0; e < part.structure.num_elements(); ++e) total.forces[part.elements[e]] = r.forces[e];
    total.stats.iterations += r.stats.iterations;
    if (severity(r.status) > severity(total.status)) {
      total.status = r.status;
      total.native_code = r.native_code;
    }
    if (!r.message.empty() && (partition.parts.size() == 1 || r.status != Status::Converged)) {
      if (!messages.empty()) messages += "; ";
      messages += partition.parts.size() == 1 ? r.message : "part " + std::to_string(k) + ": " + r.message;
    }
    for (TracePoint p : r.trace) {
      p.seconds += part_start;
      total.trace.push_back(p);
    }
    total.details.insert(total.details.end(), r.details.begin(), r.details.end());
  }

  const Verification v = verify(scene, total.positions, total.forces, options.tolerance);
  total.stats.seconds = seconds_since(t0);
  total.stats.residual = v.residual;
  total.stats.relative_residual = v.relative_residual;
  total.stats.geometry_change = v.geometry_change;
  if (total.status == Status::Converged && !v.ok) {
    // Never call a result converged that the independent check rejects; no
    // budget ran out, so it is the backend's accuracy that failed.
    total.status = Status::NumericalError;
    messages += (messages.empty() ? "" : "; ") + std::string("the independent verification rejected the result:");
    for (const auto& p : v.problems) messages += " " + p;
  }
  total.message = messages.empty() ? std::string(to_string(total.status)) : messages;
  return total;
}

}  // namespace

bool SolveOptions::IsValid(std::string* why) const {
  auto fail = [&](const char* reason) {
    if (why) *why = reason;
    return false;
  };
  if (!(std::isfinite(tolerance) && tolerance > 0.0)) return fail("tolerance must be a finite number > 0");
  if (max_iterations < 0) return fail("max_iterations must be >= 0 (0: the backend's default)");
  if (!(time_limit_s > 0.0) || std::isnan(time_limit_s)) return fail("time_limit_s must be > 0");
  if (!(std::isfinite(margin_fraction) && margin_fraction > 0.0 && margin_fraction < 1.0))
    return fail("margin_fraction must be in (0, 1)");
  if (!(prestress_factor > 0.0) || std::isnan(prestress_factor)) return fail("prestress_factor must be > 0");
  return true;
}

void Solver::ValidateOptions(const SolveOptions& options) const {
  validate_settings(options);
  ParseOptions(options.backend_options);
}

StressQpOptions standing_check_qp_options() {
  StressQpOptions o;
  o.certify_optimum = true;  // a claim of infeasibility needs the proof
  o.interior_point_after = kCheckInteriorPointAfter;
  o.give_up_after = kCheckGivesUpAfter;
  o.give_up_residual = kCheckGivesUpAbove;
  o.end_interior_point_when_settled = true;
  o.end_when_stalled_after = kCheckStalledAfter;
  // Its set-up and factorizations are what the check costs: through the
  // node space both cost a fraction of K's on towers (docs/BACKENDS.md).
  o.node_space = true;
  return o;
}

Eigen::VectorXd standing_check_forces(const Structure& part, const SolveOptions& options) {
  bool gave_up = false;
  SolveResult checked = forces_at_own_geometry(part, options, FixedGeometryEffort::IpoptStart, &gave_up);
  if (gave_up || checked.forces.size() != part.num_elements() || !checked.forces.allFinite())
    return Eigen::VectorXd();
  return std::move(checked.forces);
}

SolveResult Solver::Solve(const Structure& scene, const SolveOptions& options, const DriverControls& controls) const {
  validate_settings(options);
  const std::shared_ptr<const void> parsed = ParseOptions(options.backend_options);
  IterationCallback on_iteration = controls.on_iteration;
  if (options.verbose && !prints_own_log())
    on_iteration = [solver = std::string(name()), user = controls.on_iteration](const TracePoint& p, int part,
                                                                               int num_parts) {
      print_iteration_line(solver.c_str(), p, part, num_parts);
      if (user) user(p, part, num_parts);
    };
  const auto solve_part = [&](const Structure& part, const SolveOptions& part_options) {
    if (unsupported_weight(part))
      return unchanged_part(part, reference_forces(part, make_force_scale(part, part_options.margin_fraction)),
                            Status::Infeasible, "gravity acts on a part without fixed nodes: no equilibrium exists");
    SolveOptions backend_options = part_options;
    if (controls.skip_if_in_equilibrium) {
      const Clock::time_point checked = Clock::now();
      SolveResult shortcut = forces_at_own_geometry(part, part_options, FixedGeometryEffort::Check);
      if (shortcut.status == Status::Converged) return shortcut;
      // The check's time counts against the part's limit. Its forces are no
      // start: the backend finds its own, so that its answer is the one it
      // gives with --no-skip (ipopt's may be the check's, computed again).
      backend_options.time_limit_s -= seconds_since(checked);
      if (!(backend_options.time_limit_s > 0.0)) {
        shortcut.status = Status::TimeLimit;
        shortcut.message = "time budget spent checking whether the scene already stands";
        return shortcut;
      }
    }
    return DoSolve(PartProblem{part, backend_options}, parsed.get());
  };
  return solve_by_parts(scene, options, solve_part, on_iteration);
}

SolveResult solve_scene(const Solver& solver, const Structure& scene, const SolveOptions& options,
                        const DriverControls& controls) {
  return solver.Solve(scene, options, controls);
}

SolveResult solve_forces_only(const Structure& scene, const SolveOptions& options) {
  validate_settings(options);
  return solve_by_parts(scene, options, [](const Structure& part, const SolveOptions& part_options) {
    return forces_at_own_geometry(part, part_options, FixedGeometryEffort::Command);
  });
}

Solution to_solution(const SolveResult& r, const Structure& scene, std::string_view solver) {
  Solution s;
  s.scene = scene.name;
  s.solver = std::string(solver);
  s.status = r.status;
  s.positions = r.positions;
  s.forces = r.forces;
  s.stats = r.stats;
  if (!r.message.empty()) s.extra["message"] = r.message;
  if (r.native_code != 0) s.extra["native_code"] = r.native_code;
  nlohmann::json details = nlohmann::json::array();
  for (const auto& d : r.details)
    if (d) details.push_back(d->to_json());
  if (!details.empty()) s.extra["details"] = details.size() == 1 ? details.front() : details;
  return s;
}

}  // namespace tensegrity
