#include "design/stiffness_solver.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <vector>

#include "formulations/equilibrium.hpp"
#include "kernels/ipopt_solve.hpp"
#include "kernels/sparse_nlp.hpp"
#include "model/json_text.hpp"
#include "model/verify.hpp"

namespace tensegrity {
namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

// The QP in forces scaled by S: y = sigma / S, objective / S^2. Convex.
class StiffnessQpNlp final : public SparseNlp {
 public:
  // `rows`: a maximal independent set of equilibrium rows (Ipopt needs a
  // full-rank constraint Jacobian and no more equalities than unknowns).
  StiffnessQpNlp(const Equilibrium& eq, const StiffnessProblem& p, double scale, const Eigen::VectorXd& y0,
                 std::vector<int> rows)
      : p_(p), scale_(scale), y0_(y0), rows_(std::move(rows)) {
    const Eigen::SparseMatrix<double>& A = eq.A();
    m_ = static_cast<int>(A.cols());
    std::vector<int> kept(A.rows(), -1);
    for (std::size_t i = 0; i < rows_.size(); ++i) kept[rows_[i]] = static_cast<int>(i);
    for (int c = 0; c < A.outerSize(); ++c)
      for (Eigen::SparseMatrix<double>::InnerIterator it(A, c); it; ++it)
        if (it.value() != 0.0 && kept[it.row()] >= 0) {
          jacobian_.add(kept[it.row()], c);
          jac_val_.push_back(it.value());
        }
    rhs_.resize(rows_.size());
    for (std::size_t i = 0; i < rows_.size(); ++i)
      rhs_[i] = eq.has_gravity() ? -eq.gravity_load()[rows_[i]] / scale_ : 0.0;
    for (int e = 0; e < m_; ++e)
      if (p_.weight[e] > 0.0) hessian_.add(e, e);
  }

  int num_variables() const override { return m_; }
  int num_constraints() const override { return static_cast<int>(rows_.size()); }
  void variable_bounds(Vector xl, Vector xu) const override {
    for (int e = 0; e < m_; ++e) {
      xl[e] = std::isfinite(p_.lower[e]) ? p_.lower[e] / scale_ : -kInfinity;
      xu[e] = std::isfinite(p_.upper[e]) ? p_.upper[e] / scale_ : kInfinity;
    }
  }
  void constraint_bounds(Vector gl, Vector gu) const override {
    for (std::size_t i = 0; i < rhs_.size(); ++i) gl[i] = gu[i] = rhs_[i];
  }
  void starting_point(Vector x) const override { x = y0_; }
  bool objective(const ConstVector& x, double& f) override {
    f = 0.0;
    for (int e = 0; e < m_; ++e) {
      const double d = x[e] - p_.target[e] / scale_;
      if (p_.weight[e] > 0.0) f += 0.5 * p_.weight[e] * d * d;
    }
    return true;
  }
  bool gradient(const ConstVector& x, Vector g) override {
    for (int e = 0; e < m_; ++e) g[e] = p_.weight[e] > 0.0 ? p_.weight[e] * (x[e] - p_.target[e] / scale_) : 0.0;
    return true;
  }
  bool constraints(const ConstVector& x, Vector g) override {
    g.setZero();
    for (std::size_t k = 0; k < jac_val_.size(); ++k) g[jacobian_.rows[k]] += jac_val_[k] * x[jacobian_.cols[k]];
    return true;
  }
  bool jacobian_values(const ConstVector&, Vector values) override {
    std::copy(jac_val_.begin(), jac_val_.end(), values.data());
    return true;
  }
  bool hessian_values(const ConstVector&, double obj_factor, const ConstVector&, Vector values) override {
    for (int k = 0; k < hessian_.size(); ++k) values[k] = obj_factor * p_.weight[hessian_.rows[k]];
    return true;
  }
  SparsityPattern jacobian_structure() const override { return jacobian_; }
  SparsityPattern hessian_structure() const override { return hessian_; }
  bool is_convex() const override { return true; }
  void finalize(const NlpSolution& solution) override {
    y = solution.x;
    zl = solution.lower_bound_multipliers;
    zu = solution.upper_bound_multipliers;
    lambda_rows = solution.constraint_multipliers;
  }

  const std::vector<int>& rows() const { return rows_; }
  Eigen::VectorXd y, zl, zu, lambda_rows;

 private:
  const StiffnessProblem& p_;
  double scale_;
  Eigen::VectorXd y0_;
  int m_ = 0;
  std::vector<int> rows_;
  SparsityPattern jacobian_, hessian_;
  std::vector<double> jac_val_;
  std::vector<double> rhs_;
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
  StiffnessQpNlp qp(eq, problem, scale, y0, rows);

  IpoptSettings settings;
  settings.verbose = options.verbose;
  settings.set("tol", 1e-12);
  settings.set("constr_viol_tol", 1e-12);
  settings.set("max_iter", options.max_iterations);
  // Degenerate problems (many ties at a bound) may end "acceptable": keep
  // that level strict on equilibrium.
  settings.set("acceptable_tol", 1e-9);
  // Relaxed bounds would be projected back at the end, breaking equilibrium.
  settings.set("bound_relax_factor", 0.0);
  settings.set("acceptable_constr_viol_tol", 1e-11);
  settings.set("hessian_constant", "yes");
  settings.set("jac_c_constant", "yes");
  settings.set("jac_d_constant", "yes");
  settings.set("mu_strategy", "adaptive");
  settings.set("nlp_scaling_method", "none");
  const IpoptSolveResult run = solve_with_ipopt(qp, settings);
  r.iterations = run.iterations;
  if (!run.has_solution) {
    r.status = run.status;
    r.message = "Ipopt returned no point (" + run.message + ")";
    return r;
  }

  r.sigma = qp.y * scale;
  r.bound_multipliers = (qp.zl - qp.zu) * scale;
  r.lambda = Eigen::VectorXd::Zero(eq.num_equations());
  for (std::size_t i = 0; i < qp.rows().size(); ++i) r.lambda[qp.rows()[i]] = qp.lambda_rows[i] * scale;
  const bool ipopt_ok = run.status == Status::Converged;

  if (ipopt_ok && options.polish) {
    // Active set from Ipopt's complementarity: a bound is active when its
    // multiplier outweighs its slack. Then a few primal-dual corrections
    // (free a bound with a wrong-signed multiplier, fix a violated one).
    ActiveSet active(m, 0);
    for (int e = 0; e < m; ++e) {
      if (std::isfinite(problem.lower[e]) && qp.zl[e] > qp.y[e] - problem.lower[e] / scale) active[e] = -1;
      if (std::isfinite(problem.upper[e]) && qp.zu[e] > problem.upper[e] / scale - qp.y[e]) active[e] = 1;
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
          if (active[e] != 0 && (weakest < 0 || qp.zl[e] + qp.zu[e] < qp.zl[weakest] + qp.zu[weakest]))
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
  if (!ipopt_ok) {
    r.status = run.status;
    r.message = r.status == Status::Infeasible ? "no forces satisfy equilibrium within the bounds at this geometry"
                                               : run.message;
  } else if (!v.ok || violation > 1e-9 * scale) {
    r.status = Status::NumericalError;
    r.message = "the QP solution does not verify (relative residual " + message_number(v.relative_residual) +
                (v.problems.empty() ? std::string() : ", " + v.problems.front()) + ")";
  } else {
    r.status = Status::Converged;
    r.message = r.polished ? "optimal (Ipopt, polished on its active set)" : "optimal (Ipopt)";
  }
  return r;
}

}  // namespace tensegrity
