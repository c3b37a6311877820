#include "solvers/ipopt/dimensionless_eq5.hpp"

#include <cmath>
#include <limits>

#include "formulations/minimal_geometry_change_nlp.hpp"

namespace tensegrity {

DimensionlessEq5::DimensionlessEq5(MinimalGeometryChangeNlp& nlp, const Eigen::VectorXd& sigma0) : nlp_(nlp) {
  nq_ = nlp_.num_positions();
  m_ = nlp_.num_forces();
  n_ = nlp_.num_variables();
  ncon_ = nlp_.num_constraints();
  length_ = nlp_.length_scale();
  force_ = nlp_.force_scale().reference_force;
  q0_ = nlp_.reference_coordinates();
  variable_scale_ = Eigen::VectorXd(n_);
  variable_scale_.head(nq_).setConstant(length_);
  variable_scale_.tail(m_).setConstant(force_);

  // The per-entry factors of J_y and Hess_y, computed once.
  nlp_.jacobian_structure(jacobian_.rows, jacobian_.cols);
  jac_factor_.resize(jacobian_.rows.size());
  for (std::size_t k = 0; k < jac_factor_.size(); ++k) jac_factor_[k] = variable_scale_[jacobian_.cols[k]] / force_;
  nlp_.hessian_structure(hessian_.rows, hessian_.cols);
  hess_factor_.resize(hessian_.rows.size());
  for (std::size_t k = 0; k < hess_factor_.size(); ++k)
    hess_factor_[k] = variable_scale_[hessian_.rows[k]] * variable_scale_[hessian_.cols[k]];

  y0_ = Eigen::VectorXd::Zero(n_);
  y0_.tail(m_) = sigma0 / force_;
  z_ = nlp_.initial_point(sigma0);
  c_ = Eigen::VectorXd::Zero(ncon_);
  grad_ = Eigen::VectorXd::Zero(n_);
  lambda_ = Eigen::VectorXd::Zero(ncon_);
  z_final_ = z_;
}

void DimensionlessEq5::set_start(const Eigen::VectorXd& q, const Eigen::VectorXd& sigma) {
  y0_.head(nq_) = (q - q0_) / length_;
  y0_.tail(m_) = sigma / force_;
}

void DimensionlessEq5::set_start_multipliers(const Eigen::VectorXd& rows, const Eigen::VectorXd& force_bounds) {
  // With c_y = c_z / F0 and y_sigma = sigma / F0 both kinds scale by F0.
  start_rows_ = force_ * rows;
  start_lower_ = Eigen::VectorXd::Zero(n_);
  start_upper_ = Eigen::VectorXd::Zero(n_);
  Eigen::VectorXd z_lower, z_upper;
  nlp_.variable_bounds(z_lower, z_upper);
  for (int e = 0; e < m_; ++e) {
    const bool cable = std::isfinite(z_lower[nq_ + e]);
    (cable ? start_lower_ : start_upper_)[nq_ + e] = force_ * force_bounds[e];
  }
}

bool DimensionlessEq5::starting_multipliers(Vector lambda, Vector z_lower, Vector z_upper) const {
  if (start_rows_.size() != ncon_) return false;
  lambda = start_rows_;
  z_lower = start_lower_;
  z_upper = start_upper_;
  return true;
}

void DimensionlessEq5::variable_bounds(Vector lower, Vector upper) const {
  Eigen::VectorXd z_lower, z_upper;
  nlp_.variable_bounds(z_lower, z_upper);
  lower.head(nq_).setConstant(-std::numeric_limits<double>::infinity());
  upper.head(nq_).setConstant(std::numeric_limits<double>::infinity());
  for (int e = 0; e < m_; ++e) {
    lower[nq_ + e] = z_lower[nq_ + e] / force_;
    upper[nq_ + e] = z_upper[nq_ + e] / force_;
  }
}

void DimensionlessEq5::constraint_bounds(Vector lower, Vector upper) const {
  Eigen::VectorXd z_lower, z_upper;
  nlp_.constraint_bounds(z_lower, z_upper);
  for (int r = 0; r < ncon_; ++r) {
    lower[r] = z_lower[r] / force_;  // -inf: the prestress cap row
    upper[r] = z_upper[r] / force_;
  }
}

bool DimensionlessEq5::objective(const ConstVector& y, double& value) {
  to_z(y);
  ++evaluations_;
  value = nlp_.objective(z_);
  return std::isfinite(value);
}

bool DimensionlessEq5::gradient(const ConstVector& y, Vector gradient) {
  to_z(y);
  nlp_.gradient(z_, grad_);
  for (int i = 0; i < n_; ++i) gradient[i] = grad_[i] * variable_scale_[i];
  return true;
}

bool DimensionlessEq5::constraints(const ConstVector& y, Vector values) {
  to_z(y);
  nlp_.constraints(z_, c_);
  for (int r = 0; r < ncon_; ++r) values[r] = c_[r] / force_;
  return c_.allFinite();
}

bool DimensionlessEq5::jacobian_values(const ConstVector& y, Vector values) {
  to_z(y);
  nlp_.jacobian_values(z_, values.data());
  for (Eigen::Index k = 0; k < values.size(); ++k) values[k] *= jac_factor_[k];
  return true;
}

bool DimensionlessEq5::hessian_values(const ConstVector& y, double obj_factor, const ConstVector& lambda,
                                      Vector values) {
  to_z(y);
  for (int r = 0; r < ncon_; ++r) lambda_[r] = lambda[r] / force_;
  nlp_.hessian_values(z_, obj_factor, lambda_, values.data());
  for (Eigen::Index k = 0; k < values.size(); ++k) values[k] *= hess_factor_[k];
  return true;
}

void DimensionlessEq5::finalize(const NlpSolution& solution) {
  to_z(solution.x);
  z_final_ = z_;
  has_final_point_ = true;
  if (ncon_ > nq_ && solution.constraint_multipliers.size() == ncon_)
    cable_sum_multiplier_ = solution.constraint_multipliers[nq_];
}

TracePoint DimensionlessEq5::trace_point(const IpoptIteration& it, double max_free_weight) {
  TracePoint p;
  p.iteration = it.iteration;
  p.evaluations = evaluations_;
  p.objective = it.objective;
  if (it.x != nullptr) {
    to_z(*it.x);
    p.residual = nlp_.max_node_residual(z_);
    const double load = max_free_weight > 0.0 ? max_free_weight : z_.tail(m_).cwiseAbs().maxCoeff();
    p.relative_residual = load > 0.0 ? p.residual / load : p.residual;
    p.geometry_change = (z_.head(nq_) - q0_).norm();
  } else {
    // Restoration phase: only Ipopt's own (scaled) infeasibility is known.
    p.residual = it.primal_infeasibility * force_;
    p.relative_residual = it.primal_infeasibility;
  }
  return p;
}

void DimensionlessEq5::to_z(const ConstVector& y) {
  for (int i = 0; i < nq_; ++i) z_[i] = q0_[i] + length_ * y[i];
  for (int e = 0; e < m_; ++e) z_[nq_ + e] = force_ * y[nq_ + e];
}

}  // namespace tensegrity
