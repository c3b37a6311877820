#pragma once
// Form finding behind one interface (after Drake's solvers/ and Ceres).
//
// A backend is a Solver. Callers use the non-virtual Solver::Solve, which
// validates the settings and parses the backend's options once, splits the
// scene into connected parts, runs the shared prechecks (gravity on a part
// without supports: infeasible; a part already in equilibrium: returned
// unchanged), calls the backend's protected DoSolve on every other part,
// merges, verifies the merged result once with model/verify and maps the
// outcome to one Status. Backends never see scenes, only parts.
//
// Units: positions in m, forces in N (positive = tension), times in s.
// Solver library headers (Ipopt, NLopt) never appear here.
#include <Eigen/Core>
#include <functional>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "formulations/force_scale.hpp"
#include "model/solution.hpp"
#include "model/status.hpp"
#include "model/structure.hpp"

namespace tensegrity {

// Iteration budget of a backend when SolveOptions::max_iterations is 0.
inline constexpr int kDefaultIterationBudget = 2000;

// Backend-specific `key=value` settings, parsed by each backend into its own
// typed options struct.
using OptionPairs = std::map<std::string, std::string>;

// Settings of a solve, the same for every backend.
struct SolveOptions {
  double tolerance = 1e-8;        // relative residual for `converged`
  // Backend iterations (outer iterations for alternating); 0: the backend's
  // own default (iteration_budget).
  int max_iterations = 0;
  double time_limit_s = 120.0;    // wall-clock budget of the whole solve
  double margin_fraction = 1e-3;  // sign margin as a fraction of F0 (formulations/force_scale.hpp)
  // kappa of Eq. 5 under gravity: mean cable force at most kappa times the
  // part's weight (formulations/force_scale.hpp, kDefaultPrestressFactor).
  double prestress_factor = kDefaultPrestressFactor;
  // Log to stderr: the backend's own log where it has one (prints_own_log),
  // else one line per iteration record from the driver.
  bool verbose = false;
  OptionPairs backend_options;    // parsed and validated by the backend

  // max_iterations, or `backend_default` when it is 0.
  int iteration_budget(int backend_default) const {
    return max_iterations > 0 ? max_iterations : backend_default;
  }
  // False with the reason when a value is out of range.
  bool IsValid(std::string* why = nullptr) const;
};

// One record per backend iteration; iteration 0 is the starting point.
struct TracePoint {
  double seconds = 0.0;            // since the start of the solve
  int iteration = 0;
  int evaluations = 0;             // function evaluations so far (where meaningful)
  double residual = 0.0;           // max free-node net force (N)
  double relative_residual = 0.0;
  double geometry_change = 0.0;    // m
  double objective = 0.0;          // the backend's own objective (see its header)
};

// Called after every backend iteration with its record (`seconds` counted
// from the start of the whole solve), the connected part it belongs to and the
// number of parts. It runs on the solving thread inside the backend's loop, so
// it must be cheap and must not throw; the record is only valid during the call.
using IterationCallback = std::function<void(const TracePoint& point, int part, int num_parts)>;

// Switches of the scene driver (not settings of the method).
struct DriverControls {
  DriverControls() = default;
  // DriverControls{false}: without the shortcut below.
  explicit DriverControls(bool skip) : skip_if_in_equilibrium(skip) {}

  // Solve the stress QP first and return a part unchanged when its geometry
  // already is a tensegrity (off for benchmarks that time the method itself).
  bool skip_if_in_equilibrium = true;
  // Progress of the backends (none when empty).
  IterationCallback on_iteration;
};

// What a backend reports beyond the common fields (counts of non-optimal
// inner solves, restarts used, native codes, ...). Written to the solution
// file under "details".
struct SolverDetails {
  virtual ~SolverDetails() = default;
  virtual nlohmann::json to_json() const = 0;

