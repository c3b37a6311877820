#pragma once
// Named scenes with known answers for the cross-backend suites and the
// benchmarks: the analytic prisms and octahedron, twisted, perturbed or loaded.
#include <Eigen/Core>
#include <vector>

#include "model/structure.hpp"

namespace tensegrity::scenes {

// The regular prism of model/reference_scenes.hpp twisted by `twist_deg` off
// its equilibrium twist; with gravity: strut mass 0.05 kg, cable mass 0.005 kg,
// bottom ring fixed. Named "prism-N[-twistT][-gravity]".
Structure prism(int n, double twist_deg = 0.0, bool gravity = false);

// The expandable octahedron (half-length 1 m); with gravity as above, its two
// lowest nodes fixed. Named "octahedron[-gravity]".
Structure octahedron(bool gravity = false);

// `s` with every node (fixed ones too) moved by up to `fraction` of its longest
// strut (clipped cube, scenes/perturb.hpp), named "-noiseP-sSEED".
Structure perturbed(Structure s, double fraction, unsigned seed);

// Two copies of `s`, the second shifted by `offset` (m): two independent parts.
Structure two_copies(const Structure& s, const Eigen::Vector3d& offset);

// The scenes every backend must form-find (perturbed, so they need it).
std::vector<Structure> backend_suite_scenes();

}  // namespace tensegrity::scenes
