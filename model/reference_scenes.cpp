#include "model/reference_scenes.hpp"

#include <cmath>
#include <string>

namespace tensegrity {

double prism_equilibrium_twist(int n) { return M_PI / 2.0 - M_PI / n; }

Structure make_regular_prism(const PrismParameters& p) {
  Structure s;
  const int n = p.n;
  s.name = "prism-" + std::to_string(n);
  const double alpha = prism_equilibrium_twist(n) + p.twist_offset;
  for (int k = 0; k < n; ++k) {
    const double t = 2.0 * M_PI * k / n;
    s.add_node({p.radius * std::cos(t), p.radius * std::sin(t), 0.0}, p.fix_bottom);
  }
  for (int k = 0; k < n; ++k) {
    const double t = alpha + 2.0 * M_PI * k / n;
    s.add_node({p.radius * std::cos(t), p.radius * std::sin(t), p.height});
  }
  for (int k = 0; k < n; ++k) s.add_element(k, n + (k + 1) % n, ElementKind::Strut, p.strut_mass);
  for (int k = 0; k < n; ++k) s.add_element(k, n + k, ElementKind::Cable, p.cable_mass);
  for (int k = 0; k < n; ++k) s.add_element(k, (k + 1) % n, ElementKind::Cable, p.cable_mass);
  for (int k = 0; k < n; ++k) s.add_element(n + k, n + (k + 1) % n, ElementKind::Cable, p.cable_mass);
  if (p.gravity) s.gravity = Eigen::Vector3d(0.0, 0.0, -9.81);
  return s;
}

Structure make_expandable_octahedron(const OctahedronParameters& p) {
  Structure s;
  s.name = "octahedron";
  const double a = p.half_length;
  // Pair along axis `ax`, offset along axis `off`: struts at off = +-a/2.
  const int axes[3][2] = {{0, 1}, {1, 2}, {2, 0}};
  for (const auto& pair : axes) {
    for (int side = 0; side < 2; ++side) {
      for (int end = 0; end < 2; ++end) {
        Eigen::Vector3d x = Eigen::Vector3d::Zero();
        x[pair[0]] = end == 0 ? -a : a;
        x[pair[1]] = side == 0 ? -a / 2.0 : a / 2.0;
        s.add_node(x, p.fix_bottom && x.z() < -0.75 * a);
      }
    }
  }
  for (int k = 0; k < 6; ++k) s.add_element(2 * k, 2 * k + 1, ElementKind::Strut, p.strut_mass);
  // Nearest ends of different pairs are at distance a sqrt(3/2).
  const double cable = a * std::sqrt(1.5);
  for (int i = 0; i < 12; ++i) {
    for (int j = i + 1; j < 12; ++j) {
      if (i / 4 == j / 4) continue;
      if (std::abs((s.positions.col(i) - s.positions.col(j)).norm() - cable) < 1e-9 * a)
        s.add_element(i, j, ElementKind::Cable, p.cable_mass);
    }
  }
  if (p.gravity) s.gravity = Eigen::Vector3d(0.0, 0.0, -9.81);
  return s;
}

}  // namespace tensegrity
