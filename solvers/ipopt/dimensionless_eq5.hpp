#pragma once
// Eq. 5 (formulations/minimal_geometry_change_nlp.hpp) as the `ipopt`
// backend hands it to Ipopt, made dimensionless:
//   y = ((q - q0) / L, sigma / F0),  rows f / F0 and c^T sigma / F0,
// L the mean element length, F0 the ForceScale reference force. With
// D = diag(L on q, F0 on sigma), z = z0 + D y, so
//   grad_y = D grad_z,  J_y = J_z D / F0,
//   Hess_y L(y; obj_factor, lambda_y) = D Hess_z L(z; obj_factor, lambda_y / F0) D.
#include <Eigen/Core>

#include <limits>
#include <vector>

#include "kernels/ipopt_solve.hpp"
#include "kernels/sparse_nlp.hpp"
#include "solvers/solver.hpp"

namespace tensegrity {

class MinimalGeometryChangeNlp;

class DimensionlessEq5 final : public SparseNlp {
 public:
  // Starts at the scene geometry with forces sigma0 (N).
  DimensionlessEq5(MinimalGeometryChangeNlp& nlp, const Eigen::VectorXd& sigma0);
  // Starts instead at free coordinates q (m) and forces sigma (N); the
  // objective still measures the change from the scene geometry.
  void set_start(const Eigen::VectorXd& q, const Eigen::VectorXd& sigma);
  // Also starts from these multipliers (SolverDetails' Eq. 5 multipliers:
  // per row 1/N, per member's sign bound 1/N); Ipopt reads them under
  // warm_start_init_point=yes.
  void set_start_multipliers(const Eigen::VectorXd& rows, const Eigen::VectorXd& force_bounds);

  int num_variables() const override { return n_; }
  int num_constraints() const override { return ncon_; }
  void variable_bounds(Vector lower, Vector upper) const override;
  void constraint_bounds(Vector lower, Vector upper) const override;
  void starting_point(Vector y) const override { y = y0_; }
  bool starting_multipliers(Vector lambda, Vector z_lower, Vector z_upper) const override;
  bool objective(const ConstVector& y, double& value) override;
  bool gradient(const ConstVector& y, Vector gradient) override;
  bool constraints(const ConstVector& y, Vector values) override;
  bool jacobian_values(const ConstVector& y, Vector values) override;
  bool hessian_values(const ConstVector& y, double obj_factor, const ConstVector& lambda, Vector values) override;
  SparsityPattern jacobian_structure() const override { return jacobian_; }
  SparsityPattern hessian_structure() const override { return hessian_; }
  void finalize(const NlpSolution& solution) override;

  // The trace record of an Ipopt iteration: the residuals of docs/FORMATS.md at the
  // iterate, or only Ipopt's own infeasibility in the restoration phase.
  // `max_free_weight` is the load scale under gravity (0 without).
  TracePoint trace_point(const IpoptIteration& it, double max_free_weight);

  bool has_final_point() const { return has_final_point_; }
  const Eigen::VectorXd& final_point() const { return z_final_; }  // z = (q, sigma)
  // Ipopt's multiplier of the cable-sum row at the final
  // point, in the convention of NlpSolution (grad f + J^T lambda - z_L + z_U
  // = 0); NaN without that row or a final point. At an optimum with the row
  // held at the prestress cap, lambda >= 0 says that lowering the level
  // would not bring the geometry closer: the point then also satisfies the
  // KKT conditions of the problem with the row only bounded above.
  double cable_sum_multiplier() const { return cable_sum_multiplier_; }

 private:
  void to_z(const ConstVector& y);

  MinimalGeometryChangeNlp& nlp_;
  int nq_ = 0, m_ = 0, n_ = 0, ncon_ = 0;
  double length_ = 1.0, force_ = 1.0;
  Eigen::VectorXd q0_, variable_scale_, y0_, z_, c_, grad_, lambda_, z_final_;
  Eigen::VectorXd start_rows_, start_lower_, start_upper_;  // scaled; empty: Ipopt's own
  SparsityPattern jacobian_, hessian_;
  std::vector<double> jac_factor_, hess_factor_;
  int evaluations_ = 0;
  bool has_final_point_ = false;
  double cable_sum_multiplier_ = std::numeric_limits<double>::quiet_NaN();
};

}  // namespace tensegrity
