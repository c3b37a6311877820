// The driver shared by every backend: parts, shortcuts, merging, verification.
#include <chrono>
#include <cmath>
#include <exception>
#include <string>

#include "formulations/components.hpp"
#include "formulations/equilibrium.hpp"
#include "formulations/force_scale.hpp"
#include "formulations/stress_qp.hpp"
#include "model/errors.hpp"
#include "model/verify.hpp"
#include "solvers/solver.hpp"

namespace tensegrity {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// Severity when parts end differently: the whole is as good as its worst part.
int severity(Status s) {
  switch (s) {
    case Status::Converged: return 0;
    case Status::MaxIterations: return 1;
    case Status::TimeLimit: return 2;
    case Status::Infeasible: return 3;
    case Status::NumericalError: return 4;
  }
  return 4;
}

bool all_finite(const SolveResult& r) {
  return r.positions.allFinite() && r.forces.allFinite();
}

// The stress QP at the part's own geometry; Converged when it verifies.
SolveResult forces_at_own_geometry(const Structure& part, const SolveOptions& options) {
  SolveResult r;
  r.positions = part.positions;
  const ForceScale scale = make_force_scale(part, options.margin_fraction);
  Equilibrium eq(part);
  eq.set_positions(part.positions);
  StressQp qp(eq, scale);
  const StressQpResult qr = qp.solve();
  r.forces = qr.sigma;
  r.stats.iterations = qr.iterations;
  const Verification v = verify(part, r.positions, r.forces, options.tolerance);
  r.status = v.ok ? Status::Converged : Status::Infeasible;
  r.message = v.ok ? "already in equilibrium at the scene geometry"
                   : "the scene geometry is not a tensegrity (stress QP relative residual " +
                         std::to_string(v.relative_residual) + ")";
  return r;
}

// Part-by-part loop shared by solve_scene and solve_forces_only.
template <class PartSolve>
SolveResult solve_by_parts(const Structure& scene, const SolveOptions& options, PartSolve part_solve) {
  const auto t0 = Clock::now();
  std::string why;
  if (!options.IsValid(&why)) throw InputError("command line", "options", why);

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
    part_options.time_limit_s = std::max(1e-3, options.time_limit_s - seconds_since(t0));
    const double part_start = seconds_since(t0);
    SolveResult r;
    try {
      r = part_solve(part.structure, part_options);
    } catch (const InputError&) {
      throw;  // bad options are the caller's error, not a solver outcome
    } catch (const std::exception& e) {
      r = SolveResult{};
      r.status = Status::NumericalError;
      r.message = std::string("backend failed: ") + e.what();
    }
    const bool shaped = r.positions.cols() == part.structure.num_nodes() &&
                        r.forces.size() == part.structure.num_elements();
    if (!shaped || !all_finite(r)) {
      r.status = Status::NumericalError;
      r.message = "backend returned non-finite or missing values" +
                  (r.message.empty() ? std::string() : " (" + r.message + ")");
      r.positions = part.structure.positions;
      r.forces = Eigen::VectorXd::Zero(part.structure.num_elements());
    }
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
  }

  const Verification v = verify(scene, total.positions, total.forces, options.tolerance);
  total.stats.seconds = seconds_since(t0);
  total.stats.residual = v.residual;
  total.stats.relative_residual = v.relative_residual;
  total.stats.geometry_change = v.geometry_change;
  if (total.status == Status::Converged && !v.ok) {
    // Never call a result converged that the independent check rejects.
    total.status = v.all_finite ? Status::MaxIterations : Status::NumericalError;
    messages += (messages.empty() ? "" : "; ") + std::string("verification failed:");
    for (const auto& p : v.problems) messages += " " + p;
  }
  total.message = messages.empty() ? std::string(to_string(total.status)) : messages;
  return total;
}

}  // namespace

SolveResult solve_forces_only(const Structure& scene, const SolveOptions& options) {
  return solve_by_parts(scene, options, forces_at_own_geometry);
}

SolveResult solve_scene(const Solver& solver, const Structure& scene, const SolveOptions& options) {
  solver.check_options(options);
  return solve_by_parts(scene, options, [&](const Structure& part, const SolveOptions& part_options) {
    if (part_options.skip_if_in_equilibrium) {
      SolveResult shortcut = forces_at_own_geometry(part, part_options);
      if (shortcut.status == Status::Converged) {
        TracePoint p;
        p.iteration = 0;
        p.relative_residual = verify(part, shortcut.positions, shortcut.forces).relative_residual;
        shortcut.trace.push_back(p);
        return shortcut;
      }
      if (shortcut.forces.size() == part.num_elements() && shortcut.forces.allFinite()) {
        SolveOptions warm = part_options;
        warm.initial_forces = std::move(shortcut.forces);
        return solver.solve_part(part, warm);
      }
    }
    return solver.solve_part(part, part_options);
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
  return s;
}

}  // namespace tensegrity
