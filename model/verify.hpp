#pragma once
// Independent re-verification of a solution against its scene, by the plain
// formulas of docs/FORMATS.md (no solver code involved). Used by `tensegrity check`
// and by every backend before it calls a result converged.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "model/structure.hpp"

namespace tensegrity {

struct Verification {
  double residual = 0.0;           // max over free nodes of |net force| (N)
  double relative_residual = 0.0;  // residual / load_scale
  double load_scale = 0.0;         // largest free-node weight, else max |sigma|
  double geometry_change = 0.0;    // |x - x_scene| (m)
  int wrong_signs = 0;             // cables with sigma <= 0, struts with sigma >= 0
  int moved_fixed_nodes = 0;       // fixed nodes not copied bit for bit
  bool all_finite = true;
  bool equilibrium_ok = false;     // relative_residual <= tolerance
  bool ok = false;                 // everything above holds
  std::vector<std::string> problems;  // human-readable reasons when !ok
};

Verification verify(const Structure& scene, const Eigen::Matrix3Xd& positions,
                    const Eigen::VectorXd& forces, double tolerance = 1e-8);

// Net force at every node (3 x n; fixed nodes get zero), the formula of docs/FORMATS.md.
Eigen::Matrix3Xd net_forces(const Structure& scene, const Eigen::Matrix3Xd& positions,
                            const Eigen::VectorXd& forces);

}  // namespace tensegrity
