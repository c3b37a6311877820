// The reduced formulation with a vector of multipliers (varpro_algorithm
// al-lbfgs, al-tnewton): the method of multipliers (Hestenes, Powell) on Eq. 5
// with the forces eliminated exactly. With r(y, sigma) the residual vector of
// reduced_residual.hpp, multipliers lambda and penalty rho, each outer
// iteration solves
//
//   min_y  Phi(y) = |y - y0|^2 + (rho / 2) min_sigma |r(y, sigma) + lambda / rho|^2,
//
// whose inner minimum over the forces is the stress QP with a shifted load
// (ReducedResidual::set_multipliers) and whose gradient in y follows from the
// envelope theorem, with NLopt's L-BFGS or truncated Newton; then
// lambda += rho r and rho grows by penalty_growth when an inner solve met its
// gradient test and |r| did not shrink fourfold.
// Every residual direction carries its own multiplier, which is what the one
// scalar constraint of the SLSQP route lacks where the equilibrium set has
// codimension above one: SLSQP then creeps along the set, this does not.
#include <algorithm>
#include <cmath>
#include <limits>

#include "formulations/force_scale.hpp"
#include "model/verify.hpp"
#include "solvers/nlopt/nlopt_internal.hpp"
#include "solvers/nlopt/reduced_residual.hpp"

