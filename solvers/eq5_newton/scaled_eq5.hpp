#pragma once
// Eq. 5 (formulations/minimal_geometry_change_nlp.hpp) in dimensionless
// variables for a Newton method on its KKT conditions:
//
//   y = (q / L, sigma / F0 [, s])                 (L mean element length, F0 ForceScale)
//   phi(y)  = |q - q0|^2 / L^2                    (the NLP's own objective)
//   c(y)    = (f(q, sigma) / F0, (c^T sigma - t) / F0 [+ s]) = 0
//             t = n_c F0 without gravity, kappa n_c W under gravity
//   d_e(y)  = s_e sigma_e / F0 - margin / F0 >= 0 (s_e = +1 cable, -1 strut)
//   d_s(y)  = s >= 0
//
// The slack s is there when the NLP bounds the cable-sum row only from above
// (PrestressRow::Cap: c^T sigma <= kappa n_c W under gravity); it turns the
// inequality into an equality and one more bound, so the Newton method sees
// bounds on the variables only. The bounded variables are the last
// num_bounded() ones: the forces, then s.
//
// With D = diag(L on q, F0 on sigma) and z = D y the derivatives are the NLP's
// rescaled: grad_y = D grad_z, J_y = J_z D / F0, and the Hessian of
// phi + lambda_y^T c is D Hess_z(1, lambda_y / F0) D. The Jacobian and the
// Hessian are sparse matrices whose patterns are built once; later calls only
// write values.
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <vector>

#include "formulations/minimal_geometry_change_nlp.hpp"

namespace tensegrity {

class ScaledEq5 {
 public:
  using SparseMatrix = Eigen::SparseMatrix<double>;

  explicit ScaledEq5(MinimalGeometryChangeNlp& nlp);

  int num_variables() const { return n_; }
  int num_constraints() const { return mc_; }
  int num_positions() const { return nq_; }
  int num_forces() const { return m_; }
  bool has_cap_slack() const { return has_slack_; }
  int num_bounded() const { return m_ + (has_slack_ ? 1 : 0); }  // the tail of y

  // z = (q, sigma) in m, N; the slack, where there is one, from the cap row at z.
  Eigen::VectorXd to_scaled(const Eigen::VectorXd& z) const;
  Eigen::VectorXd to_si(const Eigen::VectorXd& y) const;  // (q, sigma): the slack dropped

  double objective(const Eigen::VectorXd& y) const;
  void gradient(const Eigen::VectorXd& y, Eigen::VectorXd& g) const;
  void constraints(const Eigen::VectorXd& y, Eigen::VectorXd& c);
  // mc x n, pattern fixed at construction.
  const SparseMatrix& jacobian(const Eigen::VectorXd& y);
  // Lower triangle of the Hessian of phi + lambda^T c (n x n, pattern fixed;
  // every diagonal entry is present, zero where the problem has none).
  const SparseMatrix& hessian(const Eigen::VectorXd& y, const Eigen::VectorXd& lambda);

  // Per bounded variable (the tail of y) its sign and scaled margin:
  // d = signs .* y_tail - margins (forces: s_e and margin / F0; the slack: 1 and 0).
  const Eigen::VectorXd& bound_signs() const { return signs_; }
  const Eigen::VectorXd& bound_margins() const { return margins_; }
  double scaled_margin() const { return margin_; }  // the forces' margin / F0
  void slacks(const Eigen::VectorXd& y, Eigen::VectorXd& d) const;

  MinimalGeometryChangeNlp& nlp() { return nlp_; }

  // The cable-sum row is c's last entry (index num_positions()) when there is one.
  bool has_cable_sum_row() const { return mc_ > nq_; }
  // That row's rounding floor at y: kSumRoundingUlps units in the last place
  // of the sum of its terms' magnitudes (dimensionless, as c). It sums every
  // cable force, so on large structures it is far above the node rows'.
  double cable_sum_row_floor(const Eigen::VectorXd& y) const;

 private:
  MinimalGeometryChangeNlp& nlp_;
  int nq_ = 0, m_ = 0, n_ = 0, mc_ = 0;
  bool has_slack_ = false;
  int slack_jacobian_slot_ = -1;  // the slack's entry (value 1) in the cap row
  double length_ = 1.0, force_ = 1.0, margin_ = 0.0, target_ = 0.0;
  Eigen::VectorXd scale_;  // D, on (q, sigma)
  Eigen::VectorXd signs_, margins_;
  SparseMatrix jacobian_, hessian_;
  // Triplet k of the NLP's Jacobian / Hessian -> value index in the matrix,
  // and the factor that scales it.
  std::vector<int> jac_slot_, hess_slot_;
  std::vector<double> jac_factor_, hess_factor_;
  std::vector<double> jac_values_, hess_values_;
  mutable Eigen::VectorXd z_, grad_z_, c_z_, lambda_z_;
};

// Builds the compressed pattern of `rows`/`cols` (duplicates merged, plus the
// extra diagonal entries 0 .. extra_diagonal - 1) and, per triplet, the index
// of its value in the matrix's value array.
Eigen::SparseMatrix<double> sparse_pattern(int num_rows, int num_cols, const std::vector<int>& rows,
                                           const std::vector<int>& cols, int extra_diagonal,
                                           std::vector<int>& slot);

}  // namespace tensegrity
