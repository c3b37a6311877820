#include "formulations/stiffness_qp.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>

namespace tensegrity {

StiffnessProblem make_stiffness_problem(const Structure& s, const Eigen::VectorXd& cable_targets, double margin,
                                        double strut_weight) {
  const int m = s.num_elements();
  const double inf = std::numeric_limits<double>::infinity();
  StiffnessProblem p;
  p.target = Eigen::VectorXd::Zero(m);
  p.weight = Eigen::VectorXd::Zero(m);
  p.lower = Eigen::VectorXd::Constant(m, -inf);
  p.upper = Eigen::VectorXd::Constant(m, inf);
  for (int e = 0; e < m; ++e) {
    if (s.elements[e].kind == ElementKind::Cable) {
      p.target[e] = cable_targets[e];
      p.weight[e] = 1.0;
      p.lower[e] = margin;
    } else {
      p.weight[e] = strut_weight;
      p.upper[e] = -margin;
    }
  }
  return p;
}

double stiffness_objective(const StiffnessProblem& p, const Eigen::VectorXd& sigma) {
  return 0.5 * (p.weight.array() * (sigma - p.target).array().square()).sum();
}

namespace {

// A has unit columns: a relative pivot threshold well above round-off and
// well below any genuine geometric coupling.
constexpr double kRelativePivotThreshold = 1e-10;

// Rank-revealing QR of A_F^T (free columns of A, transposed). Pivoting makes
// the null space and the particular solution exact even when rows of A are
// dependent (rigid-body modes, isolated rows).
struct FreeColumnsQr {
  std::vector<int> free;
  Eigen::MatrixXd At;  // k x R
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr;
  int rank = 0;

