#include "solvers/ipopt/ipopt_solver.hpp"

#include <coin/IpIpoptApplication.hpp>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

#include "formulations/equilibrium.hpp"
#include "formulations/force_scale.hpp"
#include "formulations/minimal_geometry_change_nlp.hpp"
#include "kernels/stress_qp.hpp"
#include "model/errors.hpp"
#include "model/verify.hpp"
#include "solvers/ipopt/dimensionless_eq5.hpp"
#include "solvers/option_reader.hpp"
#include "solvers/trace_recorder.hpp"

namespace tensegrity {
namespace {

// The project's own key among the native Ipopt options.
constexpr const char* kStartKey = "start";
constexpr const char* kPrestressKey = "prestress";
// prestress=cap keeps the capped run's answer only when its change is smaller
// by more than round-off (the two runs often end at the same optimum).
constexpr double kSignificantlySmaller = 1e-9;
// The MUMPS ordering for Eq. 5's KKT matrix: 6 = QAMD, the ordering made for
// quasi-dense rows such as the force-scale row (docs/BACKENDS.md compares them).
constexpr int kQuasiDenseOrdering = 6;

// The equilibrium alternating-gn reaches from the part's geometry, or an
// empty result when it does not converge within the same settings.
SolveResult equilibrium_start(const Structure& part, const SolveOptions& options) {
  SolveOptions start_options = options;
  start_options.backend_options.clear();
  start_options.verbose = false;
  DriverControls controls;
  controls.skip_if_in_equilibrium = false;  // the driver has checked the part already
  SolveResult start = make_solver("alternating-gn")->Solve(part, start_options, controls);
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

// `key=value` typed by Ipopt's own registry; OptionError when Ipopt does not
// know the key or rejects the value.
IpoptOption typed_native_option(Ipopt::IpoptApplication& app, const std::string& key, const std::string& value) {
  auto fail = [&](const std::string& reason) { throw OptionError("ipopt", key, value, reason); };
  Ipopt::SmartPtr<const Ipopt::RegisteredOption> reg = app.RegOptions()->GetOption(key);
  if (Ipopt::IsNull(reg)) fail("not an Ipopt option");
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
      if (value == "scene") o.start = IpoptStart::Scene;
      else if (value == "alternating-gn") o.start = IpoptStart::AlternatingGn;
      else throw OptionError("ipopt", key, value, "not a start (valid: scene, alternating-gn)");
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

SolveResult IpoptSolver::DoSolve(const PartProblem& part_problem, const IpoptOptions& ipopt_options) const {
  const Structure& part = part_problem.part;
  const SolveOptions& options = part_problem.options;
  TraceRecorder recorder(options.time_limit_s);
  SolveResult result;
  const ForceScale scale = make_force_scale(part, options.margin_fraction, options.prestress_factor);
  const double max_free_weight = part.max_free_node_weight();

  MinimalGeometryChangeNlp nlp(part, scale);
  Eigen::VectorXd sigma0;
  if (part_problem.initial_forces.size() == part.num_elements() && part_problem.initial_forces.allFinite()) {
    sigma0 = part_problem.initial_forces;  // the driver's stress QP at this geometry, same scale
  } else {
    StressQp qp(nlp.equilibrium(), scale);
    sigma0 = qp.solve().sigma;
    if (sigma0.size() != part.num_elements() || !sigma0.allFinite()) sigma0 = reference_forces(part, scale);
  }
  result.positions = part.positions;
  result.forces = sigma0;

  // Ipopt's constraint violation is the max-norm of f / F0; the contract asks
  // |f_i| <= tolerance * load scale, where the load scale is the largest
  // free-node weight with gravity and otherwise max |sigma| >= F0 (mean cable
  // force = F0). A tenth of that, for the three components of a node.
  const double load_over_force =
      max_free_weight > 0.0 ? std::min(1.0, max_free_weight / scale.reference_force) : 1.0;
  const double constraint_tolerance = 0.1 * options.tolerance * load_over_force / std::sqrt(3.0);

  SolveResult start;
  if (ipopt_options.start == IpoptStart::AlternatingGn) start = equilibrium_start(part, options);
  const bool from_equilibrium = start.positions.cols() == part.num_nodes();

  IpoptSettings settings;
  settings.verbose = options.verbose;
  settings.set("linear_solver", "mumps");
  settings.set("mumps_pivot_order", kQuasiDenseOrdering);
  settings.set("hessian_approximation", "exact");
  settings.set("mu_strategy", "adaptive");
  // Tight: on scenes that need no change the barrier leaves a drift of order mu.
  settings.set("tol", std::min(1e-12, options.tolerance));
  settings.set("constr_viol_tol", constraint_tolerance);
  settings.set("acceptable_tol", 1e-8);
  settings.set("acceptable_constr_viol_tol", constraint_tolerance);
  settings.set("acceptable_iter", 5);
  // Ipopt relaxes bounds by this (y is O(1) near the margins) and projects the
  // result back onto them afterwards; that projection moves forces, so it must
  // stay below what the residual test can see.
  settings.set("bound_relax_factor", 0.1 * constraint_tolerance);
  settings.set("max_iter", options.iteration_budget(kDefaultIterationBudget));
  // No max_cpu_time: Ipopt 3.11 measures the CPU time of the whole process, so
  // with solves on other threads it stops early (two busy threads: after half
  // the budget). The wall-clock limit is checked in every iteration instead.
  settings.options.insert(settings.options.end(), ipopt_options.typed.begin(), ipopt_options.typed.end());

  DimensionlessEq5 problem(nlp, sigma0);
  if (from_equilibrium) problem.set_start(nlp.equilibrium().free_nodes().gather(start.positions), start.forces);
  settings.on_iteration = [&](const IpoptIteration& it) {
    recorder.record(problem.trace_point(it, max_free_weight));
    return recorder.out_of_time() ? IterationControl::StopForTimeLimit : IterationControl::Continue;
  };
  const IpoptSolveResult run = solve_with_ipopt(problem, settings);
  result.native_code = run.return_code;
  result.status = run.status;
  result.message = run.message;
  if (from_equilibrium)
    result.message += " (started from alternating-gn's equilibrium after " + std::to_string(start.stats.iterations) +
                      " iterations)";
  result.stats.iterations = run.iterations;
  auto details = std::make_shared<IpoptDetails>();
  details->return_code = run.return_code;
  details->iterations = run.iterations;
  result.details = {details};  // shared: the capped run below adds to it

  if (problem.has_final_point() && problem.final_point().allFinite()) {
    result.positions = nlp.positions(problem.final_point());
    result.forces = nlp.forces(problem.final_point());
  }
  Verification v = verify(part, result.positions, result.forces, options.tolerance);
  if (ipopt_options.prestress == IpoptPrestress::Cap && scale.has_prestress_cap() &&
      result.status == Status::Converged && v.ok && !recorder.out_of_time()) {
    // The capped problem restarted at the held optimum: a feasible start, so
    // Ipopt stays near it instead of wandering as it does from the scene.
    MinimalGeometryChangeNlp capped_nlp(part, scale, PrestressRow::Cap);
    DimensionlessEq5 capped(capped_nlp, sigma0);
    capped.set_start(capped_nlp.equilibrium().free_nodes().gather(result.positions), result.forces);
    // One trace for both runs: the capped run's iteration 0 is the held
    // optimum, already recorded; its counts continue the held run's.
    const int iteration_offset = run.iterations;
    const int evaluation_offset = recorder.trace().empty() ? 0 : recorder.trace().back().evaluations;
    settings.on_iteration = [&](const IpoptIteration& it) {
      if (it.iteration > 0) {
        TracePoint p = capped.trace_point(it, max_free_weight);
        p.iteration += iteration_offset;
        p.evaluations += evaluation_offset;
        recorder.record(p);
      }
      return recorder.out_of_time() ? IterationControl::StopForTimeLimit : IterationControl::Continue;
    };
    const IpoptSolveResult capped_run = solve_with_ipopt(capped, settings);
    details->iterations += capped_run.iterations;
    result.stats.iterations += capped_run.iterations;
    if (capped_run.status == Status::Converged && capped.has_final_point() && capped.final_point().allFinite()) {
      const Eigen::Matrix3Xd x = capped_nlp.positions(capped.final_point());
      const Eigen::VectorXd sigma = capped_nlp.forces(capped.final_point());
      const Verification vc = verify(part, x, sigma, options.tolerance);
      if (vc.ok && vc.geometry_change < (1.0 - kSignificantlySmaller) * v.geometry_change) {
        result.positions = x;
        result.forces = sigma;
        v = vc;
        details->prestress_cap_kept = true;
        result.message += " (mean cable force below the cap)";
      }
    }
  }
  if (result.status == Status::Converged && !v.ok && v.all_finite && v.wrong_signs == 0) {
    // Ipopt's scaled stopping test was met but not the contract's: one stress
    // solve at the final geometry, warm-started from Ipopt's forces.
    Equilibrium eq(part);
    eq.set_positions(result.positions);
    StressQp qp(eq, scale);
    const Eigen::VectorXd polished = qp.solve(result.forces).sigma;
    const Verification vp = verify(part, result.positions, polished, options.tolerance);
    if (vp.ok) {
      result.forces = polished;
      v = vp;
      result.message += " (forces polished by the stress QP)";
    }
  }
  if (!v.all_finite) {
    result.status = Status::NumericalError;
    result.positions = part.positions;
    result.forces = sigma0;
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
  return j;
}

std::unique_ptr<Solver> make_ipopt_solver() { return std::make_unique<IpoptSolver>(); }

}  // namespace tensegrity
