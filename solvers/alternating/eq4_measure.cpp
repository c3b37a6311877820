#include "solvers/alternating/eq4_measure.hpp"

#include <algorithm>

namespace tensegrity {

Eq4Measure::Eq4Measure(const Equilibrium& eq, const ForceScale& scale, double normalisation_weight)
    : eq_(eq), scale_(scale), w_(normalisation_weight) {
  const Eigen::VectorXd& fg = eq.gravity_load();
  for (int k = 0; k < eq.free_nodes().num_free(); ++k)
    gravity_scale_ = std::max(gravity_scale_, fg.segment<3>(3 * k).norm());
}

double Eq4Measure::objective(const Eigen::VectorXd& sigma, Eigen::VectorXd& f) const {
  eq_.residual(sigma, f);
  return objective_of(sigma, f);
}

double Eq4Measure::objective_of(const Eigen::VectorXd& sigma, const Eigen::VectorXd& f) const {
  double phi = f.squaredNorm();
  if (scale_.has_normalisation()) {
    const double r = scale_.normalisation_row.dot(sigma) - scale_.normalisation_target;
    phi += w_ * w_ * r * r;
  }
  return phi;
}

double Eq4Measure::max_node_residual(const Eigen::VectorXd& f) const {
  double worst = 0.0;
  for (int k = 0; k < eq_.free_nodes().num_free(); ++k) worst = std::max(worst, f.segment<3>(3 * k).norm());
  return worst;
}

double Eq4Measure::relative_residual(double residual, const Eigen::VectorXd& sigma) const {
  const double load = gravity_scale_ > 0.0 ? gravity_scale_ : sigma.cwiseAbs().maxCoeff();
  return load > 0.0 ? residual / load : residual;
}

}  // namespace tensegrity
