#pragma once
// The one force-scale convention shared by every backend (README, "Force scale").
//
// Without gravity forces are defined only up to a factor; with gravity an
// unbounded prestress would let the geometry change of Eq. 5 shrink towards
// zero. Every backend therefore fixes, per connected part of the scene:
//
//   reference force  F0 = total gravity load on the part's free nodes (N) when
//                         positive, otherwise 1 N;
//   normalisation    mean cable force of the part = F0 (one linear equality);
//   sign margins     cable sigma >= margin, strut sigma <= -margin,
//                    margin = margin_fraction * F0.
//
// The forces are then dimensionless in the geometry, so scaling a scene's
// lengths scales the solution's positions and leaves its forces unchanged.
#include <Eigen/Core>

#include "model/structure.hpp"

namespace tensegrity {

struct ForceScale {
  double reference_force = 1.0;  // F0 (N)
  double margin = 1e-3;          // N
  int num_cables = 0;            // the normalisation row sums these
  // Bounds per element: cables [margin, +inf), struts (-inf, -margin].
  Eigen::VectorXd lower, upper;
  // Normalisation row: c^T sigma = target with c = 1 on cables, 0 on struts,
  // target = num_cables * F0. Absent (has_normalisation false) without cables.
  Eigen::VectorXd normalisation_row;
  double normalisation_target = 0.0;
  bool has_normalisation() const { return num_cables > 0; }
};

// The convention applied to one connected part (or a whole scene).
ForceScale make_force_scale(const Structure& s, double margin_fraction = 1e-3);

// A starting point that satisfies the bounds and the normalisation exactly:
// +F0 on cables, -F0 on struts.
Eigen::VectorXd reference_forces(const Structure& s, const ForceScale& scale);

}  // namespace tensegrity
