#pragma once
// Shared scene fixtures for the cross-backend suites: perturbed reference
// structures with known answers (the analytic prisms and octahedron).
#include <random>
#include <string>
#include <vector>

#include "model/reference_scenes.hpp"
#include "model/structure.hpp"

namespace tensegrity::testing {

// Moves every node by a seeded random vector of length up to `fraction` of the
// longest strut.
inline Structure perturbed(Structure s, double fraction, unsigned seed) {
  double strut = 0.0;
  for (const auto& e : s.elements)
    if (e.kind == ElementKind::Strut)
      strut = std::max(strut, (s.positions.col(e.b) - s.positions.col(e.a)).norm());
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int i = 0; i < s.num_nodes(); ++i) {
    Eigen::Vector3d d(u(rng), u(rng), u(rng));
    if (d.norm() > 1.0) d.normalize();
    s.positions.col(i) += fraction * strut * d;
  }
  s.name += "-noise" + std::to_string(static_cast<int>(fraction * 100 + 0.5)) + "-s" + std::to_string(seed);
  return s;
}

inline Structure prism(int n, double twist_deg = 0.0, bool gravity = false) {
  PrismParameters p;
  p.n = n;
  p.twist_offset = twist_deg * M_PI / 180.0;
  if (gravity) {
    p.gravity = p.fix_bottom = true;
    p.strut_mass = 0.05;
    p.cable_mass = 0.005;
  }
  Structure s = make_regular_prism(p);
  s.name += (twist_deg != 0.0 ? "-twist" + std::to_string(static_cast<int>(twist_deg)) : std::string()) +
            (gravity ? "-gravity" : "");
  return s;
}

inline Structure octahedron(bool gravity = false) {
  OctahedronParameters p;
  if (gravity) {
    p.gravity = p.fix_bottom = true;
    p.strut_mass = 0.05;
    p.cable_mass = 0.005;
  }
  Structure s = make_expandable_octahedron(p);
  if (gravity) s.name += "-gravity";
  return s;
}

// Two copies of `s`, the second shifted by `offset`: two independent parts.
inline Structure two_copies(const Structure& s, const Eigen::Vector3d& offset) {
  Structure t = s;
  const int n = s.num_nodes();
  for (int i = 0; i < n; ++i) t.add_node(s.positions.col(i) + offset, s.fixed[i], s.node_mass[i]);
  for (const auto& e : s.elements) t.add_element(e.a + n, e.b + n, e.kind, e.mass);
  t.name = s.name + "-twice";
  return t;
}

// The scenes every backend must form-find (perturbed, so they need it).
inline std::vector<Structure> backend_suite_scenes() {
  std::vector<Structure> v;
  for (int n : {3, 4, 5, 6, 8, 10, 12}) v.push_back(prism(n, 10.0));
  for (int n : {3, 6, 12}) v.push_back(perturbed(prism(n), 0.05, 11u + n));
  v.push_back(perturbed(prism(4), 0.15, 7u));
  v.push_back(prism(5, 20.0));
  v.push_back(perturbed(octahedron(), 0.05, 3u));
  v.push_back(perturbed(octahedron(), 0.01, 4u));
  v.push_back(perturbed(prism(3, 0.0, true), 0.01, 5u));
  v.push_back(perturbed(prism(6, 0.0, true), 0.05, 6u));
  v.push_back(prism(4, 10.0, true));
  v.push_back(perturbed(octahedron(true), 0.05, 8u));
  v.push_back(two_copies(prism(3, 15.0), Eigen::Vector3d(5.0, 0.0, 0.0)));
  return v;
}

}  // namespace tensegrity::testing
