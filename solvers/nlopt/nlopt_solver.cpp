#include "solvers/nlopt/nlopt_solver.hpp"

#include <algorithm>
#include <limits>
#include <sstream>

#include "model/errors.hpp"
#include "model/verify.hpp"
#include "solvers/nlopt/nlopt_internal.hpp"
#include "solvers/option_reader.hpp"

namespace tensegrity {
namespace nlopt_detail {
namespace {

struct AlgorithmEntry {
  const char* name;
  Algorithm algorithm;
};

constexpr AlgorithmEntry kAlgorithms[] = {
    {"al-lbfgs", Algorithm::AlLbfgs},       {"al-tnewton", Algorithm::AlTnewton},
    {"al-mma", Algorithm::AlMma},           {"al-ccsaq", Algorithm::AlCcsaq},
    {"penalty-lbfgs", Algorithm::PenaltyLbfgs}, {"auglag-eq-lbfgs", Algorithm::AuglagEqLbfgs},
    {"slsqp", Algorithm::Slsqp},
};

struct ReducedAlgorithmEntry {
  const char* name;
  ReducedAlgorithm algorithm;
};

constexpr ReducedAlgorithmEntry kReducedAlgorithms[] = {
    {"auto", ReducedAlgorithm::Auto},
    {"slsqp", ReducedAlgorithm::Slsqp},
    {"ccsaq", ReducedAlgorithm::Ccsaq},
    {"mma", ReducedAlgorithm::Mma},
    {"auglag-lbfgs", ReducedAlgorithm::AuglagLbfgs},
    {"al-lbfgs", ReducedAlgorithm::AlLbfgs},
    {"al-tnewton", ReducedAlgorithm::AlTnewton},
};

void fill_stats(SolveResult& r, const Verification& v, int iterations, double seconds) {
  r.stats.iterations = iterations;
  r.stats.seconds = seconds;
  r.stats.residual = v.residual;
  r.stats.relative_residual = v.relative_residual;
  r.stats.geometry_change = v.geometry_change;
}

}  // namespace

const char* algorithm_name(Algorithm a) {
  for (const auto& e : kAlgorithms)
    if (e.algorithm == a) return e.name;
  return "?";
}

const char* reduced_algorithm_name(ReducedAlgorithm a) {
  for (const auto& e : kReducedAlgorithms)
    if (e.algorithm == a) return e.name;
  return "?";
}

NloptRun resolve(const NloptOptions& o, const SolveOptions& options) {
  NloptRun run;
  run.reduced = o.formulation == "varpro";
  for (const auto& e : kAlgorithms)
    if (o.algorithm == e.name) run.algorithm = e.algorithm;
  for (const auto& e : kReducedAlgorithms)
    if (o.varpro_algorithm == e.name) run.reduced_algorithm = e.algorithm;
  run.ftol_rel = o.ftol_rel;
  run.xtol_rel = o.xtol_rel;
  // An evaluation of the reduced formulation is a stress-QP solve, which is
  // what its iterations count; the full formulation's outer iterations each
  // take many evaluations.
  const long per_iteration = run.reduced ? 1 : kEvaluationsPerIteration;
  run.maxeval = o.maxeval > 0 ? o.maxeval
                              : std::min(per_iteration * options.iteration_budget(kDefaultIterationBudget),
                                         kLargestEvaluationBudget);
  run.penalty_initial = o.penalty_initial;
  run.varpro_penalty_initial = o.varpro_penalty_initial;
  run.penalty_growth = o.penalty_growth;
  run.penalty_max = o.penalty_max;
  run.lbfgs_memory = o.lbfgs_memory;
  run.init_from_qp = o.init == "qp";
  run.varpro_rounds = o.varpro_rounds;
  return run;
}

// varpro_algorithm=auto: the multiplier method with this share of the
// evaluation budget and of the time limit; where it ends unverified, the
// scalar-constraint route with the rest.
constexpr double kAutoMultiplierShare = 0.5;

ReducedAlgorithm scalar_route_for(const Structure& part) {
  // SLSQP's dense subproblem costs the cube of the variable count per
  // iteration and cannot be interrupted, so larger parts take CCSAQ.
  return 3 * part.num_free_nodes() <= kLargestDenseSlsqpVariables ? ReducedAlgorithm::Slsqp : ReducedAlgorithm::Ccsaq;
}

// The multiplier method reaches the optimum in a fraction of the QP solves
// of the scalar route where the equilibrium set has codimension above one,
// but stalls on near-degenerate geometry (nearly coincident nodes, nearly
// parallel elements) where the scalar route converges; auto runs the first
// and, where it ends unverified, the second from the scene, keeping the
// answer with the smaller residual. `route` names what ran.
PartAnswer solve_reduced_auto(const Structure& part, const SolveOptions& options, const NloptRun& o,
                              TraceRecorder& recorder, std::string& route) {
  NloptRun first = o;
  first.reduced_algorithm = ReducedAlgorithm::AlLbfgs;
  first.maxeval = std::max(1L, static_cast<long>(kAutoMultiplierShare * static_cast<double>(o.maxeval)));
  SolveOptions first_options = options;
  first_options.time_limit_s = kAutoMultiplierShare * options.time_limit_s;
  PartAnswer answer = solve_reduced_multipliers(part, first_options, first, recorder);
  route = reduced_algorithm_name(first.reduced_algorithm);
  const Verification first_check = verify(part, answer.positions, answer.forces, options.tolerance);
  if (first_check.ok || recorder.out_of_time() || answer.end.forced == ForcedStop::NonFinite) return answer;

  // maxeval bounds NLopt's evaluations, which are the iterations.
  const long remaining = o.maxeval - answer.end.iterations;
  if (remaining < 1) return answer;
  NloptRun second = o;
  second.reduced_algorithm = scalar_route_for(part);
  second.maxeval = remaining;
  // One trace: the second run's iterations continue the first's.
  recorder.set_count_offset(answer.end.iterations);
  PartAnswer fallback = solve_reduced(part, options, second, recorder);
  recorder.set_count_offset(0);
  fallback.end.iterations += answer.end.iterations;
  fallback.end.evaluations += answer.end.evaluations;
  route += std::string(", then ") + reduced_algorithm_name(second.reduced_algorithm);
  const Verification second_check = verify(part, fallback.positions, fallback.forces, options.tolerance);
  if (second_check.ok || second_check.residual <= first_check.residual) return fallback;
  // The first answer with how the whole solve ended (its own end was at its
  // share of the budget, not the solve's).
  answer.end = fallback.end;
  return answer;
}

}  // namespace nlopt_detail

using namespace nlopt_detail;

std::vector<std::string> NloptSolver::algorithm_names() {
  std::vector<std::string> names;
  for (const auto& e : kAlgorithms) names.emplace_back(e.name);
  return names;
}

std::vector<std::string> NloptSolver::varpro_algorithm_names() {
  std::vector<std::string> names;
  for (const auto& e : kReducedAlgorithms) names.emplace_back(e.name);
  return names;
}

NloptOptions NloptOptions::FromPairs(const OptionPairs& pairs) {
  OptionReader reader(pairs, "nlopt");
  NloptOptions o;
  // `algorithm` names a full-formulation algorithm: alone it selects that
  // formulation, as it did before the reduced one existed.
  const bool full_algorithm_given = pairs.count("algorithm") > 0;
  if (full_algorithm_given && pairs.count("formulation") == 0) o.formulation = "full";
  o.formulation = reader.choice("formulation", o.formulation, {"varpro", "full"});
  o.varpro_algorithm = reader.choice("varpro_algorithm", o.varpro_algorithm, NloptSolver::varpro_algorithm_names());
  o.varpro_rounds = reader.integer("varpro_rounds", o.varpro_rounds, 1, kLargestVarproRounds);
  o.algorithm = reader.choice("algorithm", o.algorithm, NloptSolver::algorithm_names());
  o.ftol_rel = reader.number("ftol_rel", o.ftol_rel, ValueRange::positive());
  o.xtol_rel = reader.number("xtol_rel", o.xtol_rel, ValueRange::positive());
  o.maxeval = reader.integer("maxeval", static_cast<int>(o.maxeval), 1, static_cast<int>(kLargestEvaluationBudget));
  o.penalty_initial = reader.number("penalty_initial", o.penalty_initial, ValueRange::positive());
  o.varpro_penalty_initial =
      reader.number("varpro_penalty_initial", o.varpro_penalty_initial, ValueRange::positive());
  o.penalty_growth = reader.number("penalty_growth", o.penalty_growth, ValueRange::open(1.0, std::numeric_limits<double>::infinity()));
  o.penalty_max = reader.number("penalty_max", o.penalty_max, ValueRange::positive());
  o.lbfgs_memory = reader.integer("lbfgs_memory", o.lbfgs_memory, 0, kLargestLbfgsMemory);
  o.init = reader.choice("init", o.init, {"qp", "reference"});
  reader.reject_unknown();
  if (o.penalty_max < o.penalty_initial) reader.fail("penalty_max", "must be at least penalty_initial");
  if (o.formulation == "varpro" && o.penalty_max < o.varpro_penalty_initial)
    reader.fail("penalty_max", "must be at least varpro_penalty_initial");
  if (o.formulation == "varpro" && full_algorithm_given)
    reader.fail("algorithm", "applies to formulation=full (formulation=varpro takes varpro_algorithm)");
  if (o.formulation == "full" && pairs.count("varpro_algorithm") > 0)
    reader.fail("varpro_algorithm", "applies to formulation=varpro");
  return o;
}

bool NloptOptions::IsValid(std::string* why) const {
  auto fail = [&](const char* reason) {
    if (why) *why = reason;
    return false;
  };
  if (formulation != "varpro" && formulation != "full") return fail("formulation must be varpro or full");
  const auto names = NloptSolver::algorithm_names();
  if (std::find(names.begin(), names.end(), algorithm) == names.end()) return fail("unknown algorithm");
  const auto reduced = NloptSolver::varpro_algorithm_names();
  if (std::find(reduced.begin(), reduced.end(), varpro_algorithm) == reduced.end())
    return fail("unknown varpro_algorithm");
  if (varpro_rounds < 1 || varpro_rounds > kLargestVarproRounds) return fail("varpro_rounds must be in [1, 100]");
  if (!(ftol_rel > 0.0 && xtol_rel > 0.0)) return fail("ftol_rel and xtol_rel must be > 0");
  if (maxeval < 0 || maxeval > kLargestEvaluationBudget) return fail("maxeval must be in [0, 2^30]");
  if (!(penalty_initial > 0.0 && penalty_growth > 1.0 && penalty_max >= penalty_initial))
    return fail("penalty_initial > 0, penalty_growth > 1 and penalty_max >= penalty_initial");
  if (!(varpro_penalty_initial > 0.0 && (formulation != "varpro" || penalty_max >= varpro_penalty_initial)))
    return fail("varpro_penalty_initial > 0 and, for varpro, penalty_max >= varpro_penalty_initial");
  if (lbfgs_memory < 0 || lbfgs_memory > kLargestLbfgsMemory) return fail("lbfgs_memory must be in [0, 1000]");
  if (init != "qp" && init != "reference") return fail("init must be qp or reference");
  return true;
}

SolveResult NloptSolver::DoSolve(const PartProblem& problem, const NloptOptions& nlopt_options) const {
  const Structure& part = problem.part;
  const SolveOptions& options = problem.options;
  const NloptRun o = resolve(nlopt_options, options);
  TraceRecorder recorder(options.time_limit_s);
  std::string route = reduced_algorithm_name(o.reduced_algorithm);
  PartAnswer answer;
  if (!o.reduced) answer = solve_full(part, options, o, recorder);
  else if (o.reduced_algorithm == ReducedAlgorithm::Auto)
    answer = solve_reduced_auto(part, options, o, recorder, route);
  else if (o.reduced_algorithm == ReducedAlgorithm::AlLbfgs || o.reduced_algorithm == ReducedAlgorithm::AlTnewton)
    answer = solve_reduced_multipliers(part, options, o, recorder);
  else
    answer = solve_reduced(part, options, o, recorder);
  const RunEnd& end = answer.end;

  SolveResult result;
  result.positions = answer.positions;
  result.forces = answer.forces;
  const Verification v = verify(part, result.positions, result.forces, options.tolerance);
  result.status = status_from_nlopt(end.code, end.forced, v);
  result.native_code = static_cast<int>(end.code);
  result.trace = std::move(recorder.trace());
  fill_stats(result, v, end.iterations, recorder.seconds());
  std::ostringstream message;
  if (o.reduced && o.reduced_algorithm == ReducedAlgorithm::Auto) message << "varpro auto (" << route << ")";
  else if (o.reduced) message << "varpro " << route;
  else message << algorithm_name(o.algorithm);
  message << ": " << to_string(result.status) << " after " << end.iterations << " iterations, " << end.evaluations
          << " evaluations (last NLopt result " << result_name(end.code) << ")";
  if (end.forced == ForcedStop::TimeLimit) message << ", time limit";
  if (end.forced == ForcedStop::NonFinite) message << ", non-finite evaluation";
  result.message = message.str();
  return result;
}

std::unique_ptr<Solver> make_nlopt_solver() { return std::make_unique<NloptSolver>(); }

}  // namespace tensegrity
