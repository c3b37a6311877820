#pragma once
// Eq. 5 reduced to the positions by variable projection (Golub and Pereyra):
// the forces enter the equilibrium linearly, so at free coordinates q the
// stress QP (Eq. 4, kernels/stress_qp.hpp) gives the best sign-correct forces
// sigma*(q), and Eq. 5 becomes a problem in q alone,
//
//   min_q |q - q0|^2 / L^2   s.t.   R(q) = 0,
//   R(q) = ( |A(q) sigma* + f_g|^2 + w^2 (c^T sigma* - t)^2 ) / F0^2,
//
// R being the QP's optimal objective made dimensionless. The cable-sum row is
// Eq. 5's force-scale equality (formulations/force_scale.hpp): t = n_c F0
// without gravity and the prestress cap kappa n_c W under gravity, so that the
// reduced problem has the optimum of the full one.
//
// Gradient by the envelope theorem: sigma* minimises the QP over a box that
// does not depend on q, so dR/dq = 2 J^T f / F0^2 with f = A sigma* + f_g and
// J = df/dq at fixed forces (formulations/equilibrium.hpp). It is exact where
// the QP's active set does not change with q and up to the QP's optimality
// tolerance; tests/nlopt_reduced_residual_test.cpp checks it by differences.
//
// Variables are y = (q - q0) / L (dimensionless), L the scene's mean element
// length, so that y = 0 is the scene's geometry bit for bit.
#include <Eigen/Core>

#include "formulations/equilibrium.hpp"
#include "formulations/force_scale.hpp"
#include "kernels/stress_qp.hpp"
#include "model/structure.hpp"
#include "solvers/solver.hpp"

namespace tensegrity {

class ReducedResidual {
 public:
  // `scale` is the part's force scale for Eq. 5; the first QP solve starts
  // from the reference forces. With `proximal_forces` the QP picks, among
  // equally good forces, those closest to the previous evaluation's
  // (StressQpOptions::proximal): on parts whose equilibrium matrix has a null
  // space, R is then not differentiable in the strict sense (its gradient
  // depends on which optimal forces the QP returns), and forces that follow
  // the path keep that gradient consistent from one evaluation to the next,
  // which L-BFGS's line search needs.
  ReducedResidual(const Structure& part, const ForceScale& scale, bool proximal_forces = false);

  int num_variables() const { return static_cast<int>(y0_.size()); }
  // y = 0: the scene's geometry.
  const Eigen::VectorXd& start() const { return y0_; }
  double length() const { return length_; }  // L (m)

  // R(y); with grad non-null also dR/dy. Each call solves the stress QP at y,
  // warm-started from the forces of the previous call.
  double evaluate(const double* y, double* grad);

  // The residual vector r = (f / F0, w (c^T sigma - t) / F0) has
  // num_residuals() entries. With multipliers lambda and penalty rho, the
  // following evaluations return R and dR/dy of the shifted residual
  // r + lambda / rho instead: the QP's data shifted (StressQp::set_shift) so
  // that the forces minimise |r + lambda / rho|^2, which is an augmented
  // Lagrangian's inner problem in the forces. An empty lambda: no shift.
  int num_residuals() const { return num_variables() + 1; }
  void set_multipliers(const Eigen::VectorXd& lambda, double rho);
  // r of the last evaluation, unshifted.
  void residual_vector(Eigen::VectorXd& r) const;

  // Of the last evaluation: the forces sigma* (N), f = A sigma* + f_g (N), the
  // residual of docs/FORMATS.md (largest free-node |f_i|, N) and the QP's status.
  const Eigen::VectorXd& forces() const { return sigma_; }
  const Eigen::VectorXd& net_forces() const { return f_; }
  double max_node_residual() const;
  StressQpStatus qp_status() const { return qp_status_; }
  long qp_solves() const { return qp_solves_; }

  // The load scale (docs/FORMATS.md) as far as it is known before the forces: the
  // largest free-node weight under gravity, else F0 (N), which the largest
  // |sigma| is at least close to (the mean cable force is F0).
  double load_scale() const { return load_scale_; }
  double reference_force() const { return reference_force_; }  // F0 (N)
  // The relative residual (docs/FORMATS.md) of the last evaluation: the residual over
  // the largest free-node weight under gravity, else over max |sigma*|.
  double relative_residual() const;

  // The trace record of the last evaluation, made at y and counted as the
  // `evaluations`-th (the first, at the start, is iteration 0): geometry
  // change L |y - start| (m), objective |y - start|^2. `seconds` is the recorder's.
  TracePoint trace_point(const double* y, long evaluations) const;

  // All node positions (3 x n, m) at y; fixed nodes copied from the scene.
  Eigen::Matrix3Xd positions(const double* y) const;

 private:

  Structure part_;
  Equilibrium eq_;
  ForceScale scale_;
  StressQp qp_;
  double length_ = 1.0;
  double reference_force_ = 1.0;
  double load_scale_ = 1.0;
  double max_free_weight_ = 0.0;  // N; 0 without gravity
  double normalisation_weight_ = 0.0;  // w; 0 without cables
  Eigen::VectorXd q0_, y0_, q_, sigma_, f_, jf_;
  Eigen::VectorXd load_shift_, shifted_f_;  // F0 lambda_f / rho (N); f + it
  double target_shift_ = 0.0;               // N
  StressQpStatus qp_status_ = StressQpStatus::NumericalFailure;
  long qp_solves_ = 0;
};

}  // namespace tensegrity
