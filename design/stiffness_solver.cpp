#include "design/stiffness_solver.hpp"

#include <coin/IpIpoptApplication.hpp>
#include <coin/IpTNLP.hpp>

#include <Eigen/Dense>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <vector>

#include "formulations/equilibrium.hpp"
#include "kernels/ipopt_run.hpp"
#include "model/verify.hpp"

namespace tensegrity {
namespace {

using Ipopt::Index;
using Ipopt::Number;

constexpr double kIpoptInfinity = 1e19;  // Ipopt's default nlp_{lower,upper}_bound_inf

// The QP in forces scaled by S: y = sigma / S, objective / S^2.
class StiffnessTnlp : public Ipopt::TNLP {
 public:
  // `rows`: a maximal independent set of equilibrium rows (Ipopt needs a
  // full-rank constraint Jacobian and no more equalities than unknowns).
  StiffnessTnlp(const Equilibrium& eq, const StiffnessProblem& p, double scale, const Eigen::VectorXd& y0,
                std::vector<int> rows)
      : p_(p), scale_(scale), y0_(y0), rows_(std::move(rows)) {
    const Eigen::SparseMatrix<double>& A = eq.A();
    m_ = static_cast<int>(A.cols());
    std::vector<int> kept(A.rows(), -1);
    for (std::size_t i = 0; i < rows_.size(); ++i) kept[rows_[i]] = static_cast<int>(i);
    for (int c = 0; c < A.outerSize(); ++c)
      for (Eigen::SparseMatrix<double>::InnerIterator it(A, c); it; ++it)
        if (it.value() != 0.0 && kept[it.row()] >= 0) {
          jac_row_.push_back(kept[it.row()]);
          jac_col_.push_back(c);
          jac_val_.push_back(it.value());
        }
    rhs_.resize(rows_.size());
    for (std::size_t i = 0; i < rows_.size(); ++i)
      rhs_[i] = eq.has_gravity() ? -eq.gravity_load()[rows_[i]] / scale_ : 0.0;
    for (int e = 0; e < m_; ++e)
      if (p_.weight[e] > 0.0) hess_.push_back(e);
  }

  bool get_nlp_info(Index& n, Index& m, Index& nnz_jac, Index& nnz_h, IndexStyleEnum& style) override {
    n = m_;
    m = static_cast<Index>(rows_.size());
    nnz_jac = static_cast<Index>(jac_val_.size());
    nnz_h = static_cast<Index>(hess_.size());
    style = C_STYLE;
    return true;
  }
  bool get_bounds_info(Index n, Number* xl, Number* xu, Index m, Number* gl, Number* gu) override {
    for (Index e = 0; e < n; ++e) {
      xl[e] = std::isfinite(p_.lower[e]) ? p_.lower[e] / scale_ : -kIpoptInfinity;
      xu[e] = std::isfinite(p_.upper[e]) ? p_.upper[e] / scale_ : kIpoptInfinity;
    }
    for (Index i = 0; i < m; ++i) gl[i] = gu[i] = rhs_[i];
    return true;
  }
  bool get_starting_point(Index n, bool init_x, Number* x, bool init_z, Number*, Number*, Index, bool init_lambda,
                          Number*) override {
    if (init_z || init_lambda) return false;
    if (init_x)
      for (Index e = 0; e < n; ++e) x[e] = y0_[e];
    return true;
  }
  bool eval_f(Index n, const Number* x, bool, Number& f) override {
    f = 0.0;
    for (Index e = 0; e < n; ++e) {
      const double d = x[e] - p_.target[e] / scale_;
      if (p_.weight[e] > 0.0) f += 0.5 * p_.weight[e] * d * d;
    }
    return true;
  }
  bool eval_grad_f(Index n, const Number* x, bool, Number* g) override {
    for (Index e = 0; e < n; ++e) g[e] = p_.weight[e] > 0.0 ? p_.weight[e] * (x[e] - p_.target[e] / scale_) : 0.0;
    return true;
  }
  bool eval_g(Index, const Number* x, bool, Index m, Number* g) override {
    std::fill(g, g + m, 0.0);
    for (std::size_t k = 0; k < jac_val_.size(); ++k) g[jac_row_[k]] += jac_val_[k] * x[jac_col_[k]];
    return true;
  }
  bool eval_jac_g(Index, const Number*, bool, Index, Index, Index* iRow, Index* jCol, Number* values) override {
    if (!values) {
      for (std::size_t k = 0; k < jac_val_.size(); ++k) {
        iRow[k] = jac_row_[k];
        jCol[k] = jac_col_[k];
      }
    } else {
      std::copy(jac_val_.begin(), jac_val_.end(), values);
    }
    return true;
  }
  bool eval_h(Index, const Number*, bool, Number obj_factor, Index, const Number*, bool, Index, Index* iRow,
              Index* jCol, Number* values) override {
    if (!values) {
      for (std::size_t k = 0; k < hess_.size(); ++k) iRow[k] = jCol[k] = hess_[k];
    } else {
      for (std::size_t k = 0; k < hess_.size(); ++k) values[k] = obj_factor * p_.weight[hess_[k]];
    }
    return true;
  }
  void finalize_solution(Ipopt::SolverReturn status, Index n, const Number* x, const Number* z_L, const Number* z_U,
                         Index m, const Number*, const Number* lambda, Number, const Ipopt::IpoptData*,
                         Ipopt::IpoptCalculatedQuantities*) override {
    status_ = status;
    y = Eigen::Map<const Eigen::VectorXd>(x, n);
    zl = Eigen::Map<const Eigen::VectorXd>(z_L, n);
    zu = Eigen::Map<const Eigen::VectorXd>(z_U, n);
    lambda_rows = Eigen::Map<const Eigen::VectorXd>(lambda, m);
  }

