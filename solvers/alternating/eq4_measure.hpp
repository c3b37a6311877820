#pragma once
// The measures the alternating backends share on one part: Eq. 4's
// objective |f|^2 + w^2 (c^T sigma - t)^2 (N^2, w the stress QP's
// normalisation weight), the largest free-node residual (N) and the relative
// residual (over the largest free-node weight, else over max |sigma|, as
// model/verify does).
#include <Eigen/Core>

#include "formulations/equilibrium.hpp"
#include "formulations/force_scale.hpp"

namespace tensegrity {

class Eq4Measure {
 public:
  Eq4Measure(const Equilibrium& eq, const ForceScale& scale, double normalisation_weight);

  // At the equilibrium's current geometry; writes f = A sigma + f_g.
  double objective(const Eigen::VectorXd& sigma, Eigen::VectorXd& f) const;
  // The same from f = A sigma + f_g already evaluated.
  double objective_of(const Eigen::VectorXd& sigma, const Eigen::VectorXd& f) const;
  double max_node_residual(const Eigen::VectorXd& f) const;
  double relative_residual(double residual, const Eigen::VectorXd& sigma) const;
  double normalisation_weight() const { return w_; }

 private:
  const Equilibrium& eq_;
  const ForceScale& scale_;
  double w_;
  double gravity_scale_ = 0.0;  // largest free-node weight (N)
};

}  // namespace tensegrity
