#include "formulations/minimal_geometry_change_nlp.hpp"

#include <cmath>
#include <limits>

namespace tensegrity {

MinimalGeometryChangeNlp::MinimalGeometryChangeNlp(const Structure& s, const ForceScale& scale,
                                                   PrestressRow prestress)
    : structure_(s), scale_(scale), prestress_(prestress), eq_(structure_) {
  eq_.set_positions(structure_.positions);
  nq_ = eq_.num_equations();
  m_ = eq_.num_elements();
  q0_ = eq_.free_nodes().gather(structure_.positions);
  const double mean_length = structure_.mean_element_length();
  length_scale_ = (std::isfinite(mean_length) && mean_length > 0.0) ? mean_length : 1.0;

  q_current_ = q0_;
  geometry_valid_ = true;
  sigma_ = Eigen::VectorXd::Zero(m_);
  lambda_f_ = Eigen::VectorXd::Zero(nq_);
  f_ = Eigen::VectorXd::Zero(nq_);

  // Jacobian pattern: df/dq, then A, then the cable-sum row. The iteration
  // order used here is the one jacobian_values() repeats.
  const Eigen::SparseMatrix<double>& dfdq = eq_.jacobian_positions(sigma_);
  for (int k = 0; k < dfdq.outerSize(); ++k) {
    for (Eigen::SparseMatrix<double>::InnerIterator it(dfdq, k); it; ++it) {
      jac_rows_.push_back(static_cast<int>(it.row()));
      jac_cols_.push_back(static_cast<int>(it.col()));
    }
  }
  jac_q_nonzeros_ = static_cast<int>(jac_rows_.size());
  const Eigen::SparseMatrix<double>& A = eq_.A();
  for (int k = 0; k < A.outerSize(); ++k) {
    for (Eigen::SparseMatrix<double>::InnerIterator it(A, k); it; ++it) {
      jac_rows_.push_back(static_cast<int>(it.row()));
      jac_cols_.push_back(nq_ + static_cast<int>(it.col()));
    }
  }
  jac_a_nonzeros_ = static_cast<int>(jac_rows_.size()) - jac_q_nonzeros_;
  if (scale_.has_cable_sum_row()) {
    for (int e = 0; e < m_; ++e) {
      const double c = scale_.normalisation_row[e];
      if (c == 0.0) continue;
      jac_rows_.push_back(nq_);
      jac_cols_.push_back(nq_ + e);
      normalisation_values_.push_back(c);
    }
  }

  // Hessian pattern: the equilibrium's lambda^T f triplets, then any q diagonal
  // entry they lack, so the objective's diagonal has a slot of its own.
  eq_.hessian_structure(hess_rows_, hess_cols_);
  eq_hess_nonzeros_ = static_cast<int>(hess_rows_.size());
  q_diagonal_index_.assign(nq_, -1);
  for (int k = 0; k < eq_hess_nonzeros_; ++k) {
    if (hess_rows_[k] == hess_cols_[k] && hess_rows_[k] < nq_ && q_diagonal_index_[hess_rows_[k]] < 0) {
      q_diagonal_index_[hess_rows_[k]] = k;
    }
  }
  for (int i = 0; i < nq_; ++i) {
    if (q_diagonal_index_[i] >= 0) continue;
    q_diagonal_index_[i] = static_cast<int>(hess_rows_.size());
    hess_rows_.push_back(i);
    hess_cols_.push_back(i);
  }
}

int MinimalGeometryChangeNlp::num_variables() const { return nq_ + m_; }
int MinimalGeometryChangeNlp::num_constraints() const {
  return nq_ + (scale_.has_cable_sum_row() ? 1 : 0);
}
int MinimalGeometryChangeNlp::num_positions() const { return nq_; }
int MinimalGeometryChangeNlp::num_forces() const { return m_; }

void MinimalGeometryChangeNlp::variable_bounds(Eigen::VectorXd& lower, Eigen::VectorXd& upper) const {
  const double inf = std::numeric_limits<double>::infinity();
  lower.resize(num_variables());
  upper.resize(num_variables());
  lower.head(nq_).setConstant(-inf);
  upper.head(nq_).setConstant(inf);
  lower.tail(m_) = scale_.lower;
  upper.tail(m_) = scale_.upper;
}

void MinimalGeometryChangeNlp::constraint_bounds(Eigen::VectorXd& lower, Eigen::VectorXd& upper) const {
  lower = Eigen::VectorXd::Zero(num_constraints());
  upper = lower;
  if (scale_.has_normalisation()) lower[nq_] = upper[nq_] = scale_.normalisation_target;
  // Under gravity the mean cable force is held at kappa times the weight by
  // default: from the scene, an upper bound alone lets Ipopt trade prestress
  // for geometry and end far away (docs/THEORY-force-scale.md).
  if (scale_.has_prestress_cap()) {
    upper[nq_] = scale_.prestress_cap;
    lower[nq_] = prestress_ == PrestressRow::Equal ? scale_.prestress_cap : -std::numeric_limits<double>::infinity();
  }
}

Eigen::VectorXd MinimalGeometryChangeNlp::initial_point(const Eigen::VectorXd& sigma0) const {
  Eigen::VectorXd z(num_variables());
  z.head(nq_) = q0_;
  z.tail(m_) = sigma0;
  return z;
}

Eigen::Matrix3Xd MinimalGeometryChangeNlp::positions(const Eigen::VectorXd& z) const {
  Eigen::Matrix3Xd x = structure_.positions;
  eq_.free_nodes().scatter(z.head(nq_), x);
  return x;
}

Eigen::VectorXd MinimalGeometryChangeNlp::forces(const Eigen::VectorXd& z) const { return z.tail(m_); }

double MinimalGeometryChangeNlp::objective(const Eigen::VectorXd& z) const {
  return (z.head(nq_) - q0_).squaredNorm() / (length_scale_ * length_scale_);
}

void MinimalGeometryChangeNlp::gradient(const Eigen::VectorXd& z, Eigen::VectorXd& g) const {
  g.resize(num_variables());
  g.head(nq_) = (2.0 / (length_scale_ * length_scale_)) * (z.head(nq_) - q0_);
  g.tail(m_).setZero();
}

void MinimalGeometryChangeNlp::update_geometry(const Eigen::VectorXd& z) {
  if (geometry_valid_ && z.head(nq_) == q_current_) return;
  q_current_ = z.head(nq_);
  eq_.set_free_coordinates(q_current_);
  geometry_valid_ = true;
}

void MinimalGeometryChangeNlp::copy_forces(const Eigen::VectorXd& z) { sigma_ = z.tail(m_); }

void MinimalGeometryChangeNlp::constraints(const Eigen::VectorXd& z, Eigen::VectorXd& c) {
  update_geometry(z);
  copy_forces(z);
  eq_.residual(sigma_, f_);
  c.resize(num_constraints());
  c.head(nq_) = f_;
  if (scale_.has_cable_sum_row()) c[nq_] = scale_.normalisation_row.dot(sigma_);
}

double MinimalGeometryChangeNlp::max_node_residual(const Eigen::VectorXd& z) {
  update_geometry(z);
  copy_forces(z);
  eq_.residual(sigma_, f_);
  double worst = 0.0;
  for (int i = 0; i < nq_; i += 3) worst = std::max(worst, f_.segment<3>(i).norm());
  return worst;
}

int MinimalGeometryChangeNlp::jacobian_nonzeros() const { return static_cast<int>(jac_rows_.size()); }

void MinimalGeometryChangeNlp::jacobian_structure(std::vector<int>& rows, std::vector<int>& cols) const {
  rows = jac_rows_;
  cols = jac_cols_;
}

void MinimalGeometryChangeNlp::jacobian_values(const Eigen::VectorXd& z, double* values) {
  update_geometry(z);
  copy_forces(z);
  int k = 0;
  const Eigen::SparseMatrix<double>& dfdq = eq_.jacobian_positions(sigma_);
  for (int j = 0; j < dfdq.outerSize(); ++j) {
    for (Eigen::SparseMatrix<double>::InnerIterator it(dfdq, j); it; ++it) values[k++] = it.value();
  }
  const Eigen::SparseMatrix<double>& A = eq_.A();
  for (int j = 0; j < A.outerSize(); ++j) {
    for (Eigen::SparseMatrix<double>::InnerIterator it(A, j); it; ++it) values[k++] = it.value();
  }
  for (double c : normalisation_values_) values[k++] = c;
}

int MinimalGeometryChangeNlp::hessian_nonzeros() const { return static_cast<int>(hess_rows_.size()); }

void MinimalGeometryChangeNlp::hessian_structure(std::vector<int>& rows, std::vector<int>& cols) const {
  rows = hess_rows_;
  cols = hess_cols_;
}

void MinimalGeometryChangeNlp::hessian_values(const Eigen::VectorXd& z, double obj_factor,
                                              const Eigen::VectorXd& lambda, double* values) {
  update_geometry(z);
  copy_forces(z);
  lambda_f_ = lambda.head(nq_);  // the cable-sum row is linear: no curvature
  const int nnz = hessian_nonzeros();
  for (int k = 0; k < nnz; ++k) values[k] = 0.0;
  eq_.hessian_values(sigma_, lambda_f_, values);
  const double diagonal = obj_factor * 2.0 / (length_scale_ * length_scale_);
  for (int i = 0; i < nq_; ++i) values[q_diagonal_index_[i]] += diagonal;
}

}  // namespace tensegrity
