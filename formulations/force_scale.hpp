#pragma once
// The one force-scale convention shared by every backend (docs/THEORY-force-scale.md).
//
// Per connected part of a scene, with W the total gravity load on the part's
// free nodes (N):
//
//   W = 0 (no gravity, or no weight on free nodes): forces are defined only up
//     to a factor (a self-stress), so the scale is fixed by a normalisation,
//     the equality  mean cable force = F0 = 1 N  (c^T sigma = n_c F0).
//   W > 0: the load sets the scale. There is no equality on the force level:
//     Eq. 4 at fixed geometry is the physical problem, and any sign-correct
//     equilibrium is a tensegrity whatever its force level. Eq. 5 alone needs a
//     bound, since a geometry change can shrink by raising the prestress: the
//     mean cable force is at most kappa W (c^T sigma <= n_c kappa W). Every
//     backend applies it; where the cap binds, the row is held as an equality
//     at the cap (held_at_prestress_cap, docs/THEORY-force-scale.md).
//
//   reference force  F0 = W when W > 0, otherwise 1 N (the unit of forces);
//   sign margins     cable sigma >= margin, strut sigma <= -margin,
//                    margin = margin_fraction * F0.
//
// The forces are dimensionless in the geometry, so scaling a scene's lengths
// scales the solution's positions and leaves its forces unchanged.
#include <Eigen/Core>
#include <limits>

#include "model/structure.hpp"

namespace tensegrity {

// kappa: the default bound on the mean cable force under gravity, in units of
// the part's weight (docs/THEORY-force-scale.md says how it was chosen).
inline constexpr double kDefaultPrestressFactor = 2.0;

struct ForceScale {
  double reference_force = 1.0;  // F0 (N)
  double margin = 1e-3;          // N
  int num_cables = 0;            // the cable-sum row sums these
  bool load_sets_scale = false;  // W > 0: no normalisation, a prestress cap instead
  double prestress_factor = kDefaultPrestressFactor;  // kappa
  // Bounds per element: cables [margin, +inf), struts (-inf, -margin].
  Eigen::VectorXd lower, upper;
  // Cable-sum row c: 1 on cables, 0 on struts.
  Eigen::VectorXd normalisation_row;
  // Without gravity: c^T sigma = normalisation_target = n_c F0.
  double normalisation_target = 0.0;
  // Under gravity: c^T sigma <= prestress_cap = kappa n_c W (Eq. 5 only).
  double prestress_cap = std::numeric_limits<double>::infinity();

  // The equality c^T sigma = t applies (no load, and cables to normalise).
  bool has_normalisation() const { return num_cables > 0 && !load_sets_scale; }
  // The bound c^T sigma <= prestress_cap applies (Eq. 5 under gravity).
  bool has_prestress_cap() const { return num_cables > 0 && load_sets_scale; }
  // Either of the two: Eq. 5 has a cable-sum row.
  bool has_cable_sum_row() const { return num_cables > 0; }
};

// The convention applied to one connected part (or a whole scene).
ForceScale make_force_scale(const Structure& s, double margin_fraction = 1e-3,
                            double prestress_factor = kDefaultPrestressFactor);

// The same scale with the prestress cap held as the normalisation
// (c^T sigma = prestress_cap, has_normalisation() true): the problem on the
// cap, for when the cap binds. Returns the scale unchanged without a cap.
ForceScale held_at_prestress_cap(const ForceScale& scale);

// The cable sum c^T sigma exceeds the prestress cap by more than rounding.
bool exceeds_prestress_cap(const ForceScale& scale, const Eigen::VectorXd& sigma);

// A starting point within the bounds (and on the normalisation when there is
// one): +F0 on cables, -F0 on struts.
Eigen::VectorXd reference_forces(const Structure& s, const ForceScale& scale);

}  // namespace tensegrity
