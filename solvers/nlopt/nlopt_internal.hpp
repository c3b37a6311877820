#pragma once
// Internals of the `nlopt` backend shared by its formulations: the resolved
// options, the one wrapper around nlopt::opt::optimize and the one mapping from
// an NLopt outcome to a Status. Only solvers/nlopt/*.cpp include this header
// (it needs NLopt's).
#include <nlopt.hpp>

#include <Eigen/Core>
#include <string>
#include <vector>

#include "model/verify.hpp"
#include "solvers/nlopt/nlopt_solver.hpp"
#include "solvers/solver.hpp"
#include "solvers/trace_recorder.hpp"

namespace tensegrity::nlopt_detail {

// The full formulation's algorithms (`algorithm`).
enum class Algorithm { AlLbfgs, AlTnewton, AlMma, AlCcsaq, PenaltyLbfgs, AuglagEqLbfgs, Slsqp };
// The reduced formulation's algorithms (`varpro_algorithm`).
enum class ReducedAlgorithm { Auto, Slsqp, Ccsaq, Mma, AuglagLbfgs, AlLbfgs, AlTnewton };

const char* algorithm_name(Algorithm a);
const char* reduced_algorithm_name(ReducedAlgorithm a);

// NloptOptions resolved for one solve: choices as enums and the evaluation
// budget as a number.
struct NloptRun {
  bool reduced = true;  // formulation=varpro
  Algorithm algorithm = Algorithm::AlLbfgs;
  ReducedAlgorithm reduced_algorithm = ReducedAlgorithm::Slsqp;
  double ftol_rel = 1e-15;
  double xtol_rel = 1e-15;
  long maxeval = 0;
  double penalty_initial = 10.0;
  double varpro_penalty_initial = 100.0;
  double penalty_growth = 10.0;
  double penalty_max = 1e12;
  int lbfgs_memory = 0;
  bool init_from_qp = true;
  int varpro_rounds = 4;
};

// Evaluations per iteration of the budget when maxeval is not given.
inline constexpr long kEvaluationsPerIteration = 100;
inline constexpr long kLargestEvaluationBudget = 1L << 30;  // NLopt counts evaluations in an int

NloptRun resolve(const NloptOptions& o, const SolveOptions& options);

// Why we (not NLopt) stopped a run from inside a callback.
enum class ForcedStop { None, TimeLimit, NonFinite, InnerConverged };

// What a run ended with: NLopt's last code, our own forced stop, counters.
struct RunEnd {
  nlopt::result code = nlopt::FAILURE;
  ForcedStop forced = ForcedStop::None;
  long evaluations = 0;
  int iterations = 0;
};

// A formulation's answer for one part, before verification.
struct PartAnswer {
  Eigen::Matrix3Xd positions;  // m
  Eigen::VectorXd forces;      // N
  RunEnd end;
};

// Before an outer loop's next NLopt run: the seconds left, or 0 with `code`
// set to what ran out (MAXTIME_REACHED, MAXEVAL_REACHED).
inline double outer_time_left(const SolveOptions& so, const TraceRecorder& recorder, long evaluations, long maxeval,
                              nlopt::result& code) {
  const double remaining = so.time_limit_s - recorder.seconds();
  if (remaining <= 0.0) {
    code = nlopt::MAXTIME_REACHED;
    return 0.0;
  }
  if (evaluations >= maxeval) {
    code = nlopt::MAXEVAL_REACHED;
    return 0.0;
  }
  return remaining;
}

// Runs NLopt and returns its result code. The C++ interface reports the
// negative codes as exceptions (mythrow in nlopt.hpp); translating them back to
// the codes they stand for is lossless, so status_from_nlopt is the one place
// where any NLopt outcome becomes a Status. x keeps NLopt's best point.
nlopt::result run_nlopt(nlopt::opt& opt, std::vector<double>& x);

const char* result_name(nlopt::result r);

// The one mapping from an NLopt outcome to our Status. A result is converged
// only when model/verify's equilibrium check accepts it, whatever NLopt said
// (a roundoff-limited stop on an equilibrium is still an equilibrium). A
// convergence stop (SUCCESS, FTOL, XTOL, STOPVAL) that the check rejects is a
// stall: NLopt's own tests stopped it short of equilibrium, which proves nothing.
Status status_from_nlopt(nlopt::result code, ForcedStop forced, const Verification& check);

// Eq. 5 whole in (positions, forces) (nlopt_full.cpp).
PartAnswer solve_full(const Structure& part, const SolveOptions& options, const NloptRun& run,
                      TraceRecorder& recorder);

// Eq. 5 reduced to the positions by variable projection, one scalar
// constraint (nlopt_varpro.cpp).
PartAnswer solve_reduced(const Structure& part, const SolveOptions& options, const NloptRun& run,
                         TraceRecorder& recorder);

// The same reduced formulation by the method of multipliers on its residual
// vector (nlopt_varpro_multipliers.cpp): varpro_algorithm al-lbfgs, al-tnewton.
PartAnswer solve_reduced_multipliers(const Structure& part, const SolveOptions& options, const NloptRun& run,
                                     TraceRecorder& recorder);

}  // namespace tensegrity::nlopt_detail