namespace tensegrity::nlopt_detail {
namespace {

// The inner solve stops once |grad Phi|_inf is below omega times |2 (y - y0)|_inf
// (the objective's gradient, which the multiplier term balances at the
// optimum), omega being this share of the residual vector's norm after the
// previous outer iteration within [kFinalStationarity, kLargestInnerTolerance]:
// an inexact inner solve early, a tight one near equilibrium.
constexpr double kInnerToleranceShare = 0.1;
constexpr double kLargestInnerTolerance = 1e-2;
// The answer's inner solve must have met this relative stationarity, or
// ended by NLopt's own tests (no further progress at these multipliers): a
// point that balances after a loose inner solve need not be Eq. 5's optimum.
constexpr double kFinalStationarity = 1e-6;
// Below this |2 (y - y0)|_inf the stationarity test is absolute.
constexpr double kGradientFloor = 1e-12;
// The run stops at a relative residual of this share of --tol: the iterates
// approach the equilibrium set from outside, and one outer iteration more
// brings the geometry change within rounding of the optimum's rather than
// just inside the tolerance (as the SLSQP route's tau does).
constexpr double kStopShare = 0.25;
// A penalty step is skipped while |r| shrinks at least this much per outer iteration.
constexpr double kSufficientShrink = 0.25;
// Outer iterations in a row that NLopt ends by its own tests (not the gradient
// test below) without a fourfold drop of |r| before the run is called stalled.
constexpr int kStalledOuterIterations = 3;

struct MultiplierState {
  ReducedResidual* reduced = nullptr;
  nlopt::opt* opt = nullptr;
  TraceRecorder* recorder = nullptr;
  double rho = 1.0;
  double omega = kLargestInnerTolerance;
  long evaluations = 0;
  ForcedStop forced = ForcedStop::None;
  std::vector<double> residual_gradient;
  std::vector<double> stationary_point;
};

// Phi(y) and its gradient 2 y + (rho / 2) dR/dy (y0 = 0: the scene).
double augmented_lagrangian(unsigned n, const double* y, double* grad, void* data) {
  auto& s = *static_cast<MultiplierState*>(data);
  if (s.recorder->out_of_time()) {
    s.forced = ForcedStop::TimeLimit;
    s.opt->force_stop();
    return HUGE_VAL;
  }
  ++s.evaluations;
  const double shifted = s.reduced->evaluate(y, grad != nullptr ? s.residual_gradient.data() : nullptr);
  double squared = 0.0;
  for (unsigned i = 0; i < n; ++i) squared += y[i] * y[i];
  const double value = squared + 0.5 * s.rho * shifted;
  if (!std::isfinite(value)) {
    s.forced = ForcedStop::NonFinite;
    s.opt->force_stop();
    return HUGE_VAL;
  }
  s.recorder->record(s.reduced->trace_point(y, s.evaluations));
  if (grad != nullptr) {
    double largest = 0.0, objective_gradient = 0.0;
    for (unsigned i = 0; i < n; ++i) {
      grad[i] = 2.0 * y[i] + 0.5 * s.rho * s.residual_gradient[i];
      largest = std::max(largest, std::abs(grad[i]));
      objective_gradient = std::max(objective_gradient, std::abs(2.0 * y[i]));
    }
    // NLopt's local algorithms have no gradient test: the inner solve stops here.
    if (largest <= s.omega * std::max(objective_gradient, kGradientFloor)) {
      s.stationary_point.assign(y, y + n);
      s.forced = ForcedStop::InnerConverged;
      s.opt->force_stop();
    }
  }
  return value;
}

nlopt::algorithm inner_algorithm(ReducedAlgorithm a) {
  return a == ReducedAlgorithm::AlTnewton ? nlopt::LD_TNEWTON_PRECOND_RESTART : nlopt::LD_LBFGS;
}

}  // namespace

PartAnswer solve_reduced_multipliers(const Structure& part, const SolveOptions& options, const NloptRun& o,
                                     TraceRecorder& recorder) {
  const ForceScale scale = make_force_scale(part, options.margin_fraction, options.prestress_factor);
  ReducedResidual reduced(part, scale, /*proximal_forces=*/true);
  const int n = reduced.num_variables();
  MultiplierState s;
  s.reduced = &reduced;
  s.recorder = &recorder;
  s.rho = o.varpro_penalty_initial;
  s.residual_gradient.resize(static_cast<std::size_t>(n));
  std::vector<double> y(static_cast<std::size_t>(n), 0.0);

  PartAnswer answer;
  Eigen::VectorXd r(reduced.num_residuals());
  // The answer at y with the unshifted QP's forces there, which fit y best.
  auto take = [&]() {
    reduced.set_multipliers(Eigen::VectorXd(), 0.0);
    reduced.evaluate(y.data(), nullptr);
    answer.positions = reduced.positions(y.data());
    answer.forces = reduced.forces();
    return verify(part, answer.positions, answer.forces, options.tolerance).ok;
  };
  RunEnd& end = answer.end;
  if (take()) {  // already an equilibrium at Eq. 5's force level
    end.code = nlopt::SUCCESS;
    end.evaluations = reduced.qp_solves();
    return answer;
  }
  reduced.residual_vector(r);
  double previous_norm = r.norm();
  Eigen::VectorXd lambda = Eigen::VectorXd::Zero(reduced.num_residuals());
  struct Candidate {
    Eigen::Matrix3Xd positions;
    Eigen::VectorXd forces;
    double residual = HUGE_VAL;  // N
  } best;
  int stalled = 0;
  bool converged = false;
  bool tighten = false;  // the last inner solve balanced but was too loose to stop on
  end.code = nlopt::MAXEVAL_REACHED;
  const int outer_budget = options.iteration_budget(kDefaultIterationBudget);
  for (int outer = 0; outer < outer_budget; ++outer) {
    const double remaining_time = outer_time_left(options, recorder, s.evaluations, o.maxeval, end.code);
    if (remaining_time <= 0.0) break;
    nlopt::opt inner(inner_algorithm(o.reduced_algorithm), static_cast<unsigned>(n));
    inner.set_min_objective(augmented_lagrangian, &s);
    inner.set_ftol_rel(o.ftol_rel);
    inner.set_xtol_rel(o.xtol_rel);
    if (o.lbfgs_memory > 0) inner.set_vector_storage(static_cast<unsigned>(o.lbfgs_memory));
    inner.set_maxeval(static_cast<int>(std::clamp<long>(o.maxeval - s.evaluations, 1L, kLargestEvaluationBudget)));
    inner.set_maxtime(remaining_time);
    s.opt = &inner;
    s.forced = ForcedStop::None;
    s.omega = tighten ? kFinalStationarity
                      : std::clamp(kInnerToleranceShare * previous_norm, kFinalStationarity, kLargestInnerTolerance);
    reduced.set_multipliers(lambda, s.rho);
    nlopt::result code = run_nlopt(inner, y);
    s.opt = nullptr;
    const bool inner_met = s.forced == ForcedStop::InnerConverged;
    const bool loose_stop = inner_met && s.omega > kFinalStationarity;
    if (inner_met) {
      y = s.stationary_point;
      code = nlopt::SUCCESS;
    }
    end.code = code;
    end.forced = inner_met ? ForcedStop::None : s.forced;
    if (end.forced != ForcedStop::None) break;
    // The multiplier update takes the inner minimiser's forces, those of the shifted QP.
    reduced.evaluate(y.data(), nullptr);
    reduced.residual_vector(r);
    const double norm = r.norm();
    if (!std::isfinite(norm)) {
      end.forced = ForcedStop::NonFinite;
      break;
    }
    // Stop on the inner minimiser's own forces: the unshifted QP at y can
    // balance a y that is not yet Eq. 5's optimum, wherever the equilibrium
    // set is thicker than a point's neighbourhood needs.
    const Eigen::Matrix3Xd positions = reduced.positions(y.data());
    // verify() checks the nodes; the cable-sum row (Eq. 5's force level) is r's last entry.
    const double cable_sum_bound = kStopShare * options.tolerance * reduced.load_scale() / reduced.reference_force();
    Verification check = verify(part, positions, reduced.forces(), kStopShare * options.tolerance);
    check.ok = check.ok && std::abs(r[n]) <= cable_sum_bound;
    if (check.ok && !loose_stop) {
      answer.positions = positions;
      answer.forces = reduced.forces();
      end.code = nlopt::SUCCESS;
      converged = true;
      break;
    }
    if (check.ok) tighten = true;
    if (check.residual < best.residual) best = {positions, reduced.forces(), check.residual};
    if (code == nlopt::MAXTIME_REACHED || code == nlopt::OUT_OF_MEMORY || code == nlopt::INVALID_ARGS) break;
    if (code == nlopt::MAXEVAL_REACHED && s.evaluations >= o.maxeval) break;
    const bool progress = norm <= kSufficientShrink * previous_norm;
    // NLopt stopped short of the gradient test without progress: the QP's
    // gradient is no more accurate than this; more penalty would not help.
    stalled = !inner_met && !progress ? stalled + 1 : 0;
    if (stalled >= kStalledOuterIterations) {
      end.code = nlopt::XTOL_REACHED;
      break;
    }
    lambda += s.rho * r;
    if (inner_met && !progress) s.rho = std::min(s.rho * o.penalty_growth, o.penalty_max);
    previous_norm = norm;
    if (outer + 1 == outer_budget) end.code = nlopt::MAXEVAL_REACHED;
  }
  reduced.set_multipliers(Eigen::VectorXd(), 0.0);
  // Without convergence: of the unshifted QP's forces at the last y and the
  // inner minimisers' answers, the one with the smallest residual.
  if (!converged) {
    take();
    if (best.residual < verify(part, answer.positions, answer.forces, options.tolerance).residual) {
      answer.positions = best.positions;
      answer.forces = best.forces;
    }
  }
  // As in the SLSQP route, an iteration is an NLopt evaluation (one stress-QP
  // solve each; the extra solves at the outer iterations' ends are not counted).
  end.iterations = static_cast<int>(std::min<long>(s.evaluations, std::numeric_limits<int>::max()));
  end.evaluations = reduced.qp_solves();
  return answer;
}

}  // namespace tensegrity::nlopt_detail
