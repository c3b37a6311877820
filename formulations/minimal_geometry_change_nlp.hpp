#pragma once
// Eq. 5 as a solver-independent NLP (ifopt style):
//
//   variables    z = (q, sigma): free node coordinates q (3 n_free, m) and
//                element forces sigma (m, N)
//   objective    |q - q0|^2 / L^2   (L = mean element length of the scene, so
//                the objective is dimensionless and scale-invariant)
//   constraints  f(q, sigma) = A(q) sigma + f_g = 0   (3 n_free rows, N)
//                c^T sigma = t        without gravity  (1 row when there are cables)
//                c^T sigma  = kappa n_c W  under gravity (ForceScale: the prestress level),
//                or <= with PrestressRow::Cap
//   bounds       sigma within the ForceScale sign margins; q free.
//
// Exact sparse gradient, constraint Jacobian and Hessian of the Lagrangian.
// Structures are computed once; values are written in the same order every call
// and no evaluation allocates. Everything here is in SI units; a solver adapter
// that wants a dimensionless problem rescales (solvers/ipopt/dimensionless_eq5.hpp
// divides q - q0 by L, sigma and the constraint rows by F0).
//
// Jacobian triplet order: the 3x3 blocks of df/dq (column by column), then
// df/dsigma = A (column by column), then the cable-sum row.
// Hessian triplet order: Equilibrium's lambda^T f triplets, then the diagonal
// q entries that pattern lacks (the objective's 2/L^2 lives on the q diagonal).
#include <Eigen/Core>
#include <vector>

#include "formulations/equilibrium.hpp"
#include "formulations/force_scale.hpp"
#include "model/structure.hpp"

namespace tensegrity {

// The cable-sum row under gravity: held at kappa n_c W, or only bounded above
// by it (docs/THEORY-force-scale.md measures both).
enum class PrestressRow { Equal, Cap };

class MinimalGeometryChangeNlp {
 public:
  MinimalGeometryChangeNlp(const Structure& s, const ForceScale& scale, PrestressRow prestress = PrestressRow::Equal);

  int num_variables() const;
  int num_constraints() const;
  int num_positions() const;   // 3 n_free
  int num_forces() const;      // m

  // Variable bounds (+-infinity where unbounded) and constraint bounds (equalities,
  // except the cable-sum row under gravity with PrestressRow::Cap: (-infinity, prestress_cap]).
  void variable_bounds(Eigen::VectorXd& lower, Eigen::VectorXd& upper) const;
  void constraint_bounds(Eigen::VectorXd& lower, Eigen::VectorXd& upper) const;

  // z from scene positions and given forces; and back.
  Eigen::VectorXd initial_point(const Eigen::VectorXd& sigma0) const;
  Eigen::Matrix3Xd positions(const Eigen::VectorXd& z) const;   // 3 x n, fixed nodes copied
  Eigen::VectorXd forces(const Eigen::VectorXd& z) const;

  double objective(const Eigen::VectorXd& z) const;
  void gradient(const Eigen::VectorXd& z, Eigen::VectorXd& g) const;
  void constraints(const Eigen::VectorXd& z, Eigen::VectorXd& c);

  int jacobian_nonzeros() const;
  void jacobian_structure(std::vector<int>& rows, std::vector<int>& cols) const;
  void jacobian_values(const Eigen::VectorXd& z, double* values);

  // Hessian of obj_factor * objective + lambda^T constraints, lower triangle.
  int hessian_nonzeros() const;
  void hessian_structure(std::vector<int>& rows, std::vector<int>& cols) const;
  void hessian_values(const Eigen::VectorXd& z, double obj_factor,
                      const Eigen::VectorXd& lambda, double* values);

  double length_scale() const { return length_scale_; }
  const Equilibrium& equilibrium() const { return eq_; }
  const ForceScale& force_scale() const { return scale_; }
  const Structure& structure() const { return structure_; }
  // q0: the scene's free coordinates (3 n_free, m).
  const Eigen::VectorXd& reference_coordinates() const { return q0_; }

  // Largest free-node net force |f_i| (N) at z (the residual of docs/FORMATS.md).
  double max_node_residual(const Eigen::VectorXd& z);

 private:
  // Refreshes the equilibrium's geometry only when q differs from the last one.
  void update_geometry(const Eigen::VectorXd& z);
  void copy_forces(const Eigen::VectorXd& z);

  Structure structure_;
  ForceScale scale_;
  PrestressRow prestress_ = PrestressRow::Equal;
  Equilibrium eq_;
  Eigen::VectorXd q0_;
  double length_scale_ = 1.0;
  int nq_ = 0, m_ = 0;
  std::vector<int> jac_rows_, jac_cols_, hess_rows_, hess_cols_;
  int jac_q_nonzeros_ = 0;           // df/dq entries, first in the Jacobian
  int jac_a_nonzeros_ = 0;           // A entries, next
  std::vector<double> normalisation_values_;  // last Jacobian row's coefficients
  int eq_hess_nonzeros_ = 0;         // Equilibrium's Hessian triplets, first
  std::vector<int> q_diagonal_index_;  // Hessian triplet of (i, i) for each q_i
  // Work buffers (sized once) so that evaluations never allocate.
  Eigen::VectorXd q_current_, sigma_, lambda_f_, f_;
  bool geometry_valid_ = false;
};

}  // namespace tensegrity
