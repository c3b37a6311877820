#pragma once
// One backend interface (after Drake's solvers/ and Ceres): a plain options
// struct with documented defaults, one result type with a typed status, a
// message, the native solver code and a per-iteration trace. Solver library
// headers (Ipopt, NLopt) never appear here.
#include <Eigen/Core>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "model/solution.hpp"
#include "model/status.hpp"
#include "model/structure.hpp"

namespace tensegrity {

// Iteration budget of a backend when SolveOptions::max_iterations is 0.
inline constexpr int kDefaultIterationBudget = 2000;

struct SolveOptions {
  double tolerance = 1e-8;        // relative residual for `converged` (CONTRACT.md)
  // Backend iterations (outer iterations for alternating); 0: the backend's
  // own default (iteration_budget), unlike the 0 = "none" of the budgets in
  // the backends' own option structs.
  int max_iterations = 0;
  double time_limit_s = 120.0;    // wall-clock budget per solve
  double margin_fraction = 1e-3;  // sign margin as a fraction of F0 (force_scale.hpp)
  bool verbose = false;           // let the backend print its own log to stderr
  bool skip_if_in_equilibrium = true;  // stress QP first; return unchanged geometry if it verifies
  // Backend-specific `--option key=value` pairs; each backend rejects unknown keys.
  std::map<std::string, std::string> backend_options;
  // max_iterations, or `backend_default` when it is 0 (kDefaultIterationBudget
  // for every backend but the faithful alternating scheme, whose outer
  // iterations are cheap and unbounded in the paper: alternating_solver.hpp).
  int iteration_budget(int backend_default) const {
    return max_iterations > 0 ? max_iterations : backend_default;
  }
  // Forces (N) of the stress QP at the part's input geometry, when the driver
  // has already solved it (its equilibrium shortcut): backends start from them
  // instead of solving the same QP again. Empty: the backend solves it.
  Eigen::VectorXd initial_forces;

  // False with a reason when a value is out of range.
  bool IsValid(std::string* why = nullptr) const;
};

// One record per backend iteration: for run-time-against-error curves.
struct TracePoint {
  double seconds = 0.0;            // since the start of the solve
  int iteration = 0;
  int evaluations = 0;             // function evaluations so far (where meaningful)
  double residual = 0.0;           // max free-node net force (N)
  double relative_residual = 0.0;
  double geometry_change = 0.0;    // m
  double objective = 0.0;          // the backend's own objective
};

struct SolveResult {
  Status status = Status::NumericalError;
  std::string message;             // why it stopped, in words
  int native_code = 0;             // the backend library's own return code
  Eigen::Matrix3Xd positions;      // 3 x n
  Eigen::VectorXd forces;          // m (N)
  SolutionStats stats;
  std::vector<TracePoint> trace;
};

class Solver {
 public:
  virtual ~Solver() = default;
  virtual std::string_view name() const = 0;
  // Form-finds a connected part (the driver splits scenes into parts and
  // handles equilibrium shortcuts and verification; see solve_scene).
  virtual SolveResult solve_part(const Structure& part, const SolveOptions& options) const = 0;
  // Throws InputError when a backend option is unknown or malformed.
  virtual void check_options(const SolveOptions& options) const;
};

// Registry by name: "alternating", "alternating-gn", "ipopt", "nlopt", ...
std::unique_ptr<Solver> make_solver(std::string_view name);
std::vector<std::string> solver_names();
std::string default_solver_name();

// Solves a whole scene with one backend: splits it into independent parts,
// skips parts already in equilibrium, runs the backend on the rest, merges the
// parts, and re-verifies the merged result with model/verify before calling it
// converged. Never throws on solver failure; the status says what happened.
SolveResult solve_scene(const Solver& solver, const Structure& scene, const SolveOptions& options);

// Solves only the stress QP (Eq. 4) at the scene's own geometry, part by part:
// Converged if the scene already is a tensegrity, else Infeasible. The
// positions are the scene's.
SolveResult solve_forces_only(const Structure& scene, const SolveOptions& options);

// Solution record for the file (scene name, solver name, stats).
Solution to_solution(const SolveResult& r, const Structure& scene, std::string_view solver);

}  // namespace tensegrity
