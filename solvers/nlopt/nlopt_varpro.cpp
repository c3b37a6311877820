// The reduced formulation's scalar route (formulation=varpro with
// varpro_algorithm slsqp, ccsaq, mma, auglag-lbfgs): NLopt moves the positions
// only, the stress QP supplies the forces (solvers/nlopt/reduced_residual.hpp):
//
//   min_y |y - y0|^2   s.t.   g(y) = sqrt(R(y)) - tau <= 0.
//
// The constraint is the norm of the QP's residual rather than its square: the
// square's gradient vanishes on the equilibrium set, so its linearisation (what
// SLSQP and the CCSA methods step on) would only halve the residual per step,
// while the norm grows linearly away from that set. tau is a quarter of the
// tolerance in units of the load scale, so that a point NLopt accepts also meets
// the relative residual of docs/FORMATS.md. When the independent verification still
// rejects the answer after a convergence stop, L-BFGS on R alone restores
// equilibrium from there (a tiny move), and if that fails too the run is
// repeated with tau ten times smaller (`varpro_rounds` runs at most).
#include <algorithm>
#include <cmath>
#include <limits>

#include "formulations/force_scale.hpp"
#include "model/verify.hpp"
#include "solvers/nlopt/nlopt_internal.hpp"
#include "solvers/nlopt/reduced_residual.hpp"

