#include "kernels/sparse_nlp.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>

namespace tensegrity {
namespace {

Eigen::MatrixXd dense_jacobian(SparseNlp& problem, const SparsityPattern& pattern, const Eigen::VectorXd& x,
                               bool& ok) {
  Eigen::VectorXd values(pattern.size());
  ok = problem.jacobian_values(x, values) && ok;
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(problem.num_constraints(), problem.num_variables());
  for (int k = 0; k < pattern.size(); ++k) J(pattern.rows[k], pattern.cols[k]) += values[k];
  return J;
}

// The gradient of obj_factor f + lambda^T g.
Eigen::VectorXd lagrangian_gradient(SparseNlp& problem, const SparsityPattern& jacobian, const Eigen::VectorXd& x,
                                    double obj_factor, const Eigen::VectorXd& lambda, bool& ok) {
  Eigen::VectorXd grad(problem.num_variables());
  ok = problem.gradient(x, grad) && ok;
  return obj_factor * grad + dense_jacobian(problem, jacobian, x, ok).transpose() * lambda;
}

double relative_error(double analytic, double numeric) {
  return std::abs(analytic - numeric) / std::max(1.0, std::abs(analytic));
}

}  // namespace

DerivativeCheck check_derivatives(SparseNlp& problem, const Eigen::VectorXd& x, double obj_factor,
                                  const Eigen::VectorXd& lambda, double step) {
  DerivativeCheck check;
  bool ok = true;
  const int n = problem.num_variables();
  const SparsityPattern jacobian = problem.jacobian_structure();
  const SparsityPattern hessian = problem.hessian_structure();

  Eigen::VectorXd grad(n), c_plus(problem.num_constraints()), c_minus(problem.num_constraints());
  ok = problem.gradient(x, grad) && ok;
  const Eigen::MatrixXd J = dense_jacobian(problem, jacobian, x, ok);
  Eigen::VectorXd hessian_values(hessian.size());
  ok = problem.hessian_values(x, obj_factor, lambda, hessian_values) && ok;
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(n, n);
  for (int k = 0; k < hessian.size(); ++k) {
    H(hessian.rows[k], hessian.cols[k]) += hessian_values[k];
    if (hessian.rows[k] != hessian.cols[k]) H(hessian.cols[k], hessian.rows[k]) += hessian_values[k];
  }

  for (int i = 0; i < n; ++i) {
    Eigen::VectorXd plus = x, minus = x;
    plus[i] += step;
    minus[i] -= step;
    double f_plus = 0.0, f_minus = 0.0;
    ok = problem.objective(plus, f_plus) && problem.objective(minus, f_minus) && ok;
    check.gradient_error = std::max(check.gradient_error, relative_error(grad[i], (f_plus - f_minus) / (2 * step)));
    ok = problem.constraints(plus, c_plus) && problem.constraints(minus, c_minus) && ok;
    const Eigen::VectorXd jacobian_column = (c_plus - c_minus) / (2 * step);
    for (int r = 0; r < J.rows(); ++r)
      check.jacobian_error = std::max(check.jacobian_error, relative_error(J(r, i), jacobian_column[r]));
    const Eigen::VectorXd hessian_column =
        (lagrangian_gradient(problem, jacobian, plus, obj_factor, lambda, ok) -
         lagrangian_gradient(problem, jacobian, minus, obj_factor, lambda, ok)) / (2 * step);
    for (int r = 0; r < n; ++r)
      check.hessian_error = std::max(check.hessian_error, relative_error(H(r, i), hessian_column[r]));
  }
  check.evaluated = ok;
  return check;
}

}  // namespace tensegrity
