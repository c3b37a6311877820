#include "solvers/nlopt/reduced_residual.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace tensegrity {
namespace {
StressQpOptions reduced_qp_options(bool proximal_forces) {
  StressQpOptions o;
  o.proximal = proximal_forces;
  return o;
}
}  // namespace

ReducedResidual::ReducedResidual(const Structure& part, const ForceScale& scale, bool proximal_forces)
    : part_(part), eq_(part_), scale_(held_at_prestress_cap(scale)), qp_(eq_, scale_, reduced_qp_options(proximal_forces)) {
  const double mean_length = part_.mean_element_length();
  length_ = std::isfinite(mean_length) && mean_length > 0.0 ? mean_length : 1.0;
  reference_force_ = scale_.reference_force > 0.0 ? scale_.reference_force : 1.0;
  if (scale_.has_normalisation()) normalisation_weight_ = qp_.options().normalisation_weight;
  double weight = 0.0;
  const Eigen::Matrix3Xd loads = part_.gravity_loads();
  for (int i = 0; i < part_.num_nodes(); ++i)
    if (!part_.fixed[i]) weight = std::max(weight, loads.col(i).norm());
  max_free_weight_ = weight;
  load_scale_ = weight > 0.0 ? weight : reference_force_;
  q0_ = eq_.free_nodes().gather(part_.positions);
  y0_ = Eigen::VectorXd::Zero(q0_.size());
  sigma_ = reference_forces(part_, scale_);
}

double ReducedResidual::evaluate(const double* y, double* grad) {
  const int n = num_variables();
  q_ = q0_ + Eigen::Map<const Eigen::VectorXd>(y, n) * length_;
  eq_.set_free_coordinates(q_);
  const StressQpResult r = qp_.solve(sigma_);
  ++qp_solves_;
  qp_status_ = r.status;
  if (r.sigma.size() == sigma_.size() && r.sigma.allFinite()) sigma_ = r.sigma;
  eq_.residual(sigma_, f_);
  const bool shifted = load_shift_.size() == f_.size();
  if (shifted) shifted_f_ = f_ + load_shift_;
  const Eigen::VectorXd& f = shifted ? shifted_f_ : f_;
  double value = f.squaredNorm();
  if (normalisation_weight_ > 0.0) {
    const double e = normalisation_weight_ * (scale_.normalisation_row.dot(sigma_) - scale_.normalisation_target -
                                              (shifted ? target_shift_ : 0.0));
    value += e * e;
  }
  const double f0_squared = reference_force_ * reference_force_;
  if (grad != nullptr) {
    eq_.jacobian_positions_product(sigma_, f, jf_);
    Eigen::Map<Eigen::VectorXd>(grad, n) = (2.0 * length_ / f0_squared) * jf_;
  }
  return value / f0_squared;
}

// |r + lambda / rho|^2 with r = (f / F0, w e / F0) is the QP's objective / F0^2
// at load f_g + F0 lambda_f / rho and target t - F0 lambda_e / (rho w).
void ReducedResidual::set_multipliers(const Eigen::VectorXd& lambda, double rho) {
  const int n = num_variables();
  if (lambda.size() != num_residuals() || !(rho > 0.0)) {
    load_shift_.resize(0);
    target_shift_ = 0.0;
    qp_.set_shift(load_shift_, 0.0);
    return;
  }
  load_shift_ = (reference_force_ / rho) * lambda.head(n);
  target_shift_ = normalisation_weight_ > 0.0 ? -reference_force_ * lambda[n] / (rho * normalisation_weight_) : 0.0;
  qp_.set_shift(load_shift_, target_shift_);
}

void ReducedResidual::residual_vector(Eigen::VectorXd& r) const {
  const int n = num_variables();
  r.resize(num_residuals());
  r.head(n) = f_ / reference_force_;
  r[n] = normalisation_weight_ > 0.0
             ? normalisation_weight_ * (scale_.normalisation_row.dot(sigma_) - scale_.normalisation_target) /
                   reference_force_
             : 0.0;
}

double ReducedResidual::max_node_residual() const {
  double worst = 0.0;
  for (Eigen::Index k = 0; k + 2 < f_.size(); k += 3) worst = std::max(worst, f_.segment<3>(k).norm());
  return worst;
}

double ReducedResidual::relative_residual() const {
  const double load = max_free_weight_ > 0.0 ? max_free_weight_ : sigma_.cwiseAbs().maxCoeff();
  const double residual = max_node_residual();
  return load > 0.0 ? residual / load : residual;
}

TracePoint ReducedResidual::trace_point(const double* y, long evaluations) const {
  TracePoint t;
  t.evaluations = static_cast<int>(std::min<long>(evaluations, std::numeric_limits<int>::max()));
  t.iteration = t.evaluations - 1;
  t.residual = max_node_residual();
  t.relative_residual = relative_residual();
  const double squared = (Eigen::Map<const Eigen::VectorXd>(y, num_variables()) - y0_).squaredNorm();
  t.geometry_change = length_ * std::sqrt(squared);
  t.objective = squared;
  return t;
}

Eigen::Matrix3Xd ReducedResidual::positions(const double* y) const {
  Eigen::Matrix3Xd x = part_.positions;
  eq_.free_nodes().scatter(q0_ + Eigen::Map<const Eigen::VectorXd>(y, num_variables()) * length_, x);
  return x;
}

}  // namespace tensegrity
