// The full formulation's augmented-Lagrangian outer loop (and the entry point
// solve_full, which also dispatches to NLopt's own constrained algorithms in
// nlopt_full_direct.cpp).
#include <algorithm>
#include <cmath>
#include <limits>

#include "formulations/equilibrium.hpp"
#include "kernels/stress_qp.hpp"
#include "solvers/nlopt/nlopt_full_problem.hpp"
#include "solvers/nlopt/nlopt_internal.hpp"

namespace tensegrity::nlopt_detail {

RunEnd run_direct(const Structure& part, ScaledProblem& p, std::vector<double>& y, const NloptRun& o,
                  const SolveOptions& so, TraceRecorder& recorder);

namespace {

// ---------------------------------------------------------------------------
// Augmented Lagrangian (or penalty) outer loop around a bound-constrained NLopt
// local algorithm.

struct AlState {
  ScaledProblem* problem = nullptr;
  nlopt::opt* opt = nullptr;
  TraceRecorder* recorder = nullptr;
  Eigen::VectorXd lambda, c, weight;  // weight = lambda + rho c
  double rho = 1.0;
  double omega = 1e-3;                // projected-gradient tolerance of this inner solve
  long evaluations = 0;
  ForcedStop forced = ForcedStop::None;
  std::vector<double> stationary_point;
};

double augmented_lagrangian(unsigned n, const double* y, double* grad, void* data) {
  auto& s = *static_cast<AlState*>(data);
  ++s.evaluations;
  if (s.recorder->out_of_time()) {
    s.forced = ForcedStop::TimeLimit;
    s.opt->force_stop();
    return HUGE_VAL;
  }
  ScaledProblem& p = *s.problem;
  const double objective = p.objective(y);
  p.constraints(y, s.c.data());
  s.weight = s.lambda + s.rho * s.c;
  const double value = objective + s.lambda.dot(s.c) + 0.5 * s.rho * s.c.squaredNorm();
  if (!std::isfinite(value)) {
    s.forced = ForcedStop::NonFinite;
    s.opt->force_stop();
    return HUGE_VAL;
  }
  if (grad != nullptr) {
    p.gradient(y, grad);
    p.add_jacobian_transpose_times(y, s.weight.data(), grad);
    // Projected gradient: NLopt's local algorithms have no gradient test, so
    // the inner solve stops here once it is stationary enough.
    double projected = 0.0;
    const auto& lo = p.lower();
    const auto& hi = p.upper();
    for (unsigned i = 0; i < n; ++i) {
      const double g = grad[i];
      if (!std::isfinite(g)) {
        s.forced = ForcedStop::NonFinite;
        s.opt->force_stop();
        return HUGE_VAL;
      }
      if ((y[i] <= lo[i] && g > 0.0) || (y[i] >= hi[i] && g < 0.0)) continue;
      projected = std::max(projected, std::abs(g));
    }
    if (projected <= s.omega) {
      s.stationary_point.assign(y, y + n);
      s.forced = ForcedStop::InnerConverged;
      s.opt->force_stop();
    }
  }
  return value;
}

nlopt::algorithm local_algorithm(Algorithm a) {
  switch (a) {
    case Algorithm::AlTnewton: return nlopt::LD_TNEWTON_PRECOND_RESTART;
    case Algorithm::AlMma: return nlopt::LD_MMA;
    case Algorithm::AlCcsaq: return nlopt::LD_CCSAQ;
    default: return nlopt::LD_LBFGS;
  }
}

RunEnd run_augmented_lagrangian(ScaledProblem& p, std::vector<double>& y,
                                const NloptRun& o, const SolveOptions& so,
                                TraceRecorder& recorder) {
  const int n = p.num_variables();
  const bool multipliers = o.algorithm != Algorithm::PenaltyLbfgs;
  const double target = 0.5 * so.tolerance;
  const Eigen::VectorXd y0 = Eigen::Map<const Eigen::VectorXd>(y.data(), n);

  nlopt::opt inner(local_algorithm(o.algorithm), static_cast<unsigned>(n));
  inner.set_lower_bounds(p.lower());
  inner.set_upper_bounds(p.upper());
  inner.set_ftol_rel(o.ftol_rel);
  inner.set_xtol_rel(o.xtol_rel);
  if (o.lbfgs_memory > 0) inner.set_vector_storage(static_cast<unsigned>(o.lbfgs_memory));

  AlState s;
  s.problem = &p;
  s.opt = &inner;
  s.recorder = &recorder;
  s.lambda = Eigen::VectorXd::Zero(p.num_constraints());
  s.c.resize(p.num_constraints());
  s.weight.resize(p.num_constraints());
  s.rho = o.penalty_initial;
  inner.set_min_objective(augmented_lagrangian, &s);

  Eigen::VectorXd c(p.num_constraints());
  p.constraints(y.data(), c.data());
  double violation = c.lpNorm<Eigen::Infinity>();
  double previous_violation = violation;
  int stalled = 0;
  RunEnd end;
  // Normalisation accurate enough that every backend's forces compare.
  const double normalisation_target = 1e-10;
  auto accepted = [&](const double* at) {
    return p.relative_residual(c.data(), at) <= target &&
           p.normalisation_error(c.data()) <= normalisation_target;
  };
  if (accepted(y.data())) {  // already in equilibrium: do not move it
    end.code = nlopt::SUCCESS;
    return end;
  }
  end.code = nlopt::MAXEVAL_REACHED;
  const int outer_budget = so.iteration_budget(kDefaultIterationBudget);
  for (int outer = 0; outer < outer_budget; ++outer) {
    const double remaining_time = outer_time_left(so, recorder, s.evaluations, o.maxeval, end.code);
    if (remaining_time <= 0.0) break;
    inner.set_maxtime(remaining_time);
    inner.set_maxeval(static_cast<int>(std::min<long>(o.maxeval - s.evaluations, 1L << 30)));
    s.omega = std::clamp(0.1 * violation, 1e-11, 1e-2);
    s.forced = ForcedStop::None;
    nlopt::result code = run_nlopt(inner, y);
    if (s.forced == ForcedStop::InnerConverged) {
      y = s.stationary_point;
      code = nlopt::SUCCESS;
    }
    end.iterations = outer + 1;
    end.code = code;
    end.forced = s.forced;

    p.constraints(y.data(), c.data());
    violation = c.lpNorm<Eigen::Infinity>();
    TracePoint t;
    t.iteration = outer + 1;
    t.evaluations = static_cast<int>(std::min<long>(s.evaluations, std::numeric_limits<int>::max()));
    t.residual = p.residual(c.data());
    t.relative_residual = p.relative_residual(c.data(), y.data());
    t.geometry_change = p.geometry_change(y.data(), y0);
    t.objective = p.objective(y.data());
    recorder.record(t);

    if (!std::isfinite(violation)) {
      end.forced = ForcedStop::NonFinite;
      break;
    }
    if (accepted(y.data())) {
      end.code = nlopt::SUCCESS;
      end.forced = ForcedStop::None;
      break;
    }
    if (s.forced == ForcedStop::TimeLimit || s.forced == ForcedStop::NonFinite ||
        code == nlopt::MAXTIME_REACHED || code == nlopt::OUT_OF_MEMORY ||
        code == nlopt::INVALID_ARGS) {
      break;
    }
    if (code == nlopt::MAXEVAL_REACHED && s.evaluations >= o.maxeval) break;

    if (multipliers) s.lambda += s.rho * c;
    const bool progress = violation <= 0.25 * previous_violation;
    if (!progress || !multipliers) s.rho = std::min(s.rho * o.penalty_growth, o.penalty_max);
    // At the largest penalty without progress: a stationary point of the
    // infeasibility, not an equilibrium.
    stalled = (s.rho >= o.penalty_max && violation > 0.9 * previous_violation) ? stalled + 1 : 0;
    if (stalled >= 3) {
      end.code = nlopt::XTOL_REACHED;
      break;
    }
    previous_violation = violation;
    if (outer + 1 == outer_budget) {  // the outer budget ran out
      end.code = nlopt::MAXEVAL_REACHED;
      end.forced = ForcedStop::None;
    }
  }
  end.evaluations = s.evaluations;
  return end;
}

}  // namespace

PartAnswer solve_full(const Structure& part, const SolveOptions& options, const NloptRun& o,
                      TraceRecorder& recorder) {
  const ForceScale scale = make_force_scale(part, options.margin_fraction, options.prestress_factor);
  // Sigma_0: the stress QP at the scene geometry is the natural warm start;
  // the reference forces when asked for or when the QP gives nothing usable.
  Eigen::VectorXd sigma0 = reference_forces(part, scale);
  if (o.init_from_qp) {
    Equilibrium eq(part);
    StressQp qp(eq, scale);
    const StressQpResult s = qp.solve();
    if (s.sigma.size() == sigma0.size() && s.sigma.allFinite()) sigma0 = s.sigma;
  }

  ScaledProblem scaled(part, scale);
  const Eigen::VectorXd y0 = scaled.to_scaled(scaled.nlp().initial_point(sigma0));
  std::vector<double> y(y0.data(), y0.data() + y0.size());
  // Keep the start inside NLopt's box (it rejects points outside it).
  for (std::size_t i = 0; i < y.size(); ++i) y[i] = std::clamp(y[i], scaled.lower()[i], scaled.upper()[i]);

  PartAnswer answer;
  if (o.algorithm == Algorithm::Slsqp || o.algorithm == Algorithm::AuglagEqLbfgs)
    answer.end = run_direct(part, scaled, y, o, options, recorder);
  else
    answer.end = run_augmented_lagrangian(scaled, y, o, options, recorder);
  const Eigen::VectorXd z = scaled.to_unscaled(y.data());
  answer.positions = scaled.nlp().positions(z);
  answer.forces = scaled.nlp().forces(z);
  return answer;
}

}  // namespace tensegrity::nlopt_detail
