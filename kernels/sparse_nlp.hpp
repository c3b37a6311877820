#pragma once
// A smooth nonlinear program with sparse derivatives, independent of the
// solver that minimizes it (kernels/ipopt_solve.hpp runs it with Ipopt):
//
//   minimize    f(x)                  x in R^n
//   subject to  g_l <= g(x) <= g_u    g: R^n -> R^m  (g_l = g_u: an equality)
//               x_l <= x <= x_u       (+-infinity: no bound)
//
// The problem states its sparsity structures once, as (row, col) lists; the
// value functions then fill arrays in exactly that order. The Hessian is
// that of the Lagrangian, obj_factor f(x) + lambda^T g(x), one triangle of
// it (each off-diagonal pair listed once).
#include <Eigen/Core>

#include <vector>

namespace tensegrity {

// Positions of the structurally non-zero entries of a sparse matrix.
struct SparsityPattern {
  std::vector<int> rows, cols;
  int size() const { return static_cast<int>(rows.size()); }
  void add(int row, int col) {
    rows.push_back(row);
    cols.push_back(col);
  }
};

// The solver's final point. At a KKT point
//   grad f(x) + J(x)^T lambda - z_L + z_U = 0,   z_L, z_U >= 0.
struct NlpSolution {
  Eigen::VectorXd x;
  Eigen::VectorXd constraint_multipliers;   // lambda, one per row of g
  Eigen::VectorXd lower_bound_multipliers;  // z_L, one per variable
  Eigen::VectorXd upper_bound_multipliers;  // z_U, one per variable
};

class SparseNlp {
 public:
  using ConstVector = Eigen::Ref<const Eigen::VectorXd>;
  using Vector = Eigen::Ref<Eigen::VectorXd>;

  virtual ~SparseNlp() = default;

  virtual int num_variables() const = 0;
  virtual int num_constraints() const = 0;
  virtual void variable_bounds(Vector lower, Vector upper) const = 0;
  virtual void constraint_bounds(Vector lower, Vector upper) const = 0;
  virtual void starting_point(Vector x) const = 0;

  // Each returns false when the function cannot be evaluated at x (the
  // solver then shortens its step or stops).
  virtual bool objective(const ConstVector& x, double& value) = 0;
  virtual bool gradient(const ConstVector& x, Vector gradient) = 0;
  virtual bool constraints(const ConstVector& x, Vector values) = 0;
  virtual bool jacobian_values(const ConstVector& x, Vector values) = 0;
  virtual bool hessian_values(const ConstVector& x, double obj_factor, const ConstVector& lambda,
                              Vector values) = 0;

  // Called once per solve, before the values above.
  virtual SparsityPattern jacobian_structure() const = 0;
  virtual SparsityPattern hessian_structure() const = 0;

  // True when f is convex, g affine in its equality rows and convex in its
  // one-sided rows: then a point of local infeasibility proves infeasibility.
  virtual bool is_convex() const { return false; }

  // Multipliers to start from (in the convention of NlpSolution), for a
  // start at a known KKT point; false (the default) leaves the solver its own.
  virtual bool starting_multipliers(Vector /*constraint_multipliers*/, Vector /*lower_bound_multipliers*/,
                                    Vector /*upper_bound_multipliers*/) const {
    return false;
  }

  // The solver's last point, whatever its outcome (not called when it
  // stopped before having one).
  virtual void finalize(const NlpSolution& /*solution*/) {}
};

// Largest disagreement between the analytic derivatives of `problem` at x
// and central differences, relative to max(1, |entry|) of the analytic side.
// The Hessian is checked on the Lagrangian with the given multipliers,
// against differences of the gradient and the transposed Jacobian.
struct DerivativeCheck {
  double gradient_error = 0.0;
  double jacobian_error = 0.0;
  double hessian_error = 0.0;
  bool evaluated = true;  // false when an evaluation failed
};

DerivativeCheck check_derivatives(SparseNlp& problem, const Eigen::VectorXd& x, double obj_factor,
                                  const Eigen::VectorXd& lambda, double step = 1e-6);

}  // namespace tensegrity
