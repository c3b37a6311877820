// Algorithm 1 and its Gauss-Newton variant: one state machine (PartSolve)
// whose phases share the state, kept in one file of about 550 lines so that
// the phases read in order; the options and details are in
// alternating_options.cpp.
#include "solvers/alternating/alternating_solver.hpp"

#include <Eigen/SparseCore>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "formulations/equilibrium.hpp"
#include "formulations/force_scale.hpp"
#include "kernels/stress_qp.hpp"
#include "model/errors.hpp"
#include "model/json_text.hpp"
#include "model/verify.hpp"
#include "solvers/alternating/eq4_measure.hpp"
#include "kernels/normal_matrix.hpp"
#include "solvers/option_reader.hpp"
#include "solvers/part_result.hpp"
#include "solvers/trace_recorder.hpp"

namespace tensegrity {
namespace {

using SparseMatrix = Eigen::SparseMatrix<double>;
constexpr double kInfinity = std::numeric_limits<double>::infinity();
constexpr double kEpsilon = std::numeric_limits<double>::epsilon();

// The force scale of one run: the backend's own margin when it sets one, and
// the cable sum held at the prestress cap for a held run.
ForceScale part_force_scale(const Structure& part, const SolveOptions& options, double own_margin, bool hold_cap) {
  const ForceScale scale =
      make_force_scale(part, own_margin > 0.0 ? own_margin : options.margin_fraction, options.prestress_factor);
  return hold_cap ? held_at_prestress_cap(scale) : scale;
}

// A converged run under gravity whose cable sum is above the prestress cap
// is not an answer of Eq. 5's convention: the run is repeated with the cable
// sum held at the cap (where the cap binds, the bound is an equality).
bool exceeds_cap(const Structure& part, const SolveOptions& options, double own_margin, const SolveResult& r) {
  return r.status == Status::Converged &&
         exceeds_prestress_cap(part_force_scale(part, options, own_margin, false), r.forces);
}

// What is left of the caller's budgets after `used_seconds` and `used_iterations`.
SolveOptions remaining_budget(const SolveOptions& options, double used_seconds, int used_iterations, int default_budget) {
  SolveOptions rest = options;
  rest.time_limit_s = options.time_limit_s - used_seconds;
  rest.max_iterations = options.iteration_budget(default_budget) - used_iterations;
  return rest;
}

// One solve of one connected part: the state of Algorithm 1.
class PartSolve {
 public:
  // hold_prestress_cap: under gravity, the cable sum is held at the prestress
  // cap (held_at_prestress_cap) instead of left free.
  PartSolve(const Structure& part, const SolveOptions& options, const AlternatingOptions& alt, bool gauss_newton,
            bool hold_prestress_cap)
      : part_(part),
        options_(options),
        alt_(alt),
        gauss_newton_(gauss_newton),
        iteration_budget_(options.iteration_budget(gauss_newton ? kDefaultIterationBudget
                                                                : kFaithfulIterationBudget)),
        recorder_(options.time_limit_s),
        length_scale_(part.mean_element_length()),
        scale_(part_force_scale(part, options, alt.margin, hold_prestress_cap)),
        eq_(part),
        qp_options_(make_qp_options(alt, gauss_newton)),
        qp_(eq_, scale_, qp_options_),
        measure_(eq_, scale_, qp_options_.normalisation_weight) {
    eq_.set_positions(part.positions);
    const int nq = eq_.num_equations(), m = eq_.num_elements();
    q0_.resize(nq);
    for (int node : eq_.free_nodes().free_nodes())
      q0_.segment<3>(3 * eq_.free_nodes().slot(node)) = part.positions.col(node);
    q_ = q0_;
    q_start_.resize(nq);
    q_trial_.resize(nq);
    f_.resize(nq);
    f_trial_.resize(nq);
    f_scratch_.resize(nq);
    g_.resize(nq);
    d_.resize(nq);
    jd_.resize(nq);
    dq_.resize(nq);
    sigma_.resize(m);
    sigma_trial_.resize(m);
    dsigma_.resize(m);
    force_weight_.resize(m);
  }

