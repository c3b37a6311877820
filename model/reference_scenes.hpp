#pragma once
// Analytic reference structures: the block library builds its prisms and
// octahedra from them; scenes/ generates the test, benchmark and stress-test
// scenes from them; data/reference/ holds them as files.
//
// Regular n-strut prism: bottom node k at angle 2 pi k / n and height 0, top node
// k at alpha + 2 pi k / n and height h, all on radius r. Struts join bottom k to
// top k+1, vertical cables bottom k to top k, ring cables join neighbours on each
// ring. In equilibrium at alpha = pi/2 - pi/n, with force densities (force /
// length) struts -1, verticals 1, rings 1 / (2 sin(pi/n)) (up to one factor).
//
// Expandable octahedron: six struts of half-length a in three mutually orthogonal
// parallel pairs, each strut at distance a/2 from the centre; 24 cables join the
// nearest ends of different pairs. In equilibrium: strut length / cable length =
// sqrt(8/3) and |strut force| / cable force = sqrt(6).
#include "model/structure.hpp"

namespace tensegrity {

struct PrismParameters {
  int n = 3;
  double radius = 1.0;                 // m
  double height = 1.0;                 // m
  double twist_offset = 0.0;           // rad, added to the equilibrium twist
  double strut_mass = 0.0;             // kg per strut
  double cable_mass = 0.0;             // kg per cable
  bool gravity = false;                // -9.81 m/s^2 along z
  bool fix_bottom = false;             // bottom nodes are contact nodes
};

// Node order: bottom 0..n-1, top n..2n-1. Element order: struts, verticals,
// bottom ring, top ring.
Structure make_regular_prism(const PrismParameters& p);
double prism_equilibrium_twist(int n);   // pi/2 - pi/n

struct OctahedronParameters {
  double half_length = 1.0;            // a (m)
  double strut_mass = 0.0;
  double cable_mass = 0.0;
  bool gravity = false;
  bool fix_bottom = false;             // the two lowest nodes (z = -a) are fixed
};

// Node order: pairs along x, y, z; element order: 6 struts then 24 cables.
Structure make_expandable_octahedron(const OctahedronParameters& p);

}  // namespace tensegrity
