#pragma once
// Stiffness of the relative rotation of two blocks joined by a link (paper,
// section 4: the face link resists deformation about equally in every
// direction, the edge link less about one axis, like a hinge).
//
// At an equilibrium x with element forces sigma (N, tension > 0), the tangent
// stiffness of the prestressed network is
//   K = sum_e  k_e u_e u_e^T + (sigma_e / l_e)(I - u_e u_e^T)     (N/m, per
// element block on its end nodes), with the axial stiffness k_e = EA_e / l_e:
// one EA for the cables (a linear cord) and, as in the elastic model,
// EA = max|sigma| / strut_strain for the struts (effectively rigid).
// Block A is clamped and block B moves rigidly (three translations t, three
// rotations theta about B's centroid); every other node (the link's own) is
// condensed out, K_ll relaxed for each rigid motion of B:
//   S = D^T (K_bb - K_bl K_ll^-1 K_lb) D      (6 x 6, D = rigid motions of B),
// and B's translations are condensed too (B finds its best position for a
// given rotation): the rotational stiffness (N m / rad)
//   S_rot = S_rr - S_rt S_tt^-1 S_tr,
// which does not depend on the point rotations are taken about. Its
// eigenvalues are the principal rotational stiffnesses; max / min is the
// link's anisotropy (1 for a perfect spherical joint, large for a hinge).
#include <Eigen/Core>
#include <vector>

#include "model/structure.hpp"

namespace tensegrity {

struct LinkStiffnessOptions {
  double cable_ea = 20.0;       // N: axial stiffness of a cable is cable_ea / l
  double strut_strain = 1e-6;   // struts: EA = max |sigma| / strut_strain
};

struct LinkStiffness {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Zero();  // S_rot in world axes (N m / rad)
  Eigen::Vector3d principal = Eigen::Vector3d::Zero();   // eigenvalues of S_rot, ascending
  Eigen::Matrix3d principal_axes = Eigen::Matrix3d::Identity();  // unit eigenvectors (columns)
  double anisotropy = 0.0;       // principal max / min (infinite when min <= 0)
  bool positive_definite = false;
  // Rotational stiffness about a unit axis w (N m / rad): w^T S_rot w.
  double about(const Eigen::Vector3d& axis) const;
};

// The tangent stiffness K (3n x 3n, dense, N/m) of the prestressed network.
Eigen::MatrixXd tangent_stiffness(const Structure& s, const Eigen::Matrix3Xd& x, const Eigen::VectorXd& forces,
                                  const LinkStiffnessOptions& options = {});

// Relative rotation stiffness of block B against block A (node index lists,
// disjoint). Nodes in neither list are condensed out. Throws
// std::invalid_argument for empty or overlapping lists.
LinkStiffness relative_rotation_stiffness(const Structure& s, const Eigen::Matrix3Xd& x,
                                          const Eigen::VectorXd& forces, const std::vector<int>& block_a,
                                          const std::vector<int>& block_b,
                                          const LinkStiffnessOptions& options = {});

}  // namespace tensegrity