  SolveResult run();
  // The run ended at a stall or on the iteration budget (not on time, not
  // for a reason a restart cannot change).
  bool restartable() const { return restartable_; }
  // The counters of this run (AlternatingDetails), valid after run().
  const AlternatingDetails& details() const { return details_; }

 private:
  static StressQpOptions make_qp_options(const AlternatingOptions& alt, bool gauss_newton) {
    StressQpOptions o;
    o.mu = alt.mu;
    o.proximal = !gauss_newton && alt.qp_proximal;
    return o;
  }

  // Eq. 4's objective at the current geometry; writes f.
  double objective(const Eigen::VectorXd& sigma, Eigen::VectorXd& f) const { return measure_.objective(sigma, f); }

  // Stress QP at the current geometry warm-started from sigma (in/out); keeps
  // the warm start when the QP result is not better, so Eq. 4's objective never
  // increases. Writes f and returns the objective.
  double solve_stress(Eigen::VectorXd& sigma, Eigen::VectorXd& f) {
    const StressQpResult r = qp_.solve(sigma);
    ++evaluations_;
    count_stress_solve(r);
    const double phi_warm = objective(sigma, f);
    if (r.sigma.size() != sigma.size() || !r.sigma.allFinite()) return phi_warm;
    const double phi_qp = objective(r.sigma, f_scratch_);
    if (!(phi_qp <= phi_warm)) return phi_warm;
    sigma = r.sigma;
    f.swap(f_scratch_);
    return phi_qp;
  }

  void count_stress_solve(const StressQpResult& r) {
    ++details_.stress_solves;
    if (!r.optimal) ++details_.non_optimal_stress_solves;
  }

  double node_residual(const Eigen::VectorXd& f) const { return measure_.max_node_residual(f); }
  double relative_residual(double residual, const Eigen::VectorXd& sigma) const {
    return measure_.relative_residual(residual, sigma);
  }

  void faithful_phase();
  void gauss_newton_phase();
  bool try_step(const SparseMatrix& J, const SparseMatrix& A, const Eigen::VectorXd* anchor_offset);
  SolveResult finish(Status status, std::string message);
  std::string crawl_note() const {
    return crawl_from_ < 0 ? "" : " (SDC steps from outer iteration " + std::to_string(crawl_from_) + ")";
  }

  const Structure& part_;
  const SolveOptions& options_;
  const AlternatingOptions& alt_;
  bool gauss_newton_;
  int iteration_budget_;  // outer iterations
  TraceRecorder recorder_;
  double length_scale_;
  ForceScale scale_;
  Equilibrium eq_;
  StressQpOptions qp_options_;
  StressQp qp_;
  Eq4Measure measure_;