namespace tensegrity::nlopt_detail {
namespace {

// Share of the tolerance that the first run's tau asks for.
constexpr double kFirstTargetShare = 0.25;
// Factor by which each further run tightens tau.
constexpr double kTargetTightening = 0.1;

struct ReducedState {
  ReducedResidual* reduced = nullptr;
  nlopt::opt* opt = nullptr;
  TraceRecorder* recorder = nullptr;
  Eigen::VectorXd y0;
  double target = 0.0;  // tau: bound on sqrt(R)
  long evaluations = 0;  // QP solves
  ForcedStop forced = ForcedStop::None;
  std::vector<double> residual_gradient;
  // The closest point to the scene that met the constraint: SLSQP may end on
  // a later iterate that violates it slightly.
  std::vector<double> best_feasible;
  double best_objective = HUGE_VAL;
};

bool stop_if_late(ReducedState& s) {
  if (!s.recorder->out_of_time()) return false;
  s.forced = ForcedStop::TimeLimit;
  s.opt->force_stop();
  return true;
}

double squared_distance(unsigned n, const double* y, double* grad, void* data) {
  auto& s = *static_cast<ReducedState*>(data);
  if (stop_if_late(s)) return HUGE_VAL;
  double value = 0.0;
  for (unsigned i = 0; i < n; ++i) {
    const double d = y[i] - s.y0[i];
    value += d * d;
    if (grad != nullptr) grad[i] = 2.0 * d;
  }
  return value;
}

// g(y) = sqrt(R(y)) - tau and its gradient dR/dy / (2 sqrt R).
double residual_constraint(unsigned n, const double* y, double* grad, void* data) {
  auto& s = *static_cast<ReducedState*>(data);
  if (stop_if_late(s)) return HUGE_VAL;
  ++s.evaluations;
  const double value = s.reduced->evaluate(y, grad != nullptr ? s.residual_gradient.data() : nullptr);
  const double norm = std::sqrt(std::max(value, 0.0));
  if (!std::isfinite(norm)) {
    s.forced = ForcedStop::NonFinite;
    s.opt->force_stop();
    return HUGE_VAL;
  }
  if (grad != nullptr) {
    const double factor = norm > 0.0 ? 0.5 / norm : 0.0;
    for (unsigned i = 0; i < n; ++i) grad[i] = factor * s.residual_gradient[i];
  }
  s.recorder->record(s.reduced->trace_point(y, s.evaluations));
  if (norm <= s.target) {
    double squared = 0.0;
    for (unsigned i = 0; i < n; ++i) squared += (y[i] - s.y0[i]) * (y[i] - s.y0[i]);
    if (squared < s.best_objective) {
      s.best_objective = squared;
      s.best_feasible.assign(y, y + n);
    }
  }
  return norm - s.target;
}

nlopt::algorithm nlopt_algorithm(ReducedAlgorithm a) {
  switch (a) {
    case ReducedAlgorithm::Ccsaq: return nlopt::LD_CCSAQ;
    case ReducedAlgorithm::Mma: return nlopt::LD_MMA;
    case ReducedAlgorithm::AuglagLbfgs: return nlopt::AUGLAG;
    case ReducedAlgorithm::Slsqp:
    default: return nlopt::LD_SLSQP;
  }
}

// One NLopt run from y with the state's tau.
nlopt::result run_once(ReducedState& s, std::vector<double>& y, const NloptRun& o, const SolveOptions& so) {
  const unsigned n = static_cast<unsigned>(y.size());
  nlopt::opt opt(nlopt_algorithm(o.reduced_algorithm), n);
  s.opt = &opt;
  s.forced = ForcedStop::None;
  opt.set_min_objective(squared_distance, &s);
  opt.add_inequality_constraint(residual_constraint, &s, 0.0);
  opt.set_ftol_rel(o.ftol_rel);
  opt.set_xtol_rel(o.xtol_rel);
  opt.set_maxeval(static_cast<int>(std::clamp<long>(o.maxeval - s.evaluations, 1L, kLargestEvaluationBudget)));
  opt.set_maxtime(std::max(1e-3, so.time_limit_s - s.recorder->seconds()));
  if (o.reduced_algorithm == ReducedAlgorithm::AuglagLbfgs) {
    nlopt::opt local(nlopt::LD_LBFGS, n);
    local.set_ftol_rel(o.ftol_rel);
    local.set_xtol_rel(o.xtol_rel);
    if (o.lbfgs_memory > 0) local.set_vector_storage(static_cast<unsigned>(o.lbfgs_memory));
    opt.set_local_optimizer(local);
  }
  const nlopt::result code = run_nlopt(opt, y);
  s.opt = nullptr;
  return code;
}

// R(y) alone, for the restoration below.
double reduced_residual(unsigned, const double* y, double* grad, void* data) {
  auto& s = *static_cast<ReducedState*>(data);
  if (stop_if_late(s)) return HUGE_VAL;
  ++s.evaluations;
  const double value = s.reduced->evaluate(y, grad);
  if (!std::isfinite(value)) {
    s.forced = ForcedStop::NonFinite;
    s.opt->force_stop();
    return HUGE_VAL;
  }
  s.recorder->record(s.reduced->trace_point(y, s.evaluations));
  return value;
}

// Restoration: L-BFGS on R alone from y until R <= tau^2. SLSQP can stop on
// its own tests just outside the constraint; from there the nearest
// equilibrium is a tiny move, which this finds without the distance term.
nlopt::result restore(ReducedState& s, std::vector<double>& y, const NloptRun& o, const SolveOptions& so) {
  nlopt::opt opt(nlopt::LD_LBFGS, static_cast<unsigned>(y.size()));
  s.opt = &opt;
  s.forced = ForcedStop::None;
  opt.set_min_objective(reduced_residual, &s);
  opt.set_stopval(s.target * s.target);
  opt.set_ftol_rel(o.ftol_rel);
  opt.set_xtol_rel(o.xtol_rel);
  opt.set_maxeval(static_cast<int>(std::clamp<long>(o.maxeval - s.evaluations, 1L, kLargestEvaluationBudget)));
  opt.set_maxtime(std::max(1e-3, so.time_limit_s - s.recorder->seconds()));
  const nlopt::result code = run_nlopt(opt, y);
  s.opt = nullptr;
  return code;
}

bool is_convergence_stop(nlopt::result code) {
  return code == nlopt::SUCCESS || code == nlopt::FTOL_REACHED || code == nlopt::XTOL_REACHED ||
         code == nlopt::STOPVAL_REACHED || code == nlopt::ROUNDOFF_LIMITED;
}

}  // namespace

PartAnswer solve_reduced(const Structure& part, const SolveOptions& options, const NloptRun& o,
                         TraceRecorder& recorder) {
  const ForceScale scale = make_force_scale(part, options.margin_fraction, options.prestress_factor);
  ReducedResidual reduced(part, scale);
  ReducedState s;
  s.reduced = &reduced;
  s.recorder = &recorder;
  s.y0 = reduced.start();
  s.residual_gradient.resize(static_cast<std::size_t>(reduced.num_variables()));
  s.target = kFirstTargetShare * options.tolerance * reduced.load_scale() / reduced.reference_force();
  std::vector<double> y(s.y0.data(), s.y0.data() + s.y0.size());

  PartAnswer answer;
  // The answer at `at`: its positions and the QP's forces there; returns R.
  auto take = [&](const std::vector<double>& at) {
    const double value = reduced.evaluate(at.data(), nullptr);
    answer.positions = reduced.positions(at.data());
    answer.forces = reduced.forces();
    return value;
  };
  // Already an equilibrium at the scene geometry with Eq. 5's force level.
  if (std::sqrt(take(y)) <= s.target && verify(part, answer.positions, answer.forces, options.tolerance).ok) {
    answer.end.code = nlopt::SUCCESS;
    answer.end.evaluations = reduced.qp_solves();
    return answer;
  }
  for (int round = 0; round < o.varpro_rounds; ++round) {
    s.best_feasible.clear();
    s.best_objective = HUGE_VAL;
    answer.end.code = run_once(s, y, o, options);
    if (!s.best_feasible.empty()) y = s.best_feasible;
    answer.end.forced = s.forced;
    answer.end.iterations = static_cast<int>(std::min<long>(s.evaluations, std::numeric_limits<int>::max()));
    take(y);
    if (s.forced != ForcedStop::None || !is_convergence_stop(answer.end.code)) break;
    if (verify(part, answer.positions, answer.forces, options.tolerance).ok) break;
    answer.end.code = restore(s, y, o, options);
    answer.end.forced = s.forced;
    answer.end.iterations = static_cast<int>(std::min<long>(s.evaluations, std::numeric_limits<int>::max()));
    take(y);
    if (s.forced != ForcedStop::None) break;
    if (verify(part, answer.positions, answer.forces, options.tolerance).ok) break;
    s.target *= kTargetTightening;
  }
  answer.end.evaluations = reduced.qp_solves();
  return answer;
}

}  // namespace tensegrity::nlopt_detail
