#include "solvers/alternating/interior_gauss_newton.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "formulations/equilibrium.hpp"
#include "formulations/force_scale.hpp"
#include "kernels/stress_qp.hpp"
#include "solvers/alternating/eq4_measure.hpp"
#include "kernels/normal_matrix.hpp"
#include "solvers/part_result.hpp"
#include "solvers/trace_recorder.hpp"

namespace tensegrity {

bool InteriorGaussNewtonOptions::IsValid() const {
  return max_iterations >= 0 && force_weight > 0.0 && std::isfinite(force_weight) && boundary_fraction > 0.0 &&
         boundary_fraction < 1.0 && anchor_until >= 0.0 && anchor_until <= 1.0 && max_step > 0.0 &&
         std::isfinite(max_step) && lambda >= 0.0 && std::isfinite(lambda) && margin_fraction >= 0.0 &&
         margin_fraction < 1.0 && progress_window >= 0 && progress_ratio > 0.0 && progress_ratio <= 1.0;
}

InteriorGaussNewtonOptions patient_interior_options() {
  InteriorGaussNewtonOptions o;
  o.max_iterations = 1500;
  o.force_weight = 3e5;
  o.lambda = 1e-14;
  o.adaptive_damping = true;
  o.progress_window = 100;
  o.progress_ratio = 0.9;
  return o;
}

InteriorGaussNewtonOptions stiff_force_interior_options() {
  InteriorGaussNewtonOptions o;
  o.max_iterations = 150;
  o.force_weight = 30.0;
  o.progress_window = 50;
  o.progress_ratio = 0.9;
  return o;
}

namespace {

// Near the solution the normal matrix hardly changes from one step to the
// next: after a full plain step that cut Eq. 4's objective by this ratio or
// more, the next step first reuses the factorization (with J and A at the
// new point) and keeps it only if it cuts the objective as much again.
constexpr double kChordRatio = 0.1;
// A run about to converge is not cut short by the step budget: while the
// relative residual is within kFinalPhaseDistance times the tolerance and
// each step still cuts Eq. 4's objective to kFinalPhaseCut of its value or
// less, up to kFinalPhaseSteps steps beyond interior_iterations are taken
// (within max_iterations).
constexpr double kFinalPhaseDistance = 1e3;
constexpr double kFinalPhaseCut = 0.75;
constexpr int kFinalPhaseSteps = 20;
// Adaptive damping (InteriorGaussNewtonOptions::adaptive_damping): the factor
// by which lambda grows after a shortened step and shrinks after a full one.
constexpr double kDampingFactor = 10.0;
// The test whether the input already stands: at most this many force-only
// steps, each of which must shrink the objective by this factor at least.
constexpr int kForceOnlySteps = 4;
constexpr double kNewtonLikeDecrease = 1e-3;

class InteriorSolve {
 public:
  InteriorSolve(const Structure& part, const SolveOptions& options, const InteriorGaussNewtonOptions& o)
      : part_(part),
        options_(options),
        o_(o),
        recorder_(options.time_limit_s),
        eq_(part),
        scale_(make_force_scale(part, o.margin_fraction > 0.0 ? o.margin_fraction : options.margin_fraction)),
        L_(part.mean_element_length()),
        F0_(scale_.reference_force),
        wn_(StressQpOptions{}.normalisation_weight),
        measure_(eq_, scale_, wn_) {
    const int nq = eq_.num_equations(), m = eq_.num_elements();
    q0_ = eq_.free_nodes().gather(part.positions);
    q_ = q0_;
    for (Eigen::VectorXd* v : {&q_trial_, &f_, &f_trial_, &dq_, &offset_, &jd_}) v->resize(nq);
    for (Eigen::VectorXd* v : {&sigma_trial_, &dsigma_, &weight_}) v->resize(m);
  }

  SolveResult run();

 private:
  double objective(const Eigen::VectorXd& sigma, Eigen::VectorXd& f) const { return measure_.objective(sigma, f); }
  double relative_residual(const Eigen::VectorXd& f, const Eigen::VectorXd& sigma) const {
    return measure_.relative_residual(measure_.max_node_residual(f), sigma);
  }
  double slack(int e, double sigma) const {
    return std::isfinite(scale_.lower[e]) ? sigma - scale_.lower[e] : scale_.upper[e] - sigma;
  }
  bool factorize(bool move_positions);
  // The reference forces with the initial damping: where both the standing
  // test and the solve begin.
  void start_from_reference_forces() {
    sigma_ = reference_forces(part_, scale_);
    phi_ = objective(sigma_, f_);
    lambda_ = o_.lambda;
  }
  // Solves for the step (anchored or plain) with the current factorization.
  void step_direction(bool anchored);
  // Backtracking along the step within the slack and trust limits; true when
  // accepted. A chord step (old factorization) gets no backtracking and must
  // cut the objective by kChordRatio.
  bool line_search(bool chord = false);
  SolveResult finish(Status status, std::string message) {
    return make_part_result(part_, eq_.free_nodes(), q_, sigma_, status, std::move(message), options_.tolerance,
                            recorder_);
  }
  void record(int iteration) {
    TracePoint p;
    p.iteration = iteration;
    p.evaluations = evaluations_;
    p.residual = measure_.max_node_residual(f_);
    p.relative_residual = measure_.relative_residual(p.residual, sigma_);
    p.geometry_change = (q_ - q0_).norm();
    p.objective = phi_;
    recorder_.record(p);
  }

