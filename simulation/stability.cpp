#include "simulation/stability.hpp"

#include <Eigen/Dense>
#include <Eigen/SparseCholesky>
#include <algorithm>
#include <cmath>
#include <sstream>

namespace tensegrity {

const char* to_string(Stability s) {
  switch (s) {
    case Stability::Stable: return "stable";
    case Stability::Marginal: return "marginal";
    case Stability::Unstable: return "unstable";
  }
  return "unstable";
}

namespace {

// Orthonormal basis (columns) of the rigid-body motions of the given nodes
// over their 3 n coordinates: three translations, three rotations about the
// centroid. Fewer than six when the nodes are collinear.
Eigen::MatrixXd rigid_motion_basis(const Eigen::Matrix3Xd& x, const std::vector<int>& nodes) {
  const int n = static_cast<int>(nodes.size());
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (int i : nodes) c += x.col(i);
  if (n > 0) c /= n;
  Eigen::MatrixXd R = Eigen::MatrixXd::Zero(3 * n, 6);
  for (int k = 0; k < n; ++k) {
    const Eigen::Vector3d p = x.col(nodes[k]) - c;
    for (int a = 0; a < 3; ++a) {
      R(3 * k + a, a) = 1.0;
      const Eigen::Vector3d w = Eigen::Vector3d::Unit(a).cross(p);
      R.block<3, 1>(3 * k, 3 + a) = w;
    }
  }
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(R);
  qr.setThreshold(1e-10);
  const int rank = static_cast<int>(qr.rank());
  Eigen::MatrixXd Q = qr.householderQ();
  return Q.leftCols(rank);
}

// Block Lanczos on (K - s I)^{-1} restricted to the complement of `deflate`
// (orthonormal columns): an orthonormal basis V of the block Krylov space,
// fully re-orthogonalised column by column (a block of width `block` finds
// eigenvalues of that multiplicity, which symmetric structures have), then
// Rayleigh-Ritz on V^T (K - s I)^{-1} V. Returns the Ritz values mapped back to
// eigenvalues of K, ascending.
std::vector<double> shift_invert_lanczos(const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>>& ldlt, double shift,
                                         const Eigen::MatrixXd& deflate, int dofs, int max_vectors, int block) {
  Eigen::MatrixXd V(dofs, max_vectors), W(dofs, max_vectors);
  int count = 0;
  // Appends w (orthogonalised) to V when it brings a new direction.
  auto append = [&](Eigen::VectorXd w) {
    const double original = w.norm();
    for (int pass = 0; pass < 2; ++pass) {
      if (deflate.cols() > 0) w -= deflate * (deflate.transpose() * w);
      if (count > 0) w -= V.leftCols(count) * (V.leftCols(count).transpose() * w);
    }
    const double norm = w.norm();
    if (!(norm > 1e-10 * original) || count >= max_vectors) return false;
    V.col(count++) = w / norm;
    return true;
  };
  for (int j = 0; j < block; ++j) {
    Eigen::VectorXd v(dofs);
    for (int k = 0; k < dofs; ++k) v[k] = std::sin(12.9898 * (k + 1) + 78.233 * (j + 1)) * 43758.5453;
    for (int k = 0; k < dofs; ++k) v[k] -= std::floor(v[k]) + 0.5;  // deterministic, generic
    append(v);
  }
  int applied = 0;
  while (applied < count) {
    const int begin = applied, end = count;
    for (int c = begin; c < end; ++c) W.col(c) = ldlt.solve(V.col(c));
    applied = end;
    for (int c = begin; c < end && count < max_vectors; ++c) append(W.col(c));
    if (count == end) break;  // an invariant subspace: nothing new
  }
  // The last columns may not have been applied yet.
  for (int c = applied; c < count; ++c) W.col(c) = ldlt.solve(V.col(c));
  const Eigen::MatrixXd T = V.leftCols(count).transpose() * W.leftCols(count);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(0.5 * (T + T.transpose()), Eigen::EigenvaluesOnly);
  std::vector<double> lambda;
  for (int k = 0; k < count; ++k) {
    const double theta = eig.eigenvalues()[k];
    if (theta > 0.0) lambda.push_back(shift + 1.0 / theta);
  }
  std::sort(lambda.begin(), lambda.end());
  return lambda;
}

int negative_pivots(const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>>& ldlt) {
  return static_cast<int>((ldlt.vectorD().array() < 0.0).count());
}

}  // namespace

StabilityReport analyze_stability(const ElasticEnergy& energy, const Eigen::Matrix3Xd& x,
                                  const StabilityOptions& options) {
  StabilityReport r;
  const ElasticModel& model = energy.model();
  const FreeNodeMap& map = energy.free_map();
  const int dofs = energy.num_dofs();
  Eigen::VectorXd g;
  energy.energy_gradient(x, g);
  r.relative_residual = (dofs ? g.cwiseAbs().maxCoeff() : 0.0) / model.force_scale;
  r.in_equilibrium = r.relative_residual <= options.equilibrium_tolerance;
  if (dofs == 0) {
    r.verdict = Stability::Stable;
    r.message = "no free node";
    return r;
  }
  Eigen::SparseMatrix<double> K = energy.pattern();
  energy.hessian(x, HessianMode::Exact, K);
  r.scale = K.diagonal().cwiseAbs().maxCoeff();
  const double tol = options.zero_tolerance * r.scale;

  Eigen::MatrixXd rigid(dofs, 0);
  if (map.num_free() == map.num_nodes()) rigid = rigid_motion_basis(x, map.free_nodes());
  r.rigid_modes_removed = static_cast<int>(rigid.cols());
  r.dofs = dofs - r.rigid_modes_removed;
  const int k_wanted = std::min(options.num_eigenvalues, r.dofs);

  if (!options.force_lanczos && dofs <= options.dense_limit) {
    r.method = "dense";
    const Eigen::MatrixXd Kd = Eigen::MatrixXd(K);
    Eigen::MatrixXd reduced;
    if (r.rigid_modes_removed > 0) {
      Eigen::HouseholderQR<Eigen::MatrixXd> qr(rigid);
      const Eigen::MatrixXd Q = qr.householderQ();
      const Eigen::MatrixXd Z = Q.rightCols(r.dofs);
      reduced = Z.transpose() * Kd * Z;
    } else {
      reduced = Kd;
    }
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(reduced, Eigen::EigenvaluesOnly);
    const Eigen::VectorXd& ev = eig.eigenvalues();
    r.negative_modes = static_cast<int>((ev.array() < -tol).count());
    for (int k = 0; k < k_wanted; ++k) r.eigenvalues.push_back(ev[k]);
  } else {
    r.method = "lanczos";
    Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt;
    ldlt.analyzePattern(K);
    Eigen::SparseMatrix<double> shifted = K;
    double shift = -std::max(tol, 1e-300);
    auto factor_at = [&](double s) {
      shifted = K;
      for (int k = 0; k < dofs; ++k) shifted.valuePtr()[energy.diagonal_slot(k)] -= s;
      ldlt.factorize(shifted);
      return ldlt.info() == Eigen::Success;
    };
    if (!factor_at(shift)) {
      r.message = "the shifted stiffness could not be factorised";
      r.verdict = Stability::Unstable;
      return r;
    }
    r.negative_modes = negative_pivots(ldlt);
    // Move the shift below the spectrum, so the largest Ritz values are the smallest eigenvalues.
    for (int attempt = 0; attempt < 60 && negative_pivots(ldlt) > 0; ++attempt) {
      shift *= 10.0;
      if (!factor_at(shift)) break;
    }
    const int block = std::min(r.dofs, std::max(k_wanted, 4));
    const int vectors = std::min(r.dofs, std::max(12 * block, 80));
    const std::vector<double> lambda = shift_invert_lanczos(ldlt, shift, rigid, dofs, vectors, block);
    for (int k = 0; k < std::min<int>(k_wanted, static_cast<int>(lambda.size())); ++k) r.eigenvalues.push_back(lambda[k]);
  }
  for (double l : r.eigenvalues)
    if (std::abs(l) <= tol) ++r.zero_modes;
  const double lambda_min = r.eigenvalues.empty() ? INFINITY : r.eigenvalues.front();
  std::ostringstream msg;
  msg.precision(4);
  if (!r.in_equilibrium) {
    r.verdict = Stability::Unstable;
    msg << "not an equilibrium: max net force " << r.relative_residual << " x force scale";
  } else if (r.negative_modes > 0 || lambda_min < -tol) {
    r.verdict = Stability::Unstable;
    msg << std::max(r.negative_modes, 1) << " negative stiffness mode(s), smallest eigenvalue " << lambda_min << " N/m";
  } else if (lambda_min <= tol) {
    r.verdict = Stability::Marginal;
    msg << r.zero_modes << " zero-stiffness mode(s) (|lambda| <= " << tol << " N/m)";
  } else {
    r.verdict = Stability::Stable;
    msg << "smallest eigenvalue " << lambda_min << " N/m";
  }
  r.message = msg.str();
  return r;
}

PrestressReport prestress_stability(const Structure& s, const Eigen::Matrix3Xd& x, const Eigen::VectorXd& forces,
                                    double tolerance) {
  PrestressReport r;
  const int n = s.num_nodes(), m = s.num_elements();
  Eigen::MatrixXd omega = Eigen::MatrixXd::Zero(n, n);
  Eigen::MatrixXd conic(m, 6), rigidity = Eigen::MatrixXd::Zero(m, 3 * n);
  for (int e = 0; e < m; ++e) {
    const Element& el = s.elements[e];
    const Eigen::Vector3d d = x.col(el.b) - x.col(el.a);
    const double l = d.norm();
    const Eigen::Vector3d u = d / l;
    const double w = forces[e] / l;
    omega(el.a, el.a) += w;
    omega(el.b, el.b) += w;
    omega(el.a, el.b) -= w;
    omega(el.b, el.a) -= w;
    conic.row(e) << u.x() * u.x(), u.y() * u.y(), u.z() * u.z(), 2 * u.x() * u.y(), 2 * u.x() * u.z(),
        2 * u.y() * u.z();
    rigidity.block<1, 3>(e, 3 * el.a) = -u.transpose();
    rigidity.block<1, 3>(e, 3 * el.b) = u.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(omega, Eigen::EigenvaluesOnly);
  const Eigen::VectorXd& ev = eig.eigenvalues();
  const double scale = std::max(ev.cwiseAbs().maxCoeff(), 1e-300);
  const double tol = tolerance * scale;
  r.omega_psd = (ev.array() >= -tol).all();
  r.omega_nullity = static_cast<int>((ev.array().abs() <= tol).count());
  r.omega_smallest_nonzero = INFINITY;
  for (int k = 0; k < n; ++k)
    if (ev[k] > tol) r.omega_smallest_nonzero = std::min(r.omega_smallest_nonzero, ev[k]);
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> cq(conic);
  cq.setThreshold(1e-9);
  r.direction_rank = static_cast<int>(cq.rank());
  r.super_stable = r.omega_psd && r.omega_nullity == 4 && r.direction_rank == 6;

  // Non-trivial first-order flexes: kernel of the rigidity matrix minus the rigid motions.
  std::vector<int> all(n);
  for (int i = 0; i < n; ++i) all[i] = i;
  const Eigen::MatrixXd T = rigid_motion_basis(x, all);
  Eigen::MatrixXd stacked(m + T.cols(), 3 * n);
  stacked << rigidity, T.transpose();
  Eigen::BDCSVD<Eigen::MatrixXd> svd(stacked, Eigen::ComputeFullV);
  const Eigen::VectorXd& sv = svd.singularValues();
  const double sv_tol = 1e-9 * std::max(sv.size() ? sv[0] : 0.0, 1e-300);
  int rank = 0;
  for (int k = 0; k < sv.size(); ++k)
    if (sv[k] > sv_tol) ++rank;
  r.flexes = 3 * n - rank;
  if (r.flexes == 0) {
    r.prestress_stable = true;
    r.min_flex_stiffness = INFINITY;
  } else {
    const Eigen::MatrixXd F = svd.matrixV().rightCols(r.flexes);
    Eigen::MatrixXd kg_f(3 * n, r.flexes);  // (Omega (x) I_3) F
    for (int c = 0; c < r.flexes; ++c)
      for (int a = 0; a < 3; ++a) {
        Eigen::VectorXd comp(n);
        for (int i = 0; i < n; ++i) comp[i] = F(3 * i + a, c);
        const Eigen::VectorXd oc = omega * comp;
        for (int i = 0; i < n; ++i) kg_f(3 * i + a, c) = oc[i];
      }
    const Eigen::MatrixXd S = F.transpose() * kg_f;
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> se(S, Eigen::EigenvaluesOnly);
    r.min_flex_stiffness = se.eigenvalues()[0];
    r.prestress_stable = r.min_flex_stiffness > tol;
  }
  std::ostringstream msg;
  msg << "Omega " << (r.omega_psd ? "PSD" : "indefinite") << ", nullity " << r.omega_nullity
      << " (super stability needs 4), member directions rank " << r.direction_rank << "/6, " << r.flexes
      << " non-trivial flex(es)" << (r.flexes ? ", min stress stiffness on them " + std::to_string(r.min_flex_stiffness) : "");
  r.message = msg.str();
  return r;
}

}  // namespace tensegrity
