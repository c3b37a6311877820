#include "kernels/stress_qp_ipopt.hpp"

#include <Eigen/SparseCore>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "kernels/ipopt_solve.hpp"

namespace tensegrity {
namespace {

// Ipopt's stand-in for an infinite bound.
constexpr double kIpoptInfinity = 2e19;
// The objective |r / F0|^2 is tiny near an equilibrium; scaled up, Ipopt's
// relative tests keep working on it. With the adaptive barrier update,
// measured on the equilibria of the 10- to 160-layer towers: 1e6 reaches
// relative residual 5.6e-9 on the 160-layer one where 1e4 stops at 8.3e-9.
constexpr double kObjectiveScaling = 1e6;
// Far below what Ipopt reaches: it stops on its acceptable level, and the
// caller verifies the forces.
constexpr double kTolerance = 1e-14;
constexpr int kMaxIterations = 500;

// Variables x = (sigma / F0, r / F0). Jacobian triplets: A column by column,
// then -I on r, then the cable-sum row. Hessian: the diagonal of r.
class ResidualForm final : public SparseNlp {
 public:
  ResidualForm(const Equilibrium& eq, const ForceScale& scale, const Eigen::VectorXd& sigma0)
      : A_(eq.A()),
        m_(static_cast<int>(A_.cols())),
        rows_(static_cast<int>(A_.rows())),
        f0_(scale.reference_force > 0.0 ? scale.reference_force : 1.0),
        normalised_(scale.has_normalisation() && scale.normalisation_row.size() == m_),
        scale_(scale) {
    load_.setZero(rows_);
    if (eq.has_gravity() && eq.gravity_load().size() == rows_) load_ = eq.gravity_load() / f0_;
    start_.resize(m_);
    const bool usable = sigma0.size() == m_ && sigma0.allFinite();
    for (int e = 0; e < m_; ++e) {
      const double lo = scale.lower.size() == m_ ? scale.lower[e] : -kIpoptInfinity;
      const double hi = scale.upper.size() == m_ ? scale.upper[e] : kIpoptInfinity;
      const double reference = hi > 0.0 ? f0_ : -f0_;  // a cable's upper bound is +infinity
      start_[e] = std::clamp(usable ? sigma0[e] : reference, lo, hi) / f0_;
    }
  }

  int num_variables() const override { return m_ + rows_; }
  int num_constraints() const override { return rows_ + (normalised_ ? 1 : 0); }

  void variable_bounds(Vector lower, Vector upper) const override {
    lower.setConstant(-kIpoptInfinity);
    upper.setConstant(kIpoptInfinity);
    for (int e = 0; e < m_; ++e) {
      if (scale_.lower.size() == m_ && std::isfinite(scale_.lower[e])) lower[e] = scale_.lower[e] / f0_;
      if (scale_.upper.size() == m_ && std::isfinite(scale_.upper[e])) upper[e] = scale_.upper[e] / f0_;
    }
  }

  void constraint_bounds(Vector lower, Vector upper) const override {
    lower.head(rows_) = -load_;
    upper.head(rows_) = -load_;
    if (normalised_) lower[rows_] = upper[rows_] = scale_.normalisation_target / f0_;
  }

  void starting_point(Vector x) const override {
    x.head(m_) = start_;
    x.tail(rows_) = A_ * start_ + load_;
  }

  bool objective(const ConstVector& x, double& value) override {
    value = x.tail(rows_).squaredNorm();
    return true;
  }
  bool gradient(const ConstVector& x, Vector gradient) override {
    gradient.head(m_).setZero();
    gradient.tail(rows_) = 2.0 * x.tail(rows_);
    return true;
  }
  bool constraints(const ConstVector& x, Vector values) override {
    values.head(rows_) = A_ * x.head(m_) - x.tail(rows_);
    if (normalised_) values[rows_] = scale_.normalisation_row.dot(x.head(m_));
    return true;
  }

