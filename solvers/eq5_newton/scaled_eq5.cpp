#include "solvers/eq5_newton/scaled_eq5.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace tensegrity {
namespace {

// Rounding of a sum of many terms grows with their number; a few units in
// the last place of the magnitudes' sum covers what the cable-sum row shows
// at the optimum of the 80-layer gravity tower (one to two).
constexpr double kSumRoundingUlps = 8.0;

}  // namespace

Eigen::SparseMatrix<double> sparse_pattern(int num_rows, int num_cols, const std::vector<int>& rows,
                                           const std::vector<int>& cols, int extra_diagonal,
                                           std::vector<int>& slot) {
  std::vector<Eigen::Triplet<double>> triplets;
  triplets.reserve(rows.size() + static_cast<std::size_t>(extra_diagonal));
  for (std::size_t k = 0; k < rows.size(); ++k) triplets.emplace_back(rows[k], cols[k], 0.0);
  for (int i = 0; i < extra_diagonal; ++i) triplets.emplace_back(i, i, 0.0);
  Eigen::SparseMatrix<double> pattern(num_rows, num_cols);
  pattern.setFromTriplets(triplets.begin(), triplets.end());
  pattern.makeCompressed();
  slot.resize(rows.size());
  const int* outer = pattern.outerIndexPtr();
  const int* inner = pattern.innerIndexPtr();
  for (std::size_t k = 0; k < rows.size(); ++k) {
    const int* begin = inner + outer[cols[k]];
    const int* end = inner + outer[cols[k] + 1];
    slot[k] = static_cast<int>(std::lower_bound(begin, end, rows[k]) - inner);
  }
  return pattern;
}

ScaledEq5::ScaledEq5(MinimalGeometryChangeNlp& nlp) : nlp_(nlp) {
  nq_ = nlp.num_positions();
  m_ = nlp.num_forces();
  mc_ = nlp.num_constraints();
  Eigen::VectorXd row_lower, row_upper;
  nlp.constraint_bounds(row_lower, row_upper);
  has_slack_ = has_cable_sum_row() && !std::isfinite(row_lower[nq_]) && std::isfinite(row_upper[nq_]);
  const int nz = nlp.num_variables();
  n_ = nz + (has_slack_ ? 1 : 0);
  length_ = nlp.length_scale();
  const ForceScale& fs = nlp.force_scale();
  force_ = fs.reference_force;
  margin_ = fs.margin / force_;
  if (fs.has_normalisation()) target_ = fs.normalisation_target / force_;
  if (fs.has_prestress_cap()) target_ = fs.prestress_cap / force_;
  scale_.resize(nz);
  scale_.head(nq_).setConstant(length_);
  scale_.tail(m_).setConstant(force_);
  signs_ = Eigen::VectorXd::Ones(num_bounded());
  margins_ = Eigen::VectorXd::Zero(num_bounded());
  for (int e = 0; e < m_; ++e) {
    signs_[e] = std::isfinite(fs.lower[e]) ? 1.0 : -1.0;
    margins_[e] = margin_;
  }

  std::vector<int> rows, cols;
  nlp.jacobian_structure(rows, cols);
  const std::size_t nlp_jacobian_entries = rows.size();
  if (has_slack_) rows.push_back(nq_), cols.push_back(n_ - 1);
  jacobian_ = sparse_pattern(mc_, n_, rows, cols, 0, jac_slot_);
  if (has_slack_) slack_jacobian_slot_ = jac_slot_.back(), jac_slot_.pop_back();
  rows.resize(nlp_jacobian_entries), cols.resize(nlp_jacobian_entries);
  jac_factor_.resize(rows.size());
  for (std::size_t k = 0; k < rows.size(); ++k) jac_factor_[k] = scale_[cols[k]] / force_;
  jac_values_.resize(rows.size());

  nlp.hessian_structure(rows, cols);
  hessian_ = sparse_pattern(n_, n_, rows, cols, n_, hess_slot_);
  hess_factor_.resize(rows.size());
  for (std::size_t k = 0; k < rows.size(); ++k) hess_factor_[k] = scale_[rows[k]] * scale_[cols[k]];
  hess_values_.resize(rows.size());
}

Eigen::VectorXd ScaledEq5::to_scaled(const Eigen::VectorXd& z) const {
  Eigen::VectorXd y(n_);
  y.head(z.size()) = z.cwiseQuotient(scale_);
  if (has_slack_) {
    nlp_.constraints(z, c_z_);
    y[n_ - 1] = target_ - c_z_[nq_] / force_;  // what the cap leaves of the cable sum
  }
  return y;
}

Eigen::VectorXd ScaledEq5::to_si(const Eigen::VectorXd& y) const {
  return y.head(scale_.size()).cwiseProduct(scale_);
}

double ScaledEq5::objective(const Eigen::VectorXd& y) const {
  z_ = to_si(y);
  return nlp_.objective(z_);
}

void ScaledEq5::gradient(const Eigen::VectorXd& y, Eigen::VectorXd& g) const {
  z_ = to_si(y);
  nlp_.gradient(z_, grad_z_);
  g.resize(n_);
  g.head(scale_.size()) = grad_z_.cwiseProduct(scale_);
  if (has_slack_) g[n_ - 1] = 0.0;
}

void ScaledEq5::constraints(const Eigen::VectorXd& y, Eigen::VectorXd& c) {
  z_ = to_si(y);
  nlp_.constraints(z_, c_z_);
  c = c_z_ / force_;
  if (has_cable_sum_row()) c[nq_] -= target_;
  if (has_slack_) c[nq_] += y[n_ - 1];
}

const ScaledEq5::SparseMatrix& ScaledEq5::jacobian(const Eigen::VectorXd& y) {
  z_ = to_si(y);
  nlp_.jacobian_values(z_, jac_values_.data());
  double* values = jacobian_.valuePtr();
  std::fill(values, values + jacobian_.nonZeros(), 0.0);
  for (std::size_t k = 0; k < jac_values_.size(); ++k) values[jac_slot_[k]] += jac_factor_[k] * jac_values_[k];
  if (has_slack_) values[slack_jacobian_slot_] = 1.0;
  return jacobian_;
}

const ScaledEq5::SparseMatrix& ScaledEq5::hessian(const Eigen::VectorXd& y, const Eigen::VectorXd& lambda) {
  z_ = to_si(y);
  lambda_z_ = lambda / force_;
  nlp_.hessian_values(z_, 1.0, lambda_z_, hess_values_.data());
  double* values = hessian_.valuePtr();
  std::fill(values, values + hessian_.nonZeros(), 0.0);
  for (std::size_t k = 0; k < hess_values_.size(); ++k) values[hess_slot_[k]] += hess_factor_[k] * hess_values_[k];
  return hessian_;
}

double ScaledEq5::cable_sum_row_floor(const Eigen::VectorXd& y) const {
  if (!has_cable_sum_row()) return 0.0;
  const Eigen::VectorXd& cable_row = nlp_.force_scale().normalisation_row;
  double magnitude = cable_row.cwiseProduct(y.segment(nq_, m_)).cwiseAbs().sum() + std::abs(target_);
  if (has_slack_) magnitude += std::abs(y[n_ - 1]);
  return kSumRoundingUlps * std::numeric_limits<double>::epsilon() * magnitude;
}

void ScaledEq5::slacks(const Eigen::VectorXd& y, Eigen::VectorXd& d) const {
  d = signs_.cwiseProduct(y.tail(num_bounded())) - margins_;
}

}  // namespace tensegrity
