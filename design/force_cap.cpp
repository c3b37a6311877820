#include "design/force_cap.hpp"

#include <coin/IpIpoptApplication.hpp>
#include <coin/IpTNLP.hpp>

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <vector>

#include "formulations/equilibrium.hpp"
#include "kernels/ipopt_run.hpp"

namespace tensegrity {
namespace {

using Ipopt::Index;
using Ipopt::Number;

constexpr double kIpoptInfinity = 1e19;

// Variables y = (sigma / S, t); rows: the independent equilibrium rows / S,
// then one row (S / cap_c) y_c - t <= 0 per capped cable.
class ForceCapTnlp : public Ipopt::TNLP {
 public:
  ForceCapTnlp(const Equilibrium& eq, const std::vector<int>& rows, const Eigen::VectorXd& lower,
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

  bool get_nlp_info(Index& n, Index& m, Index& nnz_jac, Index& nnz_h, IndexStyleEnum& style) override {
    n = m_ + 1;
    m = num_eq_ + static_cast<Index>(capped.size());
    nnz_jac = static_cast<Index>(val_.size());
    nnz_h = 0;
    style = C_STYLE;
    return true;
  }
  bool get_bounds_info(Index, Number* xl, Number* xu, Index m, Number* gl, Number* gu) override {
    for (int e = 0; e < m_; ++e) {
      xl[e] = std::isfinite(lower_[e]) ? lower_[e] / scale_ : -kIpoptInfinity;
      xu[e] = std::isfinite(upper_[e]) ? upper_[e] / scale_ : kIpoptInfinity;
    }
    xl[m_] = 0.0;
    xu[m_] = kIpoptInfinity;
    for (Index i = 0; i < m; ++i) {
      gl[i] = i < num_eq_ ? rhs_[i] : -kIpoptInfinity;
      gu[i] = i < num_eq_ ? rhs_[i] : 0.0;
    }
    return true;
  }
  bool get_starting_point(Index n, bool init_x, Number* x, bool init_z, Number*, Number*, Index, bool init_lambda,
                          Number*) override {
    if (init_z || init_lambda) return false;
    if (init_x)
      for (Index k = 0; k < n; ++k) x[k] = y0_[k];
    return true;
  }
  bool eval_f(Index, const Number* x, bool, Number& f) override {
    f = x[m_];
    return true;
  }
  bool eval_grad_f(Index n, const Number*, bool, Number* g) override {
    std::fill(g, g + n, 0.0);
    g[m_] = 1.0;
    return true;
  }
  bool eval_g(Index, const Number* x, bool, Index m, Number* g) override {
    std::fill(g, g + m, 0.0);
    for (std::size_t k = 0; k < val_.size(); ++k) g[row_[k]] += val_[k] * x[col_[k]];
    return true;
  }
  bool eval_jac_g(Index, const Number*, bool, Index, Index, Index* iRow, Index* jCol, Number* values) override {
    if (!values) {
      std::copy(row_.begin(), row_.end(), iRow);
      std::copy(col_.begin(), col_.end(), jCol);
    } else {
      std::copy(val_.begin(), val_.end(), values);
    }
    return true;
  }
  bool eval_h(Index, const Number*, bool, Number, Index, const Number*, bool, Index, Index*, Index*,
              Number*) override {
    return true;
  }
  void finalize_solution(Ipopt::SolverReturn status, Index n, const Number* x, const Number*, const Number*, Index m,
                         const Number*, const Number* lambda, Number, const Ipopt::IpoptData*,
                         Ipopt::IpoptCalculatedQuantities*) override {
    status_ = status;
    y = Eigen::Map<const Eigen::VectorXd>(x, n);
    multipliers = Eigen::Map<const Eigen::VectorXd>(lambda, m).tail(capped.size());
  }

  Ipopt::SolverReturn status() const { return status_; }
  std::vector<int> capped;
  Eigen::VectorXd y, multipliers;

 private:
  void add(int row, int col, double value) {
    row_.push_back(row);
    col_.push_back(col);
    val_.push_back(value);
  }
  const Eigen::VectorXd &lower_, &upper_;
  double scale_;
  Eigen::VectorXd y0_;
  int m_ = 0, num_eq_ = 0;
  std::vector<Index> row_, col_;
  std::vector<double> val_, rhs_;
  Ipopt::SolverReturn status_ = Ipopt::INTERNAL_ERROR;
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
  Ipopt::SmartPtr<ForceCapTnlp> nlp = new ForceCapTnlp(eq, rows, lower, upper, cap, scale, y0);
  if (nlp->capped.empty()) {
    r.message = "no cable has a force cap";
    return r;
  }
  const IpoptRun run = run_ipopt(GetRawPtr(nlp), [](Ipopt::OptionsList& o) {
    o.SetNumericValue("tol", 1e-10);
    o.SetIntegerValue("max_iter", 3000);
    o.SetStringValue("hessian_constant", "yes");
    o.SetStringValue("jac_c_constant", "yes");
    o.SetStringValue("jac_d_constant", "yes");
    o.SetStringValue("mu_strategy", "adaptive");
  });
  if (!run.error.empty()) {
    r.message = run.error;
    return r;
  }
  const Ipopt::ApplicationReturnStatus status = run.status;
  if (nlp->y.size() != m + 1) {
    r.message = "Ipopt returned no point";
    return r;
  }
  r.sigma = nlp->y.head(m) * scale;
  r.ratio = nlp->y[m];
  if (status == Ipopt::Infeasible_Problem_Detected) {
    r.status = Status::Infeasible;
    r.message = "no forces balance the loads within the sign bounds at this geometry, whatever the caps";
    return r;
  }
  if (status != Ipopt::Solve_Succeeded && status != Ipopt::Solved_To_Acceptable_Level) {
    r.status = status == Ipopt::Maximum_Iterations_Exceeded ? Status::MaxIterations : Status::NumericalError;
    r.message = "Ipopt returned status " + std::to_string(static_cast<int>(status));
    return r;
  }
  // Ipopt's inequality multipliers for g <= 0 are >= 0 at a minimum.
  std::vector<int> order(nlp->capped.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(),
            [&](int a, int b) { return std::abs(nlp->multipliers[a]) > std::abs(nlp->multipliers[b]); });
  for (int k : order)
    if (std::abs(nlp->multipliers[k]) > 1e-6) {
      r.tightest.push_back(nlp->capped[k]);
      r.share.push_back(std::abs(nlp->multipliers[k]));
    }
  r.status = Status::Converged;
  r.message = "smallest achievable largest cable force / cap: " + std::to_string(r.ratio);
  return r;
}

}  // namespace tensegrity
