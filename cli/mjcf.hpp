#pragma once
// MuJoCo MJCF of a design: a free body per strut (a capsule with the
// strut's mass, point masses at its ends for the rest of each end node's lumped
// mass), a site per node, a
// spatial tendon per cable with the designed rest length as spring length,
// and ground contact at the fixed nodes (a sphere on the strut end, a plane
// under the lowest one). Fixed nodes are also pinned to the world (`connect`
// equality constraints): the design's supports are bilateral, as in the
// paper, and its feet may need horizontal reactions that friction on a
// lightly loaded contact cannot give. Nodes shared by several struts are
// joined by `connect` constraints; nodes of no strut become small free bodies.
//
// Tendon stiffness is the cord's secant stiffness k = F / (l - L) at the
// design (F the designed force, l the designed length, L the rest length), so
// the tendon pulls with exactly the designed force at the designed shape; the
// cord's tangent stiffness F'(eps) / L is noted beside it. Each tendon gets
// damping `damping_ratio` * 2 sqrt(k m) with m the mean body mass.
#include <string>

#include "model/design.hpp"

namespace tensegrity::cli {

struct MjcfOptions {
  double timestep = 1e-4;        // s; the stiff constraints below need about 10 steps per time constant
  double constraint_time_constant = 1e-3;  // s, MuJoCo solref of the connect constraints
  bool pin_fixed_nodes = true;   // bilateral supports; false: ground contact only
  double damping_ratio = 0.5;    // of the tendons' critical damping, dimensionless
  double strut_radius = 0.003;   // m, capsules (visual; struts do not collide)
  double foot_radius = 0.004;    // m, contact spheres at fixed nodes
  double friction = 1.0;         // sliding friction at the feet
};

// Throws InputError when a cable is at or below its rest length without a
// material slope to take the stiffness from.
std::string write_mjcf(const Design& design, const MjcfOptions& options = {});

}  // namespace tensegrity::cli