  Eigen::VectorXd q0_, q_, q_start_, q_trial_, f_, f_trial_, f_scratch_, g_, d_, jd_, dq_;
  Eigen::VectorXd sigma_, sigma_trial_, dsigma_, force_weight_, rhs_, y_;
  std::unique_ptr<NormalMatrix> normal_;
  double phi_ = 0.0;
  double last_move_ = kInfinity;  // |q| change of the last accepted position phase
  bool stalled_ = false;
  int evaluations_ = 0;
  double lambda_relative_ = 0.0;
  bool sigma_is_qp_optimal_ = true;
  bool trial_is_qp_optimal_ = true;
  double trust_radius_ = 0.0;
  bool restartable_ = false;
  double last_step_ = 1.0, last_largest_move_ = 0.0;  // of the last rejected trial
  int crawl_from_ = -1;  // adaptive step lengths: the outer iteration SDC steps began at (-1: not yet)
  Eigen::VectorXd anchor_offset_, rhs_anchor_;
  AlternatingDetails details_;
};

// Algorithm 1, lines 3-9, at fixed sigma; then line 2 of the next iteration.
void PartSolve::faithful_phase() {
  const double length = length_scale_;
  q_start_ = q_;
  double budget = alt_.gamma * length;
  const bool sdc = alt_.step_length == FaithfulStepLength::Sdc || crawl_from_ >= 0;
  const int i_max = crawl_from_ >= 0 ? alt_.crawl_i_max : alt_.i_max;
  const int cycle = alt_.sdc_cauchy_steps + alt_.sdc_constant_steps;
  // A shorter step moves the largest coordinates by less than their
  // rounding: halving further only re-evaluates (nearly) the same geometry
  // (at an equilibrium to rounding, 60 evaluations per outer iteration).
  const double rounding_step = 4.0 * kEpsilon * (q_.lpNorm<Eigen::Infinity>() + length);
  // Step lengths along -g (x -= alpha g): the Cauchy step of the previous
  // step and the SDC cycle's constant (Yuan) step.
  double cauchy_previous = 0.0, gradient_norm_previous = 0.0, yuan = 0.0;
  for (int i = 0; budget > 0.0 && i < i_max; ++i) {
    // J is symmetric: g = J^T f = J f and J d = -J g / |g|, matrix-free
    // products at the geometry the line search left in eq_ (J is never assembled).
    eq_.jacobian_positions_product(sigma_, f_, g_);
    const double gradient_norm = g_.norm();
    if (!(gradient_norm > 0.0) || !std::isfinite(gradient_norm)) break;
    d_ = g_ * (-1.0 / gradient_norm);  // Eq. 6 with the descent sign: dx = gamma_acc * d
    // d(|f|^2)/ds = 2 f^T J d = -2 |g|: the linearised minimiser along d is
    // |g| / |J d|^2 (the Cauchy step, s = alpha |g|). The second product is
    // needed for it alone, so an SDC constant step skips it unless the
    // constant step is rejected.
    double curvature = -1.0, cauchy = kInfinity;
    auto compute_cauchy = [&] {
      eq_.jacobian_positions_product(sigma_, g_, jd_);
      curvature = jd_.squaredNorm() / (gradient_norm * gradient_norm);
      cauchy = curvature > 0.0 ? 1.0 / curvature : kInfinity;
    };
    double first_trial = 0.0;  // an SDC constant step, tried before the Cauchy step
    if (sdc) {
      const int position = i % cycle;
      if (position == 0) yuan = 0.0;  // a cycle never reuses the previous cycle's step
      if (position >= alt_.sdc_cauchy_steps) first_trial = yuan;
      if (!(first_trial > 0.0 && std::isfinite(first_trial))) compute_cauchy();
      if (position == alt_.sdc_cauchy_steps - 1 && cauchy_previous > 0.0 && std::isfinite(cauchy_previous) &&
          std::isfinite(cauchy)) {
        // Yuan's step from the last two Cauchy steps (De Asmundis et al. 2014, SDC).
        const double a = 1.0 / cauchy_previous, b = 1.0 / cauchy;
        const double ratio = gradient_norm / (cauchy_previous * gradient_norm_previous);
        yuan = 2.0 / (std::sqrt((a - b) * (a - b) + 4.0 * ratio * ratio) + a + b);
      }
    } else {
      compute_cauchy();
    }
    double phi_trial = phi_;
    // Moves to q + step d (in eq_ too) and tests Armijo on Eq. 4's objective.
    auto try_step_length = [&](double step) {
      q_trial_ = q_ + step * d_;
      eq_.set_free_coordinates_and_residual(q_trial_, sigma_, f_trial_);
      ++evaluations_;
      phi_trial = measure_.objective_of(sigma_, f_trial_);
      return phi_trial <= phi_ - 1e-4 * 2.0 * step * gradient_norm;
    };
    bool accepted = false;
    double step = 0.0;
    if (first_trial > 0.0 && std::isfinite(first_trial)) {
      step = std::min(budget, first_trial * gradient_norm);
      accepted = try_step_length(step);
    }
    if (!accepted) {
      if (curvature < 0.0) {  // the rejected constant step left its geometry in eq_
        eq_.set_free_coordinates(q_);
        compute_cauchy();
      }
      step = curvature > 0.0 ? std::min(budget, gradient_norm / curvature) : budget;
    }
    // After the fallback: Yuan's step reads the Cauchy step of the previous
    // step (computed unless a constant step was accepted there).
    cauchy_previous = cauchy;
    gradient_norm_previous = gradient_norm;
    for (int halving = 0; !accepted && halving < 60 && step > rounding_step; ++halving) {
      accepted = try_step_length(step);
      if (!accepted) step *= 0.5;
    }
    if (!accepted) {
      eq_.set_free_coordinates(q_);
      break;
    }
    q_.swap(q_trial_);
    f_.swap(f_trial_);
    phi_ = phi_trial;
    budget -= step;
  }
  last_move_ = (q_ - q_start_).norm();
  stalled_ = last_move_ < alt_.epsilon_cvg * length;
  phi_ = solve_stress(sigma_, f_);
}

// One trial of the joint step from the solution y_ of the normal equations:
// dq = (L^2 / F0) J^T y (+ the anchor offset q0 - q), dsigma from A^T y.
// Returns true when the iteration is over (accepted, or a non-finite step that
// raised the damping); false leaves the state unchanged.
//
// The anchored step must also reduce Eq. 4's objective by at least a quarter
// of what its linearisation predicts: its pull towards the input geometry
// otherwise trades residual for distance in many tiny steps.
bool PartSolve::try_step(const SparseMatrix& J, const SparseMatrix& A, const Eigen::VectorXd* anchor_offset) {
  const double L = length_scale_, F0 = scale_.reference_force;
  const int nq = eq_.num_equations();
  const bool norm = scale_.has_normalisation();
  const double wn = qp_options_.normalisation_weight;
  // dq = L dq_hat = (L^2 / F0) J^T y;  dsigma = F0 dsigma_hat = F0 ws (A^T y + wn c y_n).
  dq_.noalias() = J.transpose() * y_.head(nq);
  dq_ *= L * L / F0;
  if (anchor_offset) dq_ += *anchor_offset;
  dsigma_.noalias() = A.transpose() * y_.head(nq);
  if (norm) dsigma_ += (wn * y_[nq]) * scale_.normalisation_row;
  dsigma_ = (F0 * dsigma_.array() * force_weight_.array()).matrix();

  double largest_move = 0.0;
  for (int k = 0; k < nq / 3; ++k) largest_move = std::max(largest_move, dq_.segment<3>(3 * k).norm());
  if (!std::isfinite(largest_move) || !dsigma_.allFinite()) {
    lambda_relative_ *= 100.0;
    stalled_ = lambda_relative_ > 1e12;
    return true;
  }
  const double step = largest_move > trust_radius_ ? trust_radius_ / largest_move : 1.0;
  // The caller's A (and J) are references into eq_: the eager move below
  // rewrites A's values at the trial geometry, which the anchored prediction
  // further down reads (a second-order effect). The fused lazy move of the
  // faithful phase must not be used here: A would keep stale values.
  q_trial_ = q_ + step * dq_;
  sigma_trial_ = sigma_ + step * dsigma_;
  const bool crosses_bound =
      (sigma_trial_.array() < scale_.lower.array()).any() || (sigma_trial_.array() > scale_.upper.array()).any();
  eq_.set_free_coordinates(q_trial_);
  double phi_trial;
  // f is linear in sigma, so a joint step that keeps every sign needs no QP;
  // the QP restores the bounds (and frees elements held at them) otherwise.
  if (crosses_bound) sigma_trial_ = sigma_trial_.cwiseMax(scale_.lower).cwiseMin(scale_.upper);
  if ((crosses_bound && alt_.qp_on_crossing) || alt_.qp_every_step || alt_.sigma_weight == 0.0) {
    phi_trial = solve_stress(sigma_trial_, f_trial_);
    trial_is_qp_optimal_ = true;
  } else {
    ++evaluations_;
    phi_trial = objective(sigma_trial_, f_trial_);
    trial_is_qp_optimal_ = false;
  }
  double required = phi_;
  if (anchor_offset) {
    jd_.noalias() = J * dq_;
    jd_.noalias() += A * dsigma_;
    f_scratch_ = f_ + step * jd_;
    double predicted = f_scratch_.squaredNorm();
    if (norm) {
      const double n = scale_.normalisation_row.dot(sigma_) + step * scale_.normalisation_row.dot(dsigma_) -
                       scale_.normalisation_target;
      predicted += wn * wn * n * n;
    }
    required = phi_ - 0.25 * std::max(0.0, phi_ - predicted);
  }
  if (phi_trial < required) {
    last_move_ = step * std::sqrt(dq_.squaredNorm());
    q_.swap(q_trial_);
    sigma_.swap(sigma_trial_);
    f_.swap(f_trial_);
    phi_ = phi_trial;
    sigma_is_qp_optimal_ = trial_is_qp_optimal_;
    lambda_relative_ = std::max(1e-15, lambda_relative_ * 0.1);
    if (step < 1.0) trust_radius_ = std::min(2.0 * trust_radius_, alt_.max_step * L);
    stalled_ = last_move_ < alt_.epsilon_cvg * L && sigma_is_qp_optimal_;
    return true;
  }
  eq_.set_free_coordinates(q_);
  last_step_ = step;
  last_largest_move_ = largest_move;
  return false;
}

// One damped Gauss-Newton trial in z = (q, sigma), then the stress QP.
void PartSolve::gauss_newton_phase() {
  const double L = length_scale_, F0 = scale_.reference_force;
  const int nq = eq_.num_equations(), m = eq_.num_elements();
  const SparseMatrix& J = eq_.jacobian_positions(sigma_);
  const SparseMatrix& A = eq_.A();
  const bool norm = scale_.has_normalisation();
  const double wn = qp_options_.normalisation_weight;
  if (!normal_) {
    normal_ = std::make_unique<NormalMatrix>(J, A, norm ? &scale_.normalisation_row : nullptr);
    rhs_.resize(normal_->size());
    y_.resize(normal_->size());
    lambda_relative_ = alt_.lambda;
    trust_radius_ = alt_.max_step * L;
  }
  // Elements at a sign bound keep their force in this step (the QP may free them).
  const double at_bound = 1e-9 * F0;
  for (int e = 0; e < m; ++e) {
    const bool active = sigma_[e] - scale_.lower[e] <= at_bound || scale_.upper[e] - sigma_[e] <= at_bound;
    force_weight_[e] = active && !alt_.move_bound_forces ? 0.0 : alt_.sigma_weight;
  }
  const double wq = (L / F0) * (L / F0);
  rhs_.head(nq) = -f_ / F0;
  if (norm) rhs_[nq] = -wn * (scale_.normalisation_row.dot(sigma_) - scale_.normalisation_target) / F0;

  bool factorized = false;
  for (int attempt = 0; attempt < 8 && !factorized; ++attempt) {
    factorized = normal_->assemble_and_factorize(J, wq, A, force_weight_, wn, lambda_relative_);
    if (!factorized) lambda_relative_ = std::max(1e-12, lambda_relative_ * 100.0);
  }
  if (!factorized) {
    stalled_ = true;
    return;
  }
  // Two right-hand sides with one factorization: the anchored step first
  // (towards the input geometry, see try_step), then the plain one.
  if (alt_.anchor) {
    anchor_offset_ = q0_ - q_;
    jd_.noalias() = J * anchor_offset_;
    rhs_anchor_ = rhs_;
    rhs_anchor_.head(nq) -= jd_ / F0;
    if (anchor_offset_.squaredNorm() > 0.0) {
      normal_->solve(rhs_anchor_, y_);
      if (try_step(J, A, &anchor_offset_)) return;
    }
  }
  normal_->solve(rhs_, y_);
  if (try_step(J, A, nullptr)) return;
  if (!sigma_is_qp_optimal_) {
    // Re-optimise the forces at the current geometry before damping further.
    phi_ = solve_stress(sigma_, f_);
    sigma_is_qp_optimal_ = true;
    return;
  }
  lambda_relative_ *= 10.0;
  trust_radius_ = 0.5 * std::min(trust_radius_, last_step_ * last_largest_move_);
  stalled_ = lambda_relative_ > 1e12 || trust_radius_ < alt_.epsilon_cvg * L;
}

SolveResult PartSolve::finish(Status status, std::string message) {
  details_.gauss_newton = gauss_newton_;
  details_.sdc_from_iteration = crawl_from_;
  if (status == Status::Stalled) ++details_.stalls;
  return make_part_result(part_, eq_.free_nodes(), q_, sigma_, status, std::move(message), options_.tolerance,
                          recorder_);
}

SolveResult PartSolve::run() {
  // Line 2 of the first iteration: the stress solve at the input geometry.
  {
    const StressQpResult r = qp_.solve();
    ++evaluations_;
    count_stress_solve(r);
    sigma_ = r.sigma;
    if (sigma_.size() != eq_.num_elements()) {
      sigma_ = reference_forces(part_, scale_);
      return finish(Status::NumericalError, "the stress QP returned no forces");
    }
    phi_ = objective(sigma_, f_);
  }
  for (int iteration = 0;; ++iteration) {
    TracePoint p;
    p.iteration = iteration;
    p.evaluations = evaluations_;
    p.residual = node_residual(f_);
    p.relative_residual = relative_residual(p.residual, sigma_);
    p.geometry_change = (q_ - q0_).norm();
    p.objective = phi_;
    recorder_.record(p);
    if (!std::isfinite(phi_) || !std::isfinite(p.relative_residual) || !q_.allFinite())
      return finish(Status::NumericalError, "non-finite residual or positions" + crawl_note());
    if (p.relative_residual <= options_.tolerance)
      return finish(Status::Converged, iteration == 0 ? "in equilibrium at the input geometry"
                                                      : "converged after " + std::to_string(iteration) +
                                                            " outer iterations" + crawl_note());
    // Stagnation: a GN run whose objective fell by less than stall_ratio over
    // the last stall_window outer iterations is at (or crawling along) a local minimum.
    if (gauss_newton_ && iteration >= alt_.stall_window &&
        !(phi_ < alt_.stall_ratio *
                     recorder_.trace()[recorder_.trace().size() - 1 - alt_.stall_window].objective))
      stalled_ = true;
    if (stalled_) {
      restartable_ = true;
      return finish(Status::Stalled, "stalled: no progress (a local minimum of Eq. 4, or a crawl below epsilon_cvg) at relative residual " +
                                            message_number(p.relative_residual) + crawl_note());
    }
    if (iteration >= iteration_budget_) {
      restartable_ = true;
      return finish(Status::MaxIterations, "outer iteration budget spent" + crawl_note());
    }
    if (recorder_.out_of_time()) return finish(Status::TimeLimit, "time budget spent" + crawl_note());
    if (gauss_newton_) {
      gauss_newton_phase();
      continue;
    }
    // Adaptive step lengths: Cauchy steps until Eq. 4's objective has stopped
    // falling (above crawl_ratio times its value crawl_window outer iterations
    // ago), SDC steps with crawl_i_max inner steps from this phase on.
    const std::vector<TracePoint>& trace = recorder_.trace();
    if (alt_.step_length == FaithfulStepLength::Adaptive && crawl_from_ < 0 &&
        trace.size() > static_cast<std::size_t>(alt_.crawl_window) &&
        !(phi_ < alt_.crawl_ratio * trace[trace.size() - 1 - alt_.crawl_window].objective))
      crawl_from_ = iteration;
    faithful_phase();
  }
}

}  // namespace

namespace {

// Which local minimum of Eq. 4 a Gauss-Newton run falls into depends on how
// much it lets the forces move against the positions and how far it steps: the
// factors of each run after a stall, the first being the run as asked.
struct RestartScaling {
  double sigma_weight, max_step, lambda;
};
constexpr std::array<RestartScaling, 1 + kMaxRestarts> kRestartSchedule = {{
    {1.0, 1.0, 1.0},
    {10.0, 1.0, 1.0},
    {1.0, 1.0, 1e5},
    {3.0, 1.0, 1.0},
    {1.0, 0.2, 1.0},
    {0.1, 1.0, 1.0},
}};
// The last attempt's steps are at most this share of the iteration budget:
// the default 2000 leave the alternating runs at most 1850, and over the
// stress test none that converges takes more than 1802.
constexpr int kLastResortBudgetDivisor = 10;

// An interior attempt after earlier ones, within the budget they left
// (nothing when none is left): its trace timed from the part's start, its
// steps added to `iterations` and to the details.
std::optional<SolveResult> later_interior_attempt(const Structure& part, const SolveOptions& options,
                                                  const InteriorGaussNewtonOptions& interior, double elapsed_s,
                                                  int& iterations, AlternatingDetails& details) {
  const SolveOptions so = remaining_budget(options, elapsed_s, iterations, kDefaultIterationBudget);
  if (so.time_limit_s <= 0.0 || so.max_iterations <= 0) return std::nullopt;
  SolveResult r = solve_interior_gauss_newton(part, so, interior);
  for (TracePoint& p : r.trace) p.seconds += elapsed_s;
  details.interior_iterations += r.stats.iterations;
  iterations += r.stats.iterations;
  return r;
}

}  // namespace

SolveResult solve_faithful_part(const Structure& part, const SolveOptions& options,
                                const AlternatingOptions& alternating) {
  PartSolve solve(part, options, alternating, false, false);
  SolveResult r = solve.run();
  AlternatingDetails details = solve.details();
  if (exceeds_cap(part, options, alternating.margin, r)) {
    const SolveOptions rest = remaining_budget(options, r.stats.seconds, r.stats.iterations, kFaithfulIterationBudget);
    if (rest.time_limit_s > 0.0 && rest.max_iterations > 0) {
      PartSolve held(part, rest, alternating, false, true);
      SolveResult h = held.run();
      const double offset = r.stats.seconds;
      for (TracePoint& p : h.trace) p.seconds += offset;
      h.stats.iterations += r.stats.iterations;
      h.stats.seconds += offset;
      details.add_run(held.details(), false);
      details.sdc_from_iteration = held.details().sdc_from_iteration;
      details.held_at_prestress_cap = true;
      r = std::move(h);
    } else {
      r.status = Status::TimeLimit;
      r.message = "converged above the prestress cap, with no budget left to hold it there";
    }
  }
  r.details = {std::make_shared<const AlternatingDetails>(details)};
  return r;
}

SolveResult solve_gauss_newton_part(const Structure& part, const SolveOptions& options,
                                    const AlternatingOptions& alternating) {
  // Restarts from the input geometry with other step weights (kRestartSchedule)
  // when a run stalls. The trace is the successful (or last) run's, its times
  // counted from the start of the first run. The interior attempt goes first:
  // when it converges (within the prestress cap) it is the answer. Under
  // gravity, an answer above the cap is solved again with the cable sum held
  // at the cap. Where nothing converges, the last, stiff-force attempt.
  const auto start = std::chrono::steady_clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };
  int iterations = 0;
  SolveResult best;
  AlternatingDetails details;
  details.gauss_newton = true;
  if (alternating.interior.max_iterations > 0) {
    best = solve_interior_gauss_newton(part, options, alternating.interior);
    details.interior_iterations = best.stats.iterations;
    iterations += best.stats.iterations;
    if (best.status == Status::Converged && !exceeds_cap(part, options, alternating.margin, best)) {
      best.details = {std::make_shared<const AlternatingDetails>(details)};
      return best;
    }
  }
  auto finish = [&](SolveResult r) {
    r.stats.iterations = iterations;
    r.stats.seconds = elapsed();
    r.details = {std::make_shared<const AlternatingDetails>(details)};
    return r;
  };
  // The retry belongs to the interior attempt: interior_iterations=0 skips both.
  if (alternating.interior.max_iterations > 0 && alternating.interior_retry.max_iterations > 0 &&
      part.num_elements() >= alternating.interior_retry_elements && best.status != Status::Converged) {
    std::optional<SolveResult> retry =
        later_interior_attempt(part, options, alternating.interior_retry, elapsed(), iterations, details);
    if (retry && retry->status == Status::Converged) {
      best = std::move(*retry);
      if (!exceeds_cap(part, options, alternating.margin, best)) return finish(std::move(best));
    }
  }
  // The free alternating runs leave the last attempt its steps.
  const int last_resort_steps =
      alternating.interior.max_iterations > 0
          ? std::min(alternating.interior_last_resort.max_iterations,
                     options.iteration_budget(kDefaultIterationBudget) / kLastResortBudgetDivisor)
          : 0;
  // One series of runs (the first as asked, then restarts after stalls);
  // empty when no budget was left for a run.
  auto run_series = [&](bool hold_cap) -> std::optional<SolveResult> {
    std::optional<SolveResult> series_best;
    const int attempts = 1 + alternating.restarts;
    for (int a = 0; a < attempts; ++a) {
      AlternatingOptions o = alternating;
      o.sigma_weight *= kRestartSchedule[a].sigma_weight;
      o.max_step *= kRestartSchedule[a].max_step;
      o.lambda *= kRestartSchedule[a].lambda;
      const int reserved = hold_cap ? 0 : last_resort_steps;
      const SolveOptions so = remaining_budget(options, elapsed(), iterations + reserved, kDefaultIterationBudget);
      // The remainder must stay positive: 0 would mean "the default budget".
      if ((a > 0 || iterations > 0) && (so.time_limit_s <= 0.0 || so.max_iterations <= 0)) break;
      const double offset = elapsed();
      PartSolve solve(part, so, o, true, hold_cap);
      SolveResult r = solve.run();
      iterations += r.stats.iterations;
      details.add_run(solve.details(), a > 0);
      for (TracePoint& p : r.trace) p.seconds += offset;
      const bool better = a == 0 || r.status == Status::Converged ||
                          (series_best->status != Status::Converged &&
                           r.stats.relative_residual < series_best->stats.relative_residual);
      if (better) series_best = std::move(r);
      if (series_best->status == Status::Converged || !solve.restartable()) break;
    }
    return series_best;
  };
  const bool interior_above_cap = best.status == Status::Converged;  // converged, yet above the cap
  if (!interior_above_cap) {
    if (std::optional<SolveResult> free_run = run_series(false)) best = std::move(*free_run);
  }
  if (interior_above_cap || exceeds_cap(part, options, alternating.margin, best)) {
    details.held_at_prestress_cap = true;
    if (std::optional<SolveResult> held = run_series(true)) {
      best = std::move(*held);
    } else {
      best.status = Status::TimeLimit;
      best.message = "converged above the prestress cap, with no budget left to hold it there";
    }
  }
  if (best.status != Status::Converged && best.status != Status::TimeLimit && last_resort_steps > 0) {
    std::optional<SolveResult> last =
        later_interior_attempt(part, options, alternating.interior_last_resort, elapsed(), iterations, details);
    if (last && last->status == Status::Converged && !exceeds_cap(part, options, alternating.margin, *last)) {
      last->message += " (the last, stiff-force attempt: the alternating runs ended " +
                       std::string(to_string(best.status)) + ")";
      details.held_at_prestress_cap = false;
      best = std::move(*last);
    }
  }
  return finish(std::move(best));
}

SolveResult AlternatingSolver::DoSolve(const PartProblem& problem, const FaithfulAlternatingOptions& options) const {
  return solve_faithful_part(problem.part, problem.options, options);
}

SolveResult AlternatingGnSolver::DoSolve(const PartProblem& problem,
                                         const GaussNewtonAlternatingOptions& options) const {
  return solve_gauss_newton_part(problem.part, problem.options, options);
}

std::unique_ptr<Solver> make_alternating_solver() { return std::make_unique<AlternatingSolver>(); }
std::unique_ptr<Solver> make_alternating_gn_solver() { return std::make_unique<AlternatingGnSolver>(); }

}  // namespace tensegrity