  const Structure& part_;
  const SolveOptions& options_;
  const InteriorGaussNewtonOptions& o_;
  TraceRecorder recorder_;
  Equilibrium eq_;
  ForceScale scale_;
  double L_, F0_, wn_;
  Eq4Measure measure_;
  std::unique_ptr<NormalMatrix> normal_;
  const Eigen::SparseMatrix<double>* jacobian_ = nullptr;
  Eigen::VectorXd q0_, q_, q_trial_, f_, f_trial_, dq_, offset_, jd_;
  Eigen::VectorXd sigma_, sigma_trial_, dsigma_, weight_, rhs_, y_;
  double phi_ = 0.0, lambda_ = 0.0;
  int evaluations_ = 0;
  bool move_positions_ = true;
  bool chord_ = false;  // try the next step on the current factorization
  bool shortened_ = false;  // the line search shortened the last accepted step
};

bool InteriorSolve::factorize(bool move_positions) {
  move_positions_ = move_positions;
  const int m = eq_.num_elements();
  for (int e = 0; e < m; ++e) {
    const double s = slack(e, sigma_[e]) / F0_;
    weight_[e] = o_.force_weight * s * s;
  }
  // J stays valid until the next factorize(): trial geometries in the line
  // search do not touch it.
  const Eigen::SparseMatrix<double>& J = eq_.jacobian_positions(sigma_);
  jacobian_ = &J;
  if (!normal_) {
    normal_ = std::make_unique<NormalMatrix>(J, eq_.A(),
                                             scale_.has_normalisation() ? &scale_.normalisation_row : nullptr);
    rhs_.resize(normal_->size());
    y_.resize(normal_->size());
  }
  const double wq = move_positions ? (L_ / F0_) * (L_ / F0_) : 0.0;
  for (int attempt = 0; attempt < 6; ++attempt) {
    if (normal_->assemble_and_factorize(J, wq, eq_.A(), weight_, wn_, lambda_)) return true;
    lambda_ = std::max(1e-12, lambda_ * 100.0);
  }
  return false;
}

void InteriorSolve::step_direction(bool anchored) {
  const int nq = eq_.num_equations();
  const Eigen::SparseMatrix<double>& J = *jacobian_;  // from factorize(), at (q, sigma)
  const Eigen::SparseMatrix<double>& A = eq_.A();
  const bool norm = scale_.has_normalisation();
  // In units of F0: r + J_hat dq_hat + A dsigma_hat = 0 with J_hat = J L / F0.
  rhs_.head(nq) = -f_ / F0_;
  if (norm) rhs_[nq] = -wn_ * (scale_.normalisation_row.dot(sigma_) - scale_.normalisation_target) / F0_;
  if (anchored && move_positions_) {
    offset_ = q0_ - q_;
    jd_.noalias() = J * offset_;
    rhs_.head(nq) -= jd_ / F0_;
  }
  normal_->solve(rhs_, y_);
  if (move_positions_) {
    dq_.noalias() = J.transpose() * y_.head(nq);
    dq_ *= L_ * L_ / F0_;
    if (anchored) dq_ += offset_;
  } else {
    dq_.setZero();
  }
  dsigma_.noalias() = A.transpose() * y_.head(nq);
  if (norm) dsigma_ += (wn_ * y_[nq]) * scale_.normalisation_row;
  dsigma_ = (F0_ * dsigma_.array() * weight_.array()).matrix();
}

bool InteriorSolve::line_search(bool chord) {
  const int m = eq_.num_elements();
  double alpha = 1.0;
  for (int e = 0; e < m; ++e) {
    const double toward_bound = std::isfinite(scale_.lower[e]) ? -dsigma_[e] : dsigma_[e];
    if (toward_bound > 0.0) alpha = std::min(alpha, o_.boundary_fraction * slack(e, sigma_[e]) / toward_bound);
  }
  double largest_move = 0.0;
  for (int k = 0; k < eq_.free_nodes().num_free(); ++k) largest_move = std::max(largest_move, dq_.segment<3>(3 * k).norm());
  if (!std::isfinite(largest_move) || !dsigma_.allFinite() || !(alpha > 0.0)) return false;
  if (alpha * largest_move > o_.max_step * L_) alpha = o_.max_step * L_ / largest_move;
  const double longest = alpha;
  for (int halving = 0; halving < (chord ? 1 : 12); ++halving, alpha *= 0.5) {
    q_trial_ = q_ + alpha * dq_;
    sigma_trial_ = sigma_ + alpha * dsigma_;
    eq_.set_free_coordinates(q_trial_);
    ++evaluations_;
    const double phi_trial = objective(sigma_trial_, f_trial_);
    if (phi_trial < phi_ * (chord ? kChordRatio : 1.0 - 1e-4 * alpha)) {
      shortened_ = alpha < longest;
      q_.swap(q_trial_);
      sigma_.swap(sigma_trial_);
      f_.swap(f_trial_);
      phi_ = phi_trial;
      return true;
    }
  }
  eq_.set_free_coordinates(q_);
  return false;
}

SolveResult InteriorSolve::run() {
  // Is the input already a tensegrity? Force-only steps (the geometry fixed).
  start_from_reference_forces();
  for (int step = 0; step < kForceOnlySteps && factorize(false); ++step) {
    const double before = phi_;
    step_direction(false);
    if (!line_search()) break;
    if (relative_residual(f_, sigma_) <= options_.tolerance) {
      record(0);
      return finish(Status::Converged, "in equilibrium at the input geometry");
    }
    if (phi_ > kNewtonLikeDecrease * before) break;  // not converging like Newton: the geometry must move
  }

  start_from_reference_forces();
  bool anchored = true;
  bool steady_cut = false;  // the last step cut the objective to kFinalPhaseCut or less
  for (int iteration = 0;; ++iteration) {
    record(iteration);
    const double rel = recorder_.trace().back().relative_residual;
    if (!std::isfinite(phi_) || !std::isfinite(rel)) return finish(Status::NumericalError, "non-finite residual");
    if (rel <= options_.tolerance)
      return finish(Status::Converged, "converged after " + std::to_string(iteration) + " interior Gauss-Newton steps");
    const bool final_phase = steady_cut && rel <= kFinalPhaseDistance * options_.tolerance;
    const int step_budget = o_.max_iterations + (final_phase ? kFinalPhaseSteps : 0);
    if (iteration >= std::min(step_budget, options_.iteration_budget(kDefaultIterationBudget)))
      return finish(Status::MaxIterations, "interior Gauss-Newton step budget spent");
    if (recorder_.out_of_time()) return finish(Status::TimeLimit, "time budget spent");
    if (o_.progress_window > 0 && iteration > 0 && iteration % o_.progress_window == 0) {
      const std::vector<TracePoint>& trace = recorder_.trace();
      const double window_start = trace[trace.size() - 1 - o_.progress_window].relative_residual;
      if (rel > o_.progress_ratio * window_start)
        return finish(Status::Stalled, "stalled: the relative residual fell too little over " +
                                           std::to_string(o_.progress_window) + " interior steps");
    }
    const double before = phi_;
    if (chord_) {
      chord_ = false;
      jacobian_ = &eq_.jacobian_positions(sigma_);
      step_direction(false);
      if (line_search(true)) {
        chord_ = true;
        steady_cut = true;
        continue;
      }
    }
    if (!factorize(true)) return finish(Status::NumericalError, "the normal matrix could not be factorized");
    step_direction(anchored);
    bool accepted = line_search();
    if (!accepted && anchored) {
      anchored = false;
      step_direction(false);
      accepted = line_search();
    }
    if (!accepted) {
      steady_cut = false;
      lambda_ = std::max(1e-10, lambda_ * 100.0);
      if (lambda_ > 1e6) return finish(Status::Stalled, "stalled: no step decreases Eq. 4's objective");
      continue;
    }
    if (!o_.adaptive_damping) lambda_ = std::max(o_.lambda, lambda_ * 0.01);
    else if (shortened_) lambda_ = std::max(o_.lambda, lambda_ * kDampingFactor);
    else lambda_ = std::max(o_.lambda, lambda_ / kDampingFactor);
    steady_cut = phi_ <= kFinalPhaseCut * before;
    chord_ = !anchored && phi_ <= kChordRatio * before;
    if (anchored && phi_ > o_.anchor_until * before) anchored = false;
  }
}

}  // namespace

SolveResult solve_interior_gauss_newton(const Structure& part, const SolveOptions& options,
                                        const InteriorGaussNewtonOptions& interior) {
  InteriorSolve solve(part, options, interior);
  return solve.run();
}

}  // namespace tensegrity
