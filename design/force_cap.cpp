#include "design/force_cap.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <vector>

#include "formulations/equilibrium.hpp"
#include "kernels/ipopt_solve.hpp"
#include "kernels/sparse_nlp.hpp"

namespace tensegrity {
namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

// An LP. Variables y = (sigma / S, t); rows: the independent equilibrium rows
// / S, then one row (S / cap_c) y_c - t <= 0 per capped cable; minimize t.
class ForceCapLp final : public SparseNlp {
 public:
  ForceCapLp(const Equilibrium& eq, const std::vector<int>& rows, const Eigen::VectorXd& lower,
             const Eigen::VectorXd& upper, const Eigen::VectorXd& cap, double scale, const Eigen::VectorXd& y0)
      : lower_(lower), upper_(upper), scale_(scale), y0_(y0) {
    const Eigen::SparseMatrix<double>& A = eq.A();
    m_ = static_cast<int>(A.cols());
    std::vector<int> kept(A.rows(), -1);
    for (std::size_t i = 0; i < rows.size(); ++i) kept[rows[i]] = static_cast<int>(i);
    for (int c = 0; c < A.outerSize(); ++c)
      for (Eigen::SparseMatrix<double>::InnerIterator it(A, c); it; ++it)
        if (it.value() != 0.0 && kept[it.row()] >= 0) add(kept[it.row()], c, it.value());
    num_eq_ = static_cast<int>(rows.size());
    rhs_.resize(num_eq_);
    for (int i = 0; i < num_eq_; ++i) rhs_[i] = eq.has_gravity() ? -eq.gravity_load()[rows[i]] / scale_ : 0.0;
    for (int e = 0; e < m_; ++e)
      if (std::isfinite(cap[e]) && cap[e] > 0.0) {
        const int row = num_eq_ + static_cast<int>(capped.size());
        capped.push_back(e);
        add(row, e, scale_ / cap[e]);
        add(row, m_, -1.0);
      }
  }

  int num_variables() const override { return m_ + 1; }
  int num_constraints() const override { return num_eq_ + static_cast<int>(capped.size()); }
  void variable_bounds(Vector xl, Vector xu) const override {
    for (int e = 0; e < m_; ++e) {
      xl[e] = std::isfinite(lower_[e]) ? lower_[e] / scale_ : -kInfinity;
      xu[e] = std::isfinite(upper_[e]) ? upper_[e] / scale_ : kInfinity;
    }
    xl[m_] = 0.0;
    xu[m_] = kInfinity;
  }
  void constraint_bounds(Vector gl, Vector gu) const override {
    for (int i = 0; i < num_constraints(); ++i) {
      gl[i] = i < num_eq_ ? rhs_[i] : -kInfinity;
      gu[i] = i < num_eq_ ? rhs_[i] : 0.0;
    }
  }
  void starting_point(Vector x) const override { x = y0_; }
  bool objective(const ConstVector& x, double& f) override {
    f = x[m_];
    return true;
  }
  bool gradient(const ConstVector&, Vector g) override {
    g.setZero();
    g[m_] = 1.0;
    return true;
  }
  bool constraints(const ConstVector& x, Vector g) override {
    g.setZero();
    for (std::size_t k = 0; k < val_.size(); ++k) g[jacobian_.rows[k]] += val_[k] * x[jacobian_.cols[k]];
    return true;
  }
  bool jacobian_values(const ConstVector&, Vector values) override {
    std::copy(val_.begin(), val_.end(), values.data());
    return true;
  }
  bool hessian_values(const ConstVector&, double, const ConstVector&, Vector) override { return true; }
  SparsityPattern jacobian_structure() const override { return jacobian_; }
  SparsityPattern hessian_structure() const override { return {}; }
  bool is_convex() const override { return true; }
  void finalize(const NlpSolution& solution) override {
    y = solution.x;
    multipliers = solution.constraint_multipliers.tail(capped.size());
  }

