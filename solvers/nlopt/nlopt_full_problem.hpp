#pragma once
// The full formulation's problem for NLopt: Eq. 5
// (formulations/minimal_geometry_change_nlp.hpp) in dimensionless variables
// with dimensionless constraint rows. Only solvers/nlopt/*.cpp include it.
#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <vector>

#include "formulations/force_scale.hpp"
#include "formulations/minimal_geometry_change_nlp.hpp"
#include "model/structure.hpp"

namespace tensegrity::nlopt_detail {

// Eq. 5 in dimensionless variables y = z ./ D (D = L on positions, F0 on
// forces) with constraints weighted to be dimensionless (1 / F0 on equilibrium
// rows, 1 / (n_c F0) on the normalisation row). Buffers are allocated once.
class ScaledProblem {
 public:
  ScaledProblem(const Structure& part, const ForceScale& scale)
      : nlp_(part, scale), reference_force_(scale.reference_force) {
    n_ = nlp_.num_variables();
    num_constraints_ = nlp_.num_constraints();
    num_positions_ = nlp_.num_positions();
    length_ = nlp_.length_scale();
    unit_.resize(n_);
    unit_.head(num_positions_).setConstant(length_);
    unit_.tail(n_ - num_positions_).setConstant(reference_force_);
    row_weight_ = Eigen::VectorXd::Constant(num_constraints_, 1.0 / reference_force_);
    for (int r = num_positions_; r < num_constraints_; ++r)
      row_weight_[r] = 1.0 / (reference_force_ * std::max(1, scale.num_cables));
    nlp_.jacobian_structure(jac_rows_, jac_cols_);
    jac_values_.resize(nlp_.jacobian_nonzeros());
    z_.resize(n_);
    gradient_.resize(n_);
    raw_constraints_.resize(num_constraints_);
    Eigen::VectorXd lo, hi;
    nlp_.constraint_bounds(lo, hi);
    constraint_target_ = lo;
    // Under gravity the cable-sum row is the equality c^T sigma = cap of the
    // Eq. 5 formulation (an equality, like the normalisation without gravity).
    nlp_.variable_bounds(lo, hi);
    lower_.resize(n_);
    upper_.resize(n_);
    for (int i = 0; i < n_; ++i) {
      lower_[i] = std::isfinite(lo[i]) ? lo[i] / unit_[i] : -HUGE_VAL;
      upper_[i] = std::isfinite(hi[i]) ? hi[i] / unit_[i] : HUGE_VAL;
    }
    // The load scale (docs/FORMATS.md, Solution file): the largest free-node weight, when there is one.
    const Eigen::Matrix3Xd loads = part.gravity_loads();
    for (int i = 0; i < part.num_nodes(); ++i)
      if (!part.fixed[i]) gravity_load_scale_ = std::max(gravity_load_scale_, loads.col(i).norm());
  }

  int num_variables() const { return n_; }
  int num_constraints() const { return num_constraints_; }
  int num_positions() const { return num_positions_; }
  double length() const { return length_; }
  double reference_force() const { return reference_force_; }
  const std::vector<double>& lower() const { return lower_; }
  const std::vector<double>& upper() const { return upper_; }
  MinimalGeometryChangeNlp& nlp() { return nlp_; }

  Eigen::VectorXd to_scaled(const Eigen::VectorXd& z) const { return z.cwiseQuotient(unit_); }
  Eigen::VectorXd to_unscaled(const double* y) const {
    return Eigen::Map<const Eigen::VectorXd>(y, n_).cwiseProduct(unit_);
  }

