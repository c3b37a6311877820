#include "simulation/link_stiffness.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <limits>
#include <stdexcept>

namespace tensegrity {

double LinkStiffness::about(const Eigen::Vector3d& axis) const {
  const Eigen::Vector3d w = axis.normalized();
  return w.dot(rotation * w);
}

Eigen::MatrixXd tangent_stiffness(const Structure& s, const Eigen::Matrix3Xd& x, const Eigen::VectorXd& forces,
                                  const LinkStiffnessOptions& options) {
  const int n = s.num_nodes();
  double max_strut_force = 0.0;
  for (int e = 0; e < s.num_elements(); ++e)
    if (s.elements[e].kind == ElementKind::Strut) max_strut_force = std::max(max_strut_force, std::abs(forces[e]));
  const double strut_ea = max_strut_force / options.strut_strain;
  Eigen::MatrixXd K = Eigen::MatrixXd::Zero(3 * n, 3 * n);
  for (int e = 0; e < s.num_elements(); ++e) {
    const auto& el = s.elements[e];
    const Eigen::Vector3d d = x.col(el.b) - x.col(el.a);
    const double l = d.norm();
    const Eigen::Vector3d u = d / l;
    const double ea = el.kind == ElementKind::Strut ? strut_ea : options.cable_ea;
    const Eigen::Matrix3d uu = u * u.transpose();
    const Eigen::Matrix3d Ke = (ea / l) * uu + (forces[e] / l) * (Eigen::Matrix3d::Identity() - uu);
    K.block<3, 3>(3 * el.a, 3 * el.a) += Ke;
    K.block<3, 3>(3 * el.b, 3 * el.b) += Ke;
    K.block<3, 3>(3 * el.a, 3 * el.b) -= Ke;
    K.block<3, 3>(3 * el.b, 3 * el.a) -= Ke;
  }
  return K;
}

LinkStiffness relative_rotation_stiffness(const Structure& s, const Eigen::Matrix3Xd& x,
                                          const Eigen::VectorXd& forces, const std::vector<int>& block_a,
                                          const std::vector<int>& block_b, const LinkStiffnessOptions& options) {
  const int n = s.num_nodes();
  if (block_a.empty() || block_b.empty()) throw std::invalid_argument("link stiffness: a block has no nodes");
  std::vector<int> role(n, 0);  // 0 link (condensed), 1 block A (clamped), 2 block B (rigid)
  for (int i : block_a) role.at(i) = 1;
  for (int i : block_b) {
    if (role.at(i) != 0) throw std::invalid_argument("link stiffness: the blocks share a node");
    role[i] = 2;
  }
  std::vector<int> link;
  for (int i = 0; i < n; ++i)
    if (role[i] == 0) link.push_back(i);
  const Eigen::MatrixXd K = tangent_stiffness(s, x, forces, options);

  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (int i : block_b) c += x.col(i);
  c /= static_cast<double>(block_b.size());
  // Rigid motions of B spread over all coordinates: columns 0-2 translations,
  // 3-5 rotations about c.
  Eigen::MatrixXd D = Eigen::MatrixXd::Zero(3 * n, 6);
  for (int i : block_b)
    for (int a = 0; a < 3; ++a) {
      D(3 * i + a, a) = 1.0;
      D.block<3, 1>(3 * i, 3 + a) = Eigen::Vector3d::Unit(a).cross(x.col(i) - c);
    }
  // Link coordinates relax: condensed stiffness D^T (K - K_:l K_ll^-1 K_l:) D.
  const int nl = static_cast<int>(link.size());
  Eigen::MatrixXd KD = K * D;  // 3n x 6
  Eigen::MatrixXd S = D.transpose() * KD;
  if (nl > 0) {
    Eigen::MatrixXd Kll(3 * nl, 3 * nl), KlD(3 * nl, 6);
    for (int p = 0; p < nl; ++p) {
      for (int q = 0; q < nl; ++q) Kll.block<3, 3>(3 * p, 3 * q) = K.block<3, 3>(3 * link[p], 3 * link[q]);
      KlD.middleRows<3>(3 * p) = KD.middleRows<3>(3 * link[p]);
    }
    S -= KlD.transpose() * Kll.ldlt().solve(KlD);
  }
  S = 0.5 * (S + S.transpose());
  LinkStiffness out;
  const Eigen::Matrix3d Stt = S.topLeftCorner<3, 3>(), Str = S.topRightCorner<3, 3>();
  out.rotation = S.bottomRightCorner<3, 3>() - Str.transpose() * Stt.ldlt().solve(Str);
  out.rotation = 0.5 * (out.rotation + out.rotation.transpose());
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(out.rotation);
  out.principal = eig.eigenvalues();
  out.principal_axes = eig.eigenvectors();
  out.positive_definite = out.principal[0] > 0.0;
  out.anisotropy = out.positive_definite ? out.principal[2] / out.principal[0]
                                         : std::numeric_limits<double>::infinity();
  return out;
}

}  // namespace tensegrity
