#include "formulations/force_scale.hpp"

#include <limits>

namespace tensegrity {

ForceScale make_force_scale(const Structure& s, double margin_fraction, double prestress_factor) {
  ForceScale scale;
  const int m = s.num_elements();

  // Total weight of the free nodes; the supports carry the rest.
  double weight = 0.0;
  if (s.has_gravity()) {
    const Eigen::VectorXd mass = s.lumped_mass();
    double free_mass = 0.0;
    for (int i = 0; i < s.num_nodes(); ++i) {
      const bool is_fixed = i < static_cast<int>(s.fixed.size()) && s.fixed[i];
      if (!is_fixed) free_mass += mass[i];
    }
    weight = free_mass * s.gravity.norm();
  }
  scale.load_sets_scale = weight > 0.0;
  scale.reference_force = scale.load_sets_scale ? weight : 1.0;
  scale.prestress_factor = prestress_factor;
  scale.margin = margin_fraction * scale.reference_force;

  const double inf = std::numeric_limits<double>::infinity();
  scale.lower.resize(m);
  scale.upper.resize(m);
  scale.normalisation_row = Eigen::VectorXd::Zero(m);
  for (int e = 0; e < m; ++e) {
    if (s.elements[e].kind == ElementKind::Cable) {
      scale.lower[e] = scale.margin;
      scale.upper[e] = inf;
      scale.normalisation_row[e] = 1.0;
      ++scale.num_cables;
    } else {
      scale.lower[e] = -inf;
      scale.upper[e] = -scale.margin;
    }
  }
  if (scale.load_sets_scale) scale.prestress_cap = prestress_factor * scale.num_cables * weight;
  else scale.normalisation_target = scale.num_cables * scale.reference_force;
  return scale;
}

ForceScale held_at_prestress_cap(const ForceScale& scale) {
  ForceScale held = scale;
  if (scale.has_prestress_cap()) {
    held.load_sets_scale = false;
    held.normalisation_target = scale.prestress_cap;
  }
  return held;
}

bool exceeds_prestress_cap(const ForceScale& scale, const Eigen::VectorXd& sigma) {
  // Relative slack of a cable sum that has rounded above an exactly held cap.
  constexpr double kCapRoundingSlack = 1e-9;
  if (!scale.has_prestress_cap() || sigma.size() != scale.normalisation_row.size()) return false;
  return scale.normalisation_row.dot(sigma) > scale.prestress_cap * (1.0 + kCapRoundingSlack);
}

Eigen::VectorXd reference_forces(const Structure& s, const ForceScale& scale) {
  Eigen::VectorXd sigma(s.num_elements());
  for (int e = 0; e < s.num_elements(); ++e)
    sigma[e] = s.elements[e].kind == ElementKind::Cable ? scale.reference_force : -scale.reference_force;
  return sigma;
}

}  // namespace tensegrity
