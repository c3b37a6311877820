#pragma once
// Large generated scenes for benchmarks, tests and `tensegrity generate`.
//
// Prism tower: `layers` twisted n-strut prisms (each in its own equilibrium),
// consecutive layers overlapping and joined by extra cables from every top node
// of a layer to the nearest bottom nodes of the next, until the cable count is
// reached; then node noise. The defaults give the 80-strut / 500-cable tower
// (10 layers of 8-strut prisms). Not in equilibrium as built: its joining
// cables carry no force; data/bench/tower-80s-500c[-gravity].scene.json hold
// equilibria of it, which tower_equilibrium reads.
//
// Octahedron chain: k expandable octahedra along the (1,1,1) diagonal,
// neighbours joined by a face link between the (+,+,+) face of one and the
// (-,-,-) face of the next (15 blocks: 104 struts and 528 cables). Not in
// equilibrium as built.
//
// Octahedron grid: rows x cols expandable octahedra (half-length 1 m) on a
// square grid in the x-y plane, centres kGridSpacing apart, each pair of grid
// neighbours joined by the `cables_per_join` shortest cables between their
// nodes. The default 2 x 7 grid with 8 cables per join has 84 struts and 572
// elements. Far from equilibrium as built: the joining cables carry no force.
#include <string>

#include "model/structure.hpp"

namespace tensegrity::scenes {

struct TowerParameters {
  int layers = 10;
  int struts_per_layer = 8;
  int cables = 500;            // total, prism cables included
  double layer_height = 1.0;   // m, prism height
  double overlap = 0.3;        // fraction of a layer's height shared with the next
  double noise = 0.02;         // node noise as a fraction of the first element's length
  unsigned seed = 1;
  bool gravity = false;        // masses on struts and cables, bottom ring fixed
};

Structure make_prism_tower(const TowerParameters& p);

// `s` with the towers' node noise: free nodes, up to `fraction` of the first
// element's length (clipped cube, scenes/perturb.hpp), from std::mt19937(seed).
Structure with_tower_noise(Structure s, double fraction, unsigned seed);

// The stored equilibrium of the 80/500 tower under data_dir/bench/.
Structure tower_equilibrium(const std::string& data_dir, bool gravity);

// That equilibrium with node noise (fraction of the first element's length,
// clipped cube, free nodes only).
Structure perturbed_tower(const std::string& data_dir, bool gravity, double noise = 0.02, unsigned seed = 1);

Structure octahedron_chain(int blocks);

struct OctahedronGridParameters {
  int rows = 2;
  int cols = 7;
  int cables_per_join = 8;
};
Structure octahedron_grid(const OctahedronGridParameters& p);

}  // namespace tensegrity::scenes