  // Eq. 5's multipliers at the part's answer, where the backend ends at a
  // KKT point of it; empty otherwise, and not written
  // to the solution file. In the terms of MinimalGeometryChangeNlp
  // (grad phi + J^T rows - z_lower + z_upper = 0 in z = (q, sigma)): `rows`
  // per row of its constraints (1/N), `force_bounds` per member the multiplier
  // of its sign bound (>= 0, 1/N: z_lower of a cable, z_upper of a strut).
  // Another backend can start from them (ipopt from eq5-newton's answer).
  Eigen::VectorXd eq5_row_multipliers;
  Eigen::VectorXd eq5_force_bound_multipliers;
};

struct SolveResult {
  Status status = Status::NumericalError;
  std::string message;             // why it stopped, in words
  int native_code = 0;             // the backend library's own return code
  Eigen::Matrix3Xd positions;      // 3 x n (m)
  Eigen::VectorXd forces;          // m (N)
  SolutionStats stats;
  std::vector<TracePoint> trace;
  // Per part, in part order (null where a part needed no backend run).
  std::vector<std::shared_ptr<const SolverDetails>> details;
};

class Solver {
 public:
  virtual ~Solver() = default;
  virtual std::string_view name() const = 0;
  // True when the backend prints its own iteration log under
  // SolveOptions::verbose; otherwise the driver prints one line per record.
  virtual bool prints_own_log() const { return false; }

  // Form-finds `scene`. Throws InputError (OptionError for backend options)
  // for invalid settings; every solver outcome is a status, never an exception.
  SolveResult Solve(const Structure& scene, const SolveOptions& options, const DriverControls& controls = {}) const;

  // Throws what Solve would throw for these settings, without solving.
  void ValidateOptions(const SolveOptions& options) const;

 protected:
  // One connected part and its settings. The driver's check whether the part
  // already stands hands nothing on: a backend's answer does not depend on it.
  struct PartProblem {
    const Structure& part;
    const SolveOptions& options;
  };

  // The backend's options, parsed from key=value pairs and validated
  // (OptionError naming the option and its valid range).
  virtual std::shared_ptr<const void> ParseOptions(const OptionPairs& pairs) const = 0;
  // Solves one part. Positions and forces must be sized to the part; the
  // driver verifies them. Converged is a claim the driver checks.
  virtual SolveResult DoSolve(const PartProblem& problem, const void* parsed_options) const = 0;
};

// A backend whose options are the struct `Options`, which provides
// `static Options FromPairs(const OptionPairs&)` (OptionError for unknown keys
// and malformed or out-of-range values) and `bool IsValid(std::string*) const`.
template <class Options>
class SolverWithOptions : public Solver {
 protected:
  virtual SolveResult DoSolve(const PartProblem& problem, const Options& options) const = 0;

 private:
  std::shared_ptr<const void> ParseOptions(const OptionPairs& pairs) const final {
    return std::make_shared<const Options>(Options::FromPairs(pairs));
  }
  SolveResult DoSolve(const PartProblem& problem, const void* parsed_options) const final {
    return DoSolve(problem, *static_cast<const Options*>(parsed_options));
  }
};

// Registry by name: "alternating", "alternating-gn", "eq5-newton", "ipopt", "nlopt".
// Throws InputError for an unknown name.
std::unique_ptr<Solver> make_solver(std::string_view name);
std::vector<std::string> solver_names();
std::string default_solver_name();

// The same as solver.Solve(scene, options, controls).
SolveResult solve_scene(const Solver& solver, const Structure& scene, const SolveOptions& options,
                        const DriverControls& controls = {});

// The stress QP (Eq. 4) alone at the scene's own geometry, part by part:
// Converged when the scene already is a tensegrity; Infeasible when the QP's
// optimum has a positive residual; otherwise the QP's own stop (e.g.
// MaxIterations). The positions are the scene's.
SolveResult solve_forces_only(const Structure& scene, const SolveOptions& options);

// Solution record for the file (scene name, solver name, stats, message, details).
Solution to_solution(const SolveResult& r, const Structure& scene, std::string_view solver);

}  // namespace tensegrity