  double objective(const double* y) {
    set(y);
    return nlp_.objective(z_);
  }
  // grad = d objective / dy.
  void gradient(const double* y, double* grad) {
    set(y);
    nlp_.gradient(z_, gradient_);
    Eigen::Map<Eigen::VectorXd>(grad, n_) = gradient_.cwiseProduct(unit_);
  }
  // c = scaled constraints at y.
  void constraints(const double* y, double* c) {
    set(y);
    nlp_.constraints(z_, raw_constraints_);
    Eigen::Map<Eigen::VectorXd>(c, num_constraints_) =
        (raw_constraints_ - constraint_target_).cwiseProduct(row_weight_);
    if (cap_row_ >= 0) c[cap_row_] = std::max(0.0, c[cap_row_]);
  }
  // Whether Jacobian row r is zero at the current point (the hinge of the
  // prestress cap below the cap).
  bool row_inactive(int r) const {
    return r == cap_row_ &&
           nlp_.force_scale().normalisation_row.dot(z_.tail(n_ - num_positions_)) <= constraint_target_[r];
  }
  // grad += (dc/dy)^T v.
  void add_jacobian_transpose_times(const double* y, const double* v, double* grad) {
    set(y);
    nlp_.jacobian_values(z_, jac_values_.data());
    const bool skip_cap = cap_row_ >= 0 && row_inactive(cap_row_);
    for (std::size_t k = 0; k < jac_values_.size(); ++k) {
      const int r = jac_rows_[k], col = jac_cols_[k];
      if (skip_cap && r == cap_row_) continue;
      grad[col] += jac_values_[k] * row_weight_[r] * v[r] * unit_[col];
    }
  }
  // Dense row-major Jacobian of the scaled constraints (what NLopt's
  // mconstraint interface asks for).
  void dense_jacobian(const double* y, double* jac) {
    set(y);
    nlp_.jacobian_values(z_, jac_values_.data());
    std::fill(jac, jac + static_cast<std::size_t>(num_constraints_) * n_, 0.0);
    const bool skip_cap = cap_row_ >= 0 && row_inactive(cap_row_);
    for (std::size_t k = 0; k < jac_values_.size(); ++k) {
      const int r = jac_rows_[k], col = jac_cols_[k];
      if (skip_cap && r == cap_row_) continue;
      jac[static_cast<std::size_t>(r) * n_ + col] += jac_values_[k] * row_weight_[r] * unit_[col];
    }
  }

  // The residual (N) and relative residual of docs/FORMATS.md from scaled constraints.
  double residual(const double* c) const {
    double worst = 0.0;
    for (int k = 0; k + 2 < num_positions_; k += 3)
      worst = std::max(worst, std::sqrt(c[k] * c[k] + c[k + 1] * c[k + 1] + c[k + 2] * c[k + 2]));
    return worst * reference_force_;
  }
  double relative_residual(const double* c, const double* y) const {
    double scale = gravity_load_scale_;
    if (!(scale > 0.0)) {
      for (int i = num_positions_; i < n_; ++i) scale = std::max(scale, std::abs(y[i]));
      scale *= reference_force_;
    }
    const double r = residual(c);
    return scale > 0.0 ? r / scale : r;
  }
  // |mean cable force / F0 - 1|, zero without cables.
  double normalisation_error(const double* c) const {
    double worst = 0.0;
    for (int r = num_positions_; r < num_constraints_; ++r) worst = std::max(worst, std::abs(c[r]));
    return worst;
  }
  double geometry_change(const double* y, const Eigen::VectorXd& y0) const {
    double sum = 0.0;
    for (int i = 0; i < num_positions_; ++i) sum += (y[i] - y0[i]) * (y[i] - y0[i]);
    return length_ * std::sqrt(sum);
  }
  // Target on |scaled equilibrium row| that meets relative residual `rr`.
  double absolute_target(double rr) const {
    const double scale = gravity_load_scale_ > 0.0 ? gravity_load_scale_ : reference_force_;
    return rr * scale / reference_force_;
  }

 private:
  void set(const double* y) {
    z_ = Eigen::Map<const Eigen::VectorXd>(y, n_).cwiseProduct(unit_);
  }

  MinimalGeometryChangeNlp nlp_;
  double reference_force_ = 1.0;
  double length_ = 1.0;
  double gravity_load_scale_ = 0.0;
  int n_ = 0, num_constraints_ = 0, num_positions_ = 0;
  int cap_row_ = -1;  // the prestress cap's row under gravity, else -1
  Eigen::VectorXd unit_, row_weight_, constraint_target_, z_, gradient_, raw_constraints_;
  std::vector<int> jac_rows_, jac_cols_;
  std::vector<double> jac_values_;
  std::vector<double> lower_, upper_;
};

}  // namespace tensegrity::nlopt_detail
