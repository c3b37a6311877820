#include "scenes/suites.hpp"

#include <cmath>
#include <string>

#include "scenes/perturb.hpp"
#include "model/reference_scenes.hpp"

namespace tensegrity::scenes {
namespace {

constexpr double kStrutMass = 0.05;   // kg
constexpr double kCableMass = 0.005;  // kg

}  // namespace

Structure perturbed(Structure s, double fraction, unsigned seed) {
  NodeNoise noise;
  noise.fraction = fraction;
  noise.length = LengthMeasure::LongestStrut;
  noise.shape = NoiseShape::CubeClippedToBall;
  noise.move_fixed_nodes = true;
  s = with_node_noise(std::move(s), noise, seed);
  s.name += "-noise" + std::to_string(static_cast<int>(fraction * 100 + 0.5)) + "-s" + std::to_string(seed);
  return s;
}

Structure prism(int n, double twist_deg, bool gravity) {
  PrismParameters p;
  p.n = n;
  p.twist_offset = twist_deg * M_PI / 180.0;
  if (gravity) {
    p.gravity = p.fix_bottom = true;
    p.strut_mass = kStrutMass;
    p.cable_mass = kCableMass;
  }
  Structure s = make_regular_prism(p);
  s.name += (twist_deg != 0.0 ? "-twist" + std::to_string(static_cast<int>(twist_deg)) : std::string()) +
            (gravity ? "-gravity" : "");
  return s;
}

Structure octahedron(bool gravity) {
  OctahedronParameters p;
  if (gravity) {
    p.gravity = p.fix_bottom = true;
    p.strut_mass = kStrutMass;
    p.cable_mass = kCableMass;
  }
  Structure s = make_expandable_octahedron(p);
  if (gravity) s.name += "-gravity";
  return s;
}

Structure two_copies(const Structure& s, const Eigen::Vector3d& offset) {
  Structure t = s;
  const int n = s.num_nodes();
  for (int i = 0; i < n; ++i) t.add_node(s.positions.col(i) + offset, s.fixed[i], s.node_mass[i]);
  for (const auto& e : s.elements) t.add_element(e.a + n, e.b + n, e.kind, e.mass);
  t.name = s.name + "-twice";
  return t;
}

std::vector<Structure> backend_suite_scenes() {
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

}  // namespace tensegrity::scenes