  FreeColumnsQr(const Equilibrium& eq, const std::vector<int>& free_elements) : free(free_elements) {
    const Eigen::MatrixXd A = Eigen::MatrixXd(eq.A());
    At.resize(static_cast<Eigen::Index>(free.size()), A.rows());
    for (std::size_t i = 0; i < free.size(); ++i) At.row(static_cast<Eigen::Index>(i)) = A.col(free[i]).transpose();
    qr = Eigen::ColPivHouseholderQR<Eigen::MatrixXd>(At.rows(), At.cols());
    qr.setThreshold(kRelativePivotThreshold);
    if (At.size() > 0) {
      qr.compute(At);
      rank = static_cast<int>(qr.rank());
    }
  }
};

}  // namespace

ActiveSetSolution solve_on_active_set(const Equilibrium& eq, const StiffnessProblem& p, const ActiveSet& active) {
  const int m = eq.num_elements();
  const Eigen::SparseMatrix<double>& A = eq.A();
  ActiveSetSolution out;
  out.sigma = Eigen::VectorXd::Zero(m);
  std::vector<int> free;
  for (int e = 0; e < m; ++e) {
    if (active[e] < 0) out.sigma[e] = p.lower[e];
    else if (active[e] > 0) out.sigma[e] = p.upper[e];
    else free.push_back(e);
  }
  if (!out.sigma.allFinite()) return out;  // an infinite bound cannot be active
  Eigen::VectorXd rhs = -A * out.sigma;
  if (eq.has_gravity()) rhs -= eq.gravity_load();

  const int k = static_cast<int>(free.size());
  FreeColumnsQr f(eq, free);
  Eigen::VectorXd wF(k), tF(k);
  for (int i = 0; i < k; ++i) {
    wF[i] = p.weight[free[i]];
    tF[i] = p.target[free[i]];
  }
  Eigen::VectorXd sF = Eigen::VectorXd::Zero(k);
  if (k > 0) {
    const int r = f.rank;
    const Eigen::MatrixXd Q = f.qr.householderQ() * Eigen::MatrixXd::Identity(k, k);
    // A_F = P R^T Q^T, so A_F (Q_1 w) = rhs reads R_11^T w = (P^T rhs)_{1..r}.
    const Eigen::VectorXd b = f.qr.colsPermutation().transpose() * rhs;
    Eigen::VectorXd w = Eigen::VectorXd::Zero(r);
    if (r > 0)
      w = f.qr.matrixR().topLeftCorner(r, r).triangularView<Eigen::Upper>().transpose().solve(b.head(r));
    const Eigen::VectorXd s_particular = Q.leftCols(r) * w;
    sF = s_particular;
    if (k > r) {
      const Eigen::MatrixXd Z = Q.rightCols(k - r);
      const Eigen::MatrixXd H = Z.transpose() * wF.asDiagonal() * Z;
      const Eigen::VectorXd g = Z.transpose() * (wF.asDiagonal() * (tF - s_particular));
      // Semi-definite when some null direction carries no weight (struts with
      // weight 0): the complete orthogonal decomposition gives the
      // minimum-norm step among the optimal ones.
      const Eigen::VectorXd y = H.completeOrthogonalDecomposition().solve(g);
      sF += Z * y;
    }
    for (int i = 0; i < k; ++i) out.sigma[free[i]] = sF[i];
  }

  const Eigen::VectorXd grad = p.weight.cwiseProduct(out.sigma - p.target);
  if (k > 0 && A.rows() > 0) {
    Eigen::VectorXd gF(k);
    for (int i = 0; i < k; ++i) gF[i] = grad[free[i]];
    out.lambda = f.qr.solve(Eigen::VectorXd(-gF));
  } else {
    out.lambda = Eigen::VectorXd::Zero(A.rows());
  }
  out.z = grad + A.transpose() * out.lambda;
  for (int e : free) out.z[e] = 0.0;
  Eigen::VectorXd residual = A * out.sigma;
  if (eq.has_gravity()) residual += eq.gravity_load();
  out.equilibrium_norm = residual.norm();
  out.ok = out.sigma.allFinite() && out.lambda.allFinite() && out.z.allFinite();
  return out;
}

StiffnessKkt stiffness_kkt(const Equilibrium& eq, const StiffnessProblem& p, const Eigen::VectorXd& sigma,
                           double active_tolerance) {
  const int m = eq.num_elements();
  const Eigen::SparseMatrix<double>& A = eq.A();
  StiffnessKkt kkt;
  std::vector<int> free;
  ActiveSet side(m, 0);
  for (int e = 0; e < m; ++e) {
    kkt.bound_violation = std::max({kkt.bound_violation, p.lower[e] - sigma[e], sigma[e] - p.upper[e]});
    if (sigma[e] - p.lower[e] <= active_tolerance) side[e] = -1;
    else if (p.upper[e] - sigma[e] <= active_tolerance) side[e] = 1;
    else free.push_back(e);
  }
  kkt.active = m - static_cast<int>(free.size());
  const Eigen::VectorXd grad = p.weight.cwiseProduct(sigma - p.target);
  FreeColumnsQr f(eq, free);
  const int k = static_cast<int>(free.size());
  Eigen::VectorXd gF(k);
  for (int i = 0; i < k; ++i) gF[i] = grad[free[i]];
  kkt.lambda = (k > 0 && A.rows() > 0) ? Eigen::VectorXd(f.qr.solve(Eigen::VectorXd(-gF)))
                                       : Eigen::VectorXd(Eigen::VectorXd::Zero(A.rows()));
  kkt.z = grad + A.transpose() * kkt.lambda;
  for (int e = 0; e < m; ++e) {
    if (side[e] == 0) {
      kkt.stationarity = std::max(kkt.stationarity, std::abs(kkt.z[e]));
      kkt.z[e] = 0.0;
    } else if (side[e] < 0) {
      kkt.wrong_sign = std::max(kkt.wrong_sign, -kkt.z[e]);
    } else {
      kkt.wrong_sign = std::max(kkt.wrong_sign, kkt.z[e]);
    }
  }
  Eigen::VectorXd residual = A * sigma;
  if (eq.has_gravity()) residual += eq.gravity_load();
  kkt.equilibrium_norm = residual.norm();
  return kkt;
}

}  // namespace tensegrity