  std::vector<int> capped;
  Eigen::VectorXd y, multipliers;

 private:
  void add(int row, int col, double value) {
    jacobian_.add(row, col);
    val_.push_back(value);
  }
  const Eigen::VectorXd &lower_, &upper_;
  double scale_;
  Eigen::VectorXd y0_;
  int m_ = 0, num_eq_ = 0;
  SparsityPattern jacobian_;
  std::vector<double> val_, rhs_;
};

}  // namespace

ForceCapResult smallest_force_cap(const Structure& s, const Eigen::Matrix3Xd& positions, const Eigen::VectorXd& lower,
                                  const Eigen::VectorXd& upper, const Eigen::VectorXd& cap) {
  ForceCapResult r;
  const int m = s.num_elements();
  Equilibrium eq(s);
  eq.set_positions(positions);
  double scale = eq.has_gravity() ? eq.gravity_load().cwiseAbs().maxCoeff() : 0.0;
  for (int e = 0; e < m; ++e)
    if (std::isfinite(cap[e]) && cap[e] > 0.0) scale = std::max(scale, cap[e]);
  if (!(scale > 0.0) || !std::isfinite(scale)) scale = 1.0;

  // A maximal independent set of rows (Ipopt needs a full-rank Jacobian), as
  // in the stiffness solver; dependent rows are implied when the load is
  // consistent, which the equilibrium check below confirms.
  const Eigen::MatrixXd Ad = Eigen::MatrixXd(eq.A());
  std::vector<int> rows;
  if (Ad.size() > 0) {
    Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(Ad.transpose());
    qr.setThreshold(1e-10);
    for (int i = 0; i < static_cast<int>(qr.rank()); ++i) rows.push_back(qr.colsPermutation().indices()[i]);
    std::sort(rows.begin(), rows.end());
  }

  Eigen::VectorXd y0(m + 1);
  for (int e = 0; e < m; ++e) {
    const double lo = std::isfinite(lower[e]) ? lower[e] : -scale, hi = std::isfinite(upper[e]) ? upper[e] : scale;
    y0[e] = std::clamp(s.elements[e].kind == ElementKind::Cable ? std::max(lo, 0.0) : std::min(hi, 0.0), lo, hi) / scale;
  }
  y0[m] = 1.0;
  ForceCapLp lp(eq, rows, lower, upper, cap, scale, y0);
  if (lp.capped.empty()) {
    r.message = "no cable has a force cap";
    return r;
  }
  IpoptSettings settings;
  settings.set("tol", 1e-10);
  settings.set("max_iter", 3000);
  settings.set("hessian_constant", "yes");
  settings.set("jac_c_constant", "yes");
  settings.set("jac_d_constant", "yes");
  settings.set("mu_strategy", "adaptive");
  const IpoptSolveResult run = solve_with_ipopt(lp, settings);
  if (run.has_solution) {
    r.sigma = lp.y.head(m) * scale;
    r.ratio = lp.y[m];
  }
  if (run.status != Status::Converged) {
    r.status = run.status;
    r.message = r.status == Status::Infeasible
                    ? "no forces balance the loads within the sign bounds at this geometry, whatever the caps"
                    : run.message;
    return r;
  }
  // Ipopt's inequality multipliers for g <= 0 are >= 0 at a minimum.
  std::vector<int> order(lp.capped.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(),
            [&](int a, int b) { return std::abs(lp.multipliers[a]) > std::abs(lp.multipliers[b]); });
  for (int k : order)
    if (std::abs(lp.multipliers[k]) > 1e-6) {
      r.tightest.push_back(lp.capped[k]);
      r.share.push_back(std::abs(lp.multipliers[k]));
    }
  r.status = Status::Converged;
  r.message = "smallest achievable largest cable force / cap: " + std::to_string(r.ratio);
  return r;
}

}  // namespace tensegrity
