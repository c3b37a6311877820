#pragma once
// Ipopt (interior point, MUMPS) on any SparseNlp, and the one reading of
// Ipopt's return codes as the project's Status. No Ipopt header is included:
// Ipopt is a private dependency of this library.
//
// MUMPS (sequential, as Debian builds it for Ipopt 3.11) keeps global state
// and is not thread-safe, so solve_with_ipopt holds one process-wide lock
// from before the Ipopt application exists until after it is destroyed:
// concurrent calls from several threads run one after the other.
#include <Eigen/Core>

#include <functional>
#include <string>
#include <variant>
#include <vector>

#include "kernels/sparse_nlp.hpp"
#include "model/status.hpp"

namespace tensegrity {

// One Ipopt option (e.g. {"tol", 1e-10}, {"max_iter", 3000}, {"mu_strategy", "adaptive"}).
struct IpoptOption {
  std::string name;
  std::variant<std::string, int, double> value;
};

// What the per-iteration callback sees of an Ipopt iteration.
struct IpoptIteration {
  int iteration = 0;
  double objective = 0.0;
  double primal_infeasibility = 0.0;  // max-norm of Ipopt's (scaled) constraint violation
  double dual_infeasibility = 0.0;    // max-norm of Ipopt's (scaled) dual infeasibility
  double barrier_parameter = 0.0;     // mu, which bounds the complementarity Ipopt aims at
  // The iterate in the problem's own variables; null in the restoration
  // phase, where Ipopt does not expose it.
  const Eigen::VectorXd* x = nullptr;
};

enum class IterationControl {
  Continue,
  StopForTimeLimit,  // the caller's time budget ran out: the solve ends as TimeLimit
  StopSatisfied,     // the iterate passes the caller's own test: the solve ends as Converged
};

struct IpoptSettings {
  // Applied in order after the defaults (sb=yes, print_level 0 or 5 with
  // verbose, mumps_mem_percent 100); a later value of the same option wins.
  std::vector<IpoptOption> options;
  bool verbose = false;  // Ipopt's log to stderr (never stdout, which may carry a solution)
  std::function<IterationControl(const IpoptIteration&)> on_iteration;  // optional

  void set(const std::string& name, const char* value) { options.push_back({name, std::string(value)}); }
  void set(const std::string& name, const std::string& value) { options.push_back({name, value}); }
  void set(const std::string& name, int value) { options.push_back({name, value}); }
  void set(const std::string& name, double value) { options.push_back({name, value}); }
};

// Ipopt's return code (ApplicationReturnStatus) in the project's terms:
//   Solve_Succeeded, Solved_To_Acceptable_Level  -> Converged (a candidate:
//                                                   callers verify the point)
//   Infeasible_Problem_Detected                  -> Infeasible for a convex problem
//                                                   (SparseNlp::is_convex), otherwise
//                                                   Stalled: local infeasibility is no proof
//   Maximum_Iterations_Exceeded                  -> MaxIterations
//   Maximum_CpuTime_Exceeded                     -> TimeLimit
//   User_Requested_Stop                          -> TimeLimit when the callback stopped for
//                                                   the time limit, Converged when it stopped
//                                                   satisfied, otherwise NumericalError
//   every other code                             -> NumericalError
// The message names the outcome ("Ipopt: ..."); callers may make it more specific.
struct IpoptOutcome {
  Status status = Status::NumericalError;
  std::string message;
};
IpoptOutcome ipopt_outcome(int return_code, bool convex_problem, bool stopped_for_time_limit,
                           bool stopped_satisfied = false);

struct IpoptSolveResult {
  Status status = Status::NumericalError;  // ipopt_outcome, or NumericalError when Ipopt did not run
  std::string message;
  int return_code = -199;  // Ipopt's ApplicationReturnStatus (Internal_Error when Ipopt did not run)
  int iterations = 0;
  bool has_solution = false;  // SparseNlp::finalize was called (always so when Converged)
};

// Minimizes `problem` from its starting point; the final point reaches the
// problem through SparseNlp::finalize.
IpoptSolveResult solve_with_ipopt(SparseNlp& problem, const IpoptSettings& settings);

}  // namespace tensegrity
