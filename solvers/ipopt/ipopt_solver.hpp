#pragma once
// The `ipopt` backend: Eq. 5 (formulations/minimal_geometry_change_nlp.hpp)
// solved whole by Ipopt's interior-point method with MUMPS, through the one
// Ipopt adapter (kernels/ipopt_solve.hpp). No Ipopt header is included here.
//
// Ipopt sees a dimensionless problem: y = ((q - q0) / L, sigma / F0), equality
// rows f / F0 and c^T sigma / F0 (L = mean element length, F0 the ForceScale
// reference force), so its tolerances mean the same at every scene scale.
// Starting point (option `start`): `eq5-newton` (the default), the eq5-newton
// backend's answer (at a local optimum the point itself, with a barrier of its
// order, and where eq5-newton's KKT test passed its multipliers too; where
// that answer is eq5-newton's closest verified iterate, alternating-gn's
// equilibrium instead), then, while no run gives a verified answer, alternating-gn's
// equilibrium and the scene; `scene`, the
// scene geometry with the stress QP's forces; `alternating-gn`, the
// equilibrium that alternating-gn reaches from the scene (the scene again when
// it does not converge); `auto`, alternating-gn's equilibrium and the scene,
// each with an iteration budget that a converging run does not need, keeping
// the closer verified answer: two runs independent of eq5-newton, for
// comparing the two. docs/BACKENDS.md compares them.
//
// Defaults: exact Hessian, linear_solver mumps with the QAMD ordering (the
// force-scale row couples every cable force, and QAMD keeps such quasi-dense
// rows out of the fill-reducing ordering), tol 1e-12, constr_viol_tol
// derived from SolveOptions::tolerance (so that Ipopt's success implies the
// relative residual of docs/FORMATS.md), mu_strategy adaptive, max_iter from the
// iteration budget (SolveOptions::iteration_budget), the time limit checked
// on the wall clock in every iteration (Ipopt's own max_cpu_time counts the
// CPU time of the whole process, so other threads would cut it short),
// print_level 0 and no banner unless verbose (then Ipopt's log goes to
// stderr; stdout may carry the solution).
//
// `--option key=value` (SolveOptions::backend_options) passes any Ipopt option
// through, e.g. hessian_approximation=limited-memory, mu_strategy=monotone,
// tol=1e-9, max_iter=500. Each value is typed and range-checked by Ipopt's
// own option registry; an unknown name or a rejected value is an OptionError
// that names the valid values.
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "kernels/ipopt_solve.hpp"
#include "solvers/solver.hpp"

namespace tensegrity {

// Where Ipopt starts: the scene geometry with the stress QP's forces, the
// equilibrium that alternating-gn finds, or eq5-newton's answer (the objective
// still measures the change from the scene geometry, so this is a start, not a
// different problem). `Auto` runs the first two: first from alternating-gn's
// equilibrium, then (unless the first answer is the scene to round-off) from
// the scene with an iteration budget of a few times the first run's, and keeps
// the closer verified answer. `Eq5Newton` starts at eq5-newton's local
// optimum (at the point itself, with a barrier of the optimum's order, from
// its multipliers where its KKT test passed) and
// solves the capped problem directly under gravity with prestress=cap; only
// when that run gives no verified answer does Ipopt run from alternating-gn's
// equilibrium, and then from the scene.
enum class IpoptStart { Auto, Scene, AlternatingGn, Eq5Newton };

// Under gravity, Eq. 5's mean cable force: held at kappa times the weight
// (`equal`), or first held there and then only capped by it, Ipopt restarting
// from the held optimum and keeping the smaller verified change (`cap`).
enum class IpoptPrestress { Equal, Cap };

// `start=eq5-newton|auto|scene|alternating-gn` (default eq5-newton), `prestress=equal|cap`
// (default cap: never farther than `equal`, docs/THEORY-force-scale.md) and native Ipopt options given as `--option key=value`,
// checked against Ipopt's own registry (name, type and range).
struct IpoptOptions {
  IpoptStart start = IpoptStart::Eq5Newton;
  IpoptPrestress prestress = IpoptPrestress::Cap;
  OptionPairs native;  // every pair except `start` and `prestress`
  std::vector<IpoptOption> typed;  // `native` with the types of Ipopt's registry
  static IpoptOptions FromPairs(const OptionPairs& pairs);
  bool IsValid(std::string* why = nullptr) const;
};

// The solution file's "details" of an ipopt part solve (docs/FORMATS.md).
struct IpoptDetails : SolverDetails {
  int return_code = 0;  // Ipopt's ApplicationReturnStatus (0: Solve_Succeeded)
  int iterations = 0;   // Ipopt's own iteration count, over every run of the part
  // start=auto, start=eq5-newton: the run from the scene's iterations (-1:
  // not run) and whether its answer was kept (converged, verified and closer
  // than the warm run's).
  int cold_start_iterations = -1;
  bool cold_start_kept = false;
  // prestress=cap under gravity: the capped run's change was kept (it was
  // smaller than the held run's and verified).
  bool prestress_cap_kept = false;
  // Under gravity: Ipopt's multiplier of the held run's cable-sum row
  // (dimensionless, DimensionlessEq5::cable_sum_multiplier; NaN without one),
  // and whether it shows the cap binding at a verified held optimum, in which
  // case prestress=cap runs no capped restart (that optimum satisfies the
  // capped problem's KKT conditions already).
  double cable_sum_multiplier = std::numeric_limits<double>::quiet_NaN();
  bool prestress_cap_binds = false;
  nlohmann::json to_json() const override;
};

class IpoptSolver : public SolverWithOptions<IpoptOptions> {
 public:
  std::string_view name() const override { return "ipopt"; }
  bool prints_own_log() const override { return true; }  // Ipopt's iteration log under verbose

 protected:
  SolveResult DoSolve(const PartProblem& problem, const IpoptOptions& options) const override;
};

std::unique_ptr<Solver> make_ipopt_solver();

}  // namespace tensegrity