  const std::vector<int>& rows() const { return rows_; }
  Ipopt::SolverReturn status() const { return status_; }
  Eigen::VectorXd y, zl, zu, lambda_rows;

 private:
  const StiffnessProblem& p_;
  double scale_;
  Eigen::VectorXd y0_;
  int m_ = 0;
  std::vector<int> rows_;
  std::vector<Index> jac_row_, jac_col_;
  std::vector<double> jac_val_;
  std::vector<int> hess_;
  std::vector<double> rhs_;
  Ipopt::SolverReturn status_ = Ipopt::INTERNAL_ERROR;
};

double bound_violation(const StiffnessProblem& p, const Eigen::VectorXd& sigma) {
  double v = 0.0;
  for (Eigen::Index e = 0; e < sigma.size(); ++e) v = std::max({v, p.lower[e] - sigma[e], sigma[e] - p.upper[e]});
  return v;
}

}  // namespace

StiffnessResult solve_stiffness_qp(const Structure& s, const Eigen::Matrix3Xd& positions,
                                   const StiffnessProblem& problem, const StiffnessOptions& options,
                                   const Eigen::VectorXd* start) {
  const auto t0 = std::chrono::steady_clock::now();
  StiffnessResult r;
  const int m = s.num_elements();
  Equilibrium eq(s);
  eq.set_positions(positions);

  // Force scale S: targets and weights are O(1) in y = sigma / S.
  double scale = 0.0;
  for (int e = 0; e < m; ++e) {
    if (problem.weight[e] > 0.0) scale = std::max(scale, std::abs(problem.target[e]));
    for (double b : {problem.lower[e], problem.upper[e]})
      if (std::isfinite(b)) scale = std::max(scale, std::abs(b));
  }
  if (eq.has_gravity()) scale = std::max(scale, eq.gravity_load().cwiseAbs().maxCoeff());
  if (!(scale > 0.0) || !std::isfinite(scale)) scale = 1.0;

  Eigen::VectorXd y0(m);
  for (int e = 0; e < m; ++e) {
    const double guess = start && start->size() == m ? (*start)[e] : problem.target[e];
    y0[e] = std::clamp(guess, problem.lower[e], problem.upper[e]) / scale;
    if (!std::isfinite(y0[e])) y0[e] = 0.0;
  }

  // Rows of A that are combinations of others (rigid-body modes without fixed
  // nodes, rows of isolated nodes) are implied when the load is consistent
  // with them, and prove infeasibility when it is not.
  std::vector<int> rows;
  {
    const Eigen::MatrixXd Ad = Eigen::MatrixXd(eq.A());
    Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(Ad.cols(), Ad.rows());
    qr.setThreshold(1e-10);
    if (Ad.size() > 0) qr.compute(Ad.transpose());
    const int rank = Ad.size() > 0 ? static_cast<int>(qr.rank()) : 0;
    for (int i = 0; i < rank; ++i) rows.push_back(qr.colsPermutation().indices()[i]);
    std::sort(rows.begin(), rows.end());
    if (eq.has_gravity()) {
      const Eigen::VectorXd fg = eq.gravity_load();
      const Eigen::VectorXd x = Ad.completeOrthogonalDecomposition().solve(Eigen::VectorXd(-fg));
      const double gap = (Ad * x + fg).norm();
      if (!(gap <= 1e-9 * fg.norm())) {
        r.status = Status::Infeasible;
        r.message = "the loads are not in the range of A(x): no forces balance them at this geometry "
                    "(least-squares gap " + std::to_string(gap) + " N)";
        r.sigma = y0 * scale;
        return r;
      }
    }
  }
  Ipopt::SmartPtr<StiffnessTnlp> nlp = new StiffnessTnlp(eq, problem, scale, y0, rows);

  const IpoptRun run = run_ipopt(GetRawPtr(nlp), [&](Ipopt::OptionsList& o) {
    o.SetIntegerValue("print_level", options.verbose ? 5 : 0);
    o.SetNumericValue("tol", 1e-12);
    o.SetNumericValue("constr_viol_tol", 1e-12);
    o.SetIntegerValue("max_iter", options.max_iterations);
    // Degenerate problems (many ties at a bound) may end "acceptable": keep
    // that level strict on equilibrium.
    o.SetNumericValue("acceptable_tol", 1e-9);
    // Relaxed bounds would be projected back at the end, breaking equilibrium.
    o.SetNumericValue("bound_relax_factor", 0.0);
    o.SetNumericValue("acceptable_constr_viol_tol", 1e-11);
    o.SetStringValue("hessian_constant", "yes");
    o.SetStringValue("jac_c_constant", "yes");
    o.SetStringValue("jac_d_constant", "yes");
    o.SetStringValue("mu_strategy", "adaptive");
    o.SetStringValue("nlp_scaling_method", "none");
  });
  r.iterations = run.iterations;
  if (!run.error.empty()) {
    r.message = run.error;
    return r;
  }
  const Ipopt::ApplicationReturnStatus status = run.status;
  if (nlp->y.size() != m) {
    r.message = "Ipopt returned no point (status " + std::to_string(static_cast<int>(status)) + ")";
    r.status = status == Ipopt::Infeasible_Problem_Detected ? Status::Infeasible : Status::NumericalError;
    return r;
  }

  r.sigma = nlp->y * scale;
  r.bound_multipliers = (nlp->zl - nlp->zu) * scale;
  r.lambda = Eigen::VectorXd::Zero(eq.num_equations());
  for (std::size_t i = 0; i < nlp->rows().size(); ++i) r.lambda[nlp->rows()[i]] = nlp->lambda_rows[i] * scale;
  const bool ipopt_ok = status == Ipopt::Solve_Succeeded || status == Ipopt::Solved_To_Acceptable_Level;

  if (ipopt_ok && options.polish) {
    // Active set from Ipopt's complementarity: a bound is active when its
    // multiplier outweighs its slack. Then a few primal-dual corrections
    // (free a bound with a wrong-signed multiplier, fix a violated one).
    ActiveSet active(m, 0);
    for (int e = 0; e < m; ++e) {
      if (std::isfinite(problem.lower[e]) && nlp->zl[e] > nlp->y[e] - problem.lower[e] / scale) active[e] = -1;
      if (std::isfinite(problem.upper[e]) && nlp->zu[e] > problem.upper[e] / scale - nlp->y[e]) active[e] = 1;
    }
    const double objective_ipopt = stiffness_objective(problem, r.sigma);
    const double sign_tolerance = 1e-9 * scale;
    const double load_norm = eq.has_gravity() ? eq.gravity_load().norm() : 0.0;
    for (int round = 0; round < 50; ++round) {
      const ActiveSetSolution a = solve_on_active_set(eq, problem, active);
      if (!a.ok) break;
      bool changed = false;
      if (a.equilibrium_norm > 1e-11 * (scale + load_norm)) {
        // Too many bounds held fixed for equilibrium: release the one Ipopt
        // was least sure about (smallest multiplier).
        int weakest = -1;
        for (int e = 0; e < m; ++e)
          if (active[e] != 0 && (weakest < 0 || nlp->zl[e] + nlp->zu[e] < nlp->zl[weakest] + nlp->zu[weakest]))
            weakest = e;
        if (weakest < 0) break;
        active[weakest] = 0;
        continue;
      }
      for (int e = 0; e < m; ++e) {
        if (active[e] < 0 && a.z[e] < -sign_tolerance) active[e] = 0, changed = true;
        else if (active[e] > 0 && a.z[e] > sign_tolerance) active[e] = 0, changed = true;
        else if (active[e] == 0 && a.sigma[e] < problem.lower[e] - sign_tolerance) active[e] = -1, changed = true;
        else if (active[e] == 0 && a.sigma[e] > problem.upper[e] + sign_tolerance) active[e] = 1, changed = true;
      }
      if (changed) continue;
      const double objective = stiffness_objective(problem, a.sigma);
      // Ipopt's point is only feasible to its tolerance, so it may sit a hair
      // below the true optimum; the polished one is exact.
      if (objective <= objective_ipopt * (1.0 + 1e-6) + 1e-10 * scale * scale) {
        r.sigma = a.sigma.cwiseMax(problem.lower).cwiseMin(problem.upper);
        r.lambda = a.lambda;
        r.bound_multipliers = a.z;
        r.polished = true;
      }
      break;
    }
  }

  r.objective = stiffness_objective(problem, r.sigma);
  for (int e = 0; e < m; ++e) {
    if (problem.weight[e] > 0.0)
      r.max_target_deviation = std::max(r.max_target_deviation, std::abs(r.sigma[e] - problem.target[e]));
    if (r.sigma[e] - problem.lower[e] <= 1e-12 * scale || problem.upper[e] - r.sigma[e] <= 1e-12 * scale)
      ++r.active_bounds;
  }
  Structure at_geometry = s;
  at_geometry.positions = positions;
  const Verification v = verify(at_geometry, positions, r.sigma, options.tolerance);
  r.residual = v.residual;
  r.relative_residual = v.relative_residual;
  const double violation = bound_violation(problem, r.sigma);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (status == Ipopt::Infeasible_Problem_Detected) {
    r.status = Status::Infeasible;
    r.message = "no forces satisfy equilibrium within the bounds at this geometry";
  } else if (status == Ipopt::Maximum_Iterations_Exceeded) {
    r.status = Status::MaxIterations;
    r.message = "Ipopt iteration budget ran out";
  } else if (!ipopt_ok) {
    r.status = Status::NumericalError;
    r.message = "Ipopt returned status " + std::to_string(static_cast<int>(status));
  } else if (!v.ok || violation > 1e-9 * scale) {
    r.status = Status::NumericalError;
    r.message = "the QP solution does not verify (relative residual " + std::to_string(v.relative_residual) +
                (v.problems.empty() ? std::string() : ", " + v.problems.front()) + ")";
  } else {
    r.status = Status::Converged;
    r.message = r.polished ? "optimal (Ipopt, polished on its active set)" : "optimal (Ipopt)";
  }
  return r;
}

}  // namespace tensegrity