  SparsityPattern jacobian_structure() const override {
    SparsityPattern p;
    for (int j = 0; j < m_; ++j)
      for (Eigen::SparseMatrix<double>::InnerIterator it(A_, j); it; ++it) p.add(static_cast<int>(it.row()), j);
    for (int i = 0; i < rows_; ++i) p.add(i, m_ + i);
    if (normalised_)
      for (int j = 0; j < m_; ++j) p.add(rows_, j);
    return p;
  }
  bool jacobian_values(const ConstVector& /*x*/, Vector values) override {
    int k = 0;
    for (int j = 0; j < m_; ++j)
      for (Eigen::SparseMatrix<double>::InnerIterator it(A_, j); it; ++it) values[k++] = it.value();
    for (int i = 0; i < rows_; ++i) values[k++] = -1.0;
    if (normalised_)
      for (int j = 0; j < m_; ++j) values[k++] = scale_.normalisation_row[j];
    return true;
  }

  SparsityPattern hessian_structure() const override {
    SparsityPattern p;
    for (int i = 0; i < rows_; ++i) p.add(m_ + i, m_ + i);
    return p;
  }
  bool hessian_values(const ConstVector& /*x*/, double obj_factor, const ConstVector& /*lambda*/,
                      Vector values) override {
    values.setConstant(2.0 * obj_factor);
    return true;
  }

  bool is_convex() const override { return true; }

  void finalize(const NlpSolution& solution) override { forces_of(solution.x, sigma_); }

  // The forces (N) of a point of Ipopt's, within the bounds.
  void forces_of(const Eigen::VectorXd& x, Eigen::VectorXd& sigma) const {
    sigma = x.head(m_) * f0_;
    for (int e = 0; e < m_; ++e) {
      if (scale_.lower.size() == m_) sigma[e] = std::max(sigma[e], scale_.lower[e]);
      if (scale_.upper.size() == m_) sigma[e] = std::min(sigma[e], scale_.upper[e]);
    }
  }

  const Eigen::VectorXd& sigma() const { return sigma_; }

 private:
  const Eigen::SparseMatrix<double>& A_;
  int m_ = 0, rows_ = 0;
  double f0_ = 1.0;
  bool normalised_ = false;
  const ForceScale& scale_;
  Eigen::VectorXd load_, start_, sigma_;
};

}  // namespace

StressQpIpoptResult solve_stress_qp_with_ipopt(const Equilibrium& eq, const ForceScale& scale,
                                               const Eigen::VectorXd& sigma0, double time_limit_s,
                                               const ForceMeasure& measure, double stop_below) {
  const auto t0 = std::chrono::steady_clock::now();
  ResidualForm problem(eq, scale, sigma0);
  const int m = eq.num_elements();
  StressQpIpoptResult result;
  result.measure = std::numeric_limits<double>::infinity();
  Eigen::VectorXd sigma(m);
  IpoptSettings settings;
  settings.set("tol", kTolerance);
  settings.set("max_iter", kMaxIterations);
  settings.set("obj_scaling_factor", kObjectiveScaling);
  settings.set("mu_strategy", "adaptive");
  // The sign margins are part of the answer: no relaxation of the bounds.
  settings.set("bound_relax_factor", 0.0);
  settings.on_iteration = [&](const IpoptIteration& it) {
    if (it.x != nullptr && it.x->size() == problem.num_variables()) {
      problem.forces_of(*it.x, sigma);
      const double value = measure(sigma);
      if (value < result.measure) {
        result.measure = value;
        result.sigma = sigma;
      }
      if (result.measure <= stop_below) return IterationControl::StopSatisfied;
    }
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return seconds > time_limit_s ? IterationControl::StopForTimeLimit : IterationControl::Continue;
  };
  const IpoptSolveResult run = solve_with_ipopt(problem, settings);
  result.status = run.status;
  result.message = run.message;
  result.iterations = run.iterations;
  if (result.sigma.size() != m && run.has_solution && problem.sigma().allFinite()) {
    result.sigma = problem.sigma();
    result.measure = measure(result.sigma);
  }
  return result;
}

}  // namespace tensegrity
