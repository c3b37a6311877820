#include "model/blocks.hpp"

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "model/blocks_internal.hpp"
#include "model/errors.hpp"
#include "model/reference_scenes.hpp"

namespace tensegrity {

namespace block_detail {

void ensure_extras(Structure& s) {
  s.node_extra.resize(s.num_nodes(), nlohmann::json::object());
  s.element_extra.resize(s.num_elements(), nlohmann::json::object());
}

void set_cable_names(Block& b, const std::vector<std::string>& names) {
  for (int e = 0; e < b.structure.num_elements(); ++e) {
    b.structure.element_extra[e] = nlohmann::json::object();
    if (!names[e].empty()) b.structure.element_extra[e]["name"] = names[e];
    if (b.structure.elements[e].kind == ElementKind::Cable && !names[e].empty()) b.cables[names[e]] = e;
  }
}

}  // namespace block_detail

using block_detail::ensure_extras;
using block_detail::set_cable_names;

namespace {

// The diamond cylinder's twist and ring densities: Gauss-Newton on the nodal
// balance, continued in the diagonal ratio from the prism's solution (0) in
// this many equal steps, each run to a step below kDiamondStepTolerance.
constexpr int kDiamondContinuationSteps = 20;
constexpr int kDiamondNewtonIterations = 30;
constexpr double kDiamondStepTolerance = 1e-15;
// Central-difference step of the 6 x 3 Jacobian (the unknowns are O(1)).
constexpr double kDiamondDifferenceStep = 1e-7;
// Template coordinates are exact multiples of 1/2: a node matches a wanted
// position within rounding.
constexpr double kSamePosition = 1e-9;

int add_named(Structure& s, std::vector<std::string>& names, int a, int b, ElementKind kind,
              const std::string& name) {
  names.push_back(name);
  return s.add_element(a, b, kind);
}

// Turns force densities q (N/m) into forces q * length, scaled so that the mean
// cable force is 1 N.
Eigen::VectorXd forces_from_densities(const Structure& s, const Eigen::VectorXd& q) {
  Eigen::VectorXd f(s.num_elements());
  double cable_sum = 0.0;
  int cables = 0;
  for (int e = 0; e < s.num_elements(); ++e) {
    const auto& el = s.elements[e];
    f[e] = q[e] * (s.positions.col(el.b) - s.positions.col(el.a)).norm();
    if (el.kind == ElementKind::Cable) {
      cable_sum += f[e];
      ++cables;
    }
  }
  return f * (cables / cable_sum);
}

}  // namespace

int Block::num_struts() const {
  int k = 0;
  for (const auto& e : structure.elements) k += e.kind == ElementKind::Strut;
  return k;
}

int Block::num_cables() const { return structure.num_elements() - num_struts(); }

const std::array<int, 3>& Block::face(const std::string& face_name, const std::string& where) const {
  auto it = faces.find(face_name);
  if (it == faces.end()) {
    std::string known;
    for (const auto& [n, f] : faces) known += (known.empty() ? "" : ", ") + n;
    throw InputError(where, "face", "block '" + name + "' has no face '" + face_name + "' (faces: " + known + ")");
  }
  return it->second;
}

int Block::cable(const std::string& cable_name, const std::string& where) const {
  auto it = cables.find(cable_name);
  if (it == cables.end())
    throw InputError(where, "cable", "block '" + name + "' has no cable named '" + cable_name + "'");
  return it->second;
}

Block make_prism_block(int n) {
  if (n < 3 || n > 12) throw std::invalid_argument("make_prism_block: n must be in 3..12");
  PrismParameters p;
  p.n = n;
  Block b;
  b.structure = make_regular_prism(p);
  b.name = "prism-" + std::to_string(n);
  b.structure.name = b.name;
  b.source = "regular " + std::to_string(n) +
             "-strut prism (Snelson's twisted prism): unit radius and height, twist pi/2 - pi/n; "
             "force densities struts -1, verticals 1, rings 1/(2 sin(pi/n)) (model/reference_scenes.hpp)";
  const int m = b.structure.num_elements();
  Eigen::VectorXd q(m);
  std::vector<std::string> names(m);
  for (int k = 0; k < n; ++k) {
    q[k] = -1.0;
    names[k] = "strut-" + std::to_string(k);
    q[n + k] = 1.0;
    names[n + k] = "vertical-" + std::to_string(k);
    q[2 * n + k] = q[3 * n + k] = 1.0 / (2.0 * std::sin(M_PI / n));
    names[2 * n + k] = "bottom-" + std::to_string(k);
    names[3 * n + k] = "top-" + std::to_string(k);
  }
  ensure_extras(b.structure);
  set_cable_names(b, names);
  b.forces = forces_from_densities(b.structure, q);
  // A face is three ring nodes spread around the ring (for n = 3 the ring itself).
  const std::array<int, 3> ring = {0, n / 3, (2 * n) / 3};
  b.faces["bottom"] = ring;
  b.faces["top"] = {n + ring[0], n + ring[1], n + ring[2]};
  return b;
}

Block make_quadruplex_block() {
  Block b = make_prism_block(4);
  b.name = "quadruplex";
  b.structure.name = b.name;
  b.source = "the quadruplex: the regular 4-strut prism (" + b.source + ")";
  return b;
}

Block make_icosahedron_block() {
  OctahedronParameters p;
  Block b;
  b.structure = make_expandable_octahedron(p);
  b.name = "icosahedron";
  b.structure.name = b.name;
  b.source =
      "expandable octahedron (Fuller's 6-strut 'tensegrity icosahedron'): struts of half-length 1 in three "
      "orthogonal parallel pairs 1 apart; strut/cable length sqrt(8/3), |strut force|/cable force sqrt(6) "
      "(model/reference_scenes.hpp)";
  const auto& s = b.structure;
  const int m = s.num_elements();
  std::vector<std::string> names(m);
  Eigen::VectorXd q(m);
  for (int e = 0; e < m; ++e) {
    const auto& el = s.elements[e];
    const double len = (s.positions.col(el.b) - s.positions.col(el.a)).norm();
    if (el.kind == ElementKind::Strut) {
      q[e] = -std::sqrt(6.0) / len;
      names[e] = "strut-" + std::to_string(e);
    } else {
      q[e] = 1.0 / len;
      names[e] = "cable-" + std::to_string(el.a) + "-" + std::to_string(el.b);
    }
  }
  ensure_extras(b.structure);
  set_cable_names(b, names);
  b.forces = forces_from_densities(b.structure, q);
  // Octant faces: from each strut pair the end on the octant's side.
  for (int sx = -1; sx <= 1; sx += 2)
    for (int sy = -1; sy <= 1; sy += 2)
      for (int sz = -1; sz <= 1; sz += 2) {
        const Eigen::Vector3d want[3] = {{sx * 1.0, sy * 0.5, 0.0}, {0.0, sy * 1.0, sz * 0.5}, {sx * 0.5, 0.0, sz * 1.0}};
        std::array<int, 3> f{};
        for (int k = 0; k < 3; ++k)
          for (int i = 0; i < s.num_nodes(); ++i)
            if ((s.positions.col(i) - want[k]).norm() < kSamePosition) f[k] = i;
        const std::string name = std::string("x") + (sx > 0 ? "+" : "-") + "y" + (sy > 0 ? "+" : "-") + "z" +
                                 (sz > 0 ? "+" : "-");
        b.faces[name] = f;
      }
  return b;
}

Block make_diamond_block(int n, double diagonal_ratio) {
  // Node b_k = (cos t_k, sin t_k, 0), T_k = (cos(t_k + alpha), sin(t_k + alpha), 1), t_k = 2 pi k / n.
  // Struts b_k - T_{k+1}; cables b_k - T_k (density 1), b_k - T_{k-1} (density
  // diagonal_ratio), rings (densities q_b, q_t). Vertical balance gives the strut
  // density -(1 + ratio); alpha, q_b, q_t solve the horizontal balance at b_0 and
  // T_0 (Gauss-Newton from the prism solution, continued in the ratio).
  const double c_final = diagonal_ratio;
  auto residual = [n](const Eigen::Vector3d& p, double c) {
    const double alpha = p[0], qb = p[1], qt = p[2], qs = -(1.0 + c);
    auto B = [&](int k) {
      const double t = 2.0 * M_PI * k / n;
      return Eigen::Vector3d(std::cos(t), std::sin(t), 0.0);
    };
    auto T = [&](int k) {
      const double t = 2.0 * M_PI * k / n + alpha;
      return Eigen::Vector3d(std::cos(t), std::sin(t), 1.0);
    };
    const Eigen::Vector3d fb = qs * (T(1) - B(0)) + (T(0) - B(0)) + c * (T(-1) - B(0)) +
                               qb * (B(1) - B(0)) + qb * (B(-1) - B(0));
    const Eigen::Vector3d ft = qs * (B(-1) - T(0)) + (B(0) - T(0)) + c * (B(1) - T(0)) +
                               qt * (T(1) - T(0)) + qt * (T(-1) - T(0));
    Eigen::Matrix<double, 6, 1> r;
    r << fb, ft;
    return r;
  };
  Eigen::Vector3d p(M_PI / 2 - M_PI / n, 1.0 / (2.0 * std::sin(M_PI / n)), 1.0 / (2.0 * std::sin(M_PI / n)));
  const int steps = kDiamondContinuationSteps;
  for (int step = 1; step <= steps; ++step) {
    const double c = c_final * step / steps;
    for (int it = 0; it < kDiamondNewtonIterations; ++it) {
      const auto r = residual(p, c);
      Eigen::Matrix<double, 6, 3> J;
      for (int j = 0; j < 3; ++j) {
        Eigen::Vector3d hi = p, lo = p;
        const double h = kDiamondDifferenceStep;
        hi[j] += h;
        lo[j] -= h;
        J.col(j) = (residual(hi, c) - residual(lo, c)) / (2.0 * h);
      }
      const Eigen::Vector3d dp = J.colPivHouseholderQr().solve(r);
      p -= dp;
      if (dp.norm() < kDiamondStepTolerance) break;
    }
  }
  Block b;
  b.name = n == 4 ? "diamond" : "diamond-" + std::to_string(n);
  b.structure.name = b.name;
  std::ostringstream src;
  src.precision(17);
  src << "single-stage diamond-pattern cylinder after Pugh (An Introduction to Tensegrity, 1976): " << n
      << " struts b_k-T_{k+1}, each the long diagonal of a rhombus of two cable triangles; cables b_k-T_k "
         "(force density 1), b_k-T_{k-1} (density "
      << c_final << "), both rings; unit radius and height, twist alpha = " << p[0]
      << " rad found by Gauss-Newton on the symmetric nodal balance (model/blocks.cpp)";
  b.source = src.str();
  auto& s = b.structure;
  for (int k = 0; k < n; ++k) {
    const double t = 2.0 * M_PI * k / n;
    s.add_node({std::cos(t), std::sin(t), 0.0});
  }
  for (int k = 0; k < n; ++k) {
    const double t = 2.0 * M_PI * k / n + p[0];
    s.add_node({std::cos(t), std::sin(t), 1.0});
  }
  std::vector<std::string> names;
  std::vector<double> q;
  auto add = [&](int a, int c, ElementKind kind, double density, const std::string& name) {
    add_named(s, names, a, c, kind, name);
    q.push_back(density);
  };
  for (int k = 0; k < n; ++k) add(k, n + (k + 1) % n, ElementKind::Strut, -(1.0 + c_final), "strut-" + std::to_string(k));
  for (int k = 0; k < n; ++k) add(k, n + k, ElementKind::Cable, 1.0, "vertical-" + std::to_string(k));
  for (int k = 0; k < n; ++k) add(k, n + (k + n - 1) % n, ElementKind::Cable, c_final, "diagonal-" + std::to_string(k));
  for (int k = 0; k < n; ++k) add(k, (k + 1) % n, ElementKind::Cable, p[1], "bottom-" + std::to_string(k));
  for (int k = 0; k < n; ++k) add(n + k, n + (k + 1) % n, ElementKind::Cable, p[2], "top-" + std::to_string(k));
  ensure_extras(s);
  set_cable_names(b, names);
  b.forces = forces_from_densities(s, Eigen::Map<Eigen::VectorXd>(q.data(), q.size()));
  for (int k = 0; k < n; ++k) {
    b.faces["lower-" + std::to_string(k)] = {k, (k + 1) % n, n + k};
    b.faces["upper-" + std::to_string(k)] = {n + k, n + (k + 1) % n, (k + 1) % n};
  }
  const std::array<int, 3> ring = {0, n / 3, (2 * n) / 3};
  b.faces["bottom"] = ring;
  b.faces["top"] = {n + ring[0], n + ring[1], n + ring[2]};
  return b;
}

Block make_double_icosahedron_block() {
  const Block ico = make_icosahedron_block();
  const auto& shared = ico.faces.at("x+y+z+");
  const Eigen::Vector3d normal = Eigen::Vector3d(1, 1, 1).normalized();
  const double offset = normal.dot(ico.structure.positions.col(shared[0]));
  // Frame: the shared face's normal becomes +x, its centroid the origin.
  const Eigen::Matrix3d R =
      Eigen::Quaterniond::FromTwoVectors(normal, Eigen::Vector3d::UnitX()).toRotationMatrix();
  const Eigen::Vector3d centre = offset * normal;

  Block b;
  b.name = "double-icosahedron";
  b.source =
      "two expandable octahedra (half strut length 1) sharing one all-cable face, the second the mirror image "
      "of the first in the plane of that face; the three shared cables carry the sum of both cables' forces. "
      "The sum of two self-stresses is a self-stress, so the template is in equilibrium exactly (nodes of the "
      "shared face carry two struts). Long axis along x, shared face in the plane x = 0";
  auto& s = b.structure;
  s.name = b.name;
  std::vector<int> map_a(12), map_b(12);
  for (int i = 0; i < 12; ++i) map_a[i] = s.add_node(R * (ico.structure.positions.col(i) - centre));
  for (int i = 0; i < 12; ++i) {
    const bool on_face = i == shared[0] || i == shared[1] || i == shared[2];
    if (on_face) {
      map_b[i] = map_a[i];
      continue;
    }
    Eigen::Vector3d x = ico.structure.positions.col(i);
    x -= 2.0 * (normal.dot(x) - offset) * normal;
    map_b[i] = s.add_node(R * (x - centre));
  }
  std::vector<std::string> names;
  std::vector<double> forces;
  std::map<std::pair<int, int>, int> seen;
  auto add_copy = [&](const std::vector<int>& map, const std::string& prefix) {
    for (int e = 0; e < ico.structure.num_elements(); ++e) {
      const auto& el = ico.structure.elements[e];
      int a = map[el.a], c = map[el.b];
      const auto key = std::minmax(a, c);
      auto it = seen.find(key);
      if (it != seen.end()) {
        forces[it->second] += ico.forces[e];
        names[it->second] = "shared-" + std::to_string(key.first) + "-" + std::to_string(key.second);
        continue;
      }
      seen[key] = s.num_elements();
      add_named(s, names, a, c, el.kind,
                el.kind == ElementKind::Strut ? prefix + "strut-" + std::to_string(e)
                                              : prefix + "cable-" + std::to_string(a) + "-" + std::to_string(c));
      forces.push_back(ico.forces[e]);
    }
  };
  add_copy(map_a, "a.");
  add_copy(map_b, "b.");
  ensure_extras(s);
  set_cable_names(b, names);
  b.forces = Eigen::Map<Eigen::VectorXd>(forces.data(), forces.size());
  double cable_sum = 0.0;
  for (int e = 0; e < s.num_elements(); ++e)
    if (s.elements[e].kind == ElementKind::Cable) cable_sum += b.forces[e];
  b.forces *= b.num_cables() / cable_sum;
  for (const auto& [name, f] : ico.faces) {
    if (name == "x+y+z+") continue;
    b.faces["a." + name] = {map_a[f[0]], map_a[f[1]], map_a[f[2]]};
    b.faces["b." + name] = {map_b[f[0]], map_b[f[1]], map_b[f[2]]};
  }
  return b;
}

namespace {

// Self-stress normalised to a mean cable force of 1 N; throws if there is none.
Eigen::VectorXd normalised_self_stress(const Structure& s, const std::string& what) {
  Eigen::VectorXd f;
  if (!find_signed_self_stress(s, &f)) throw std::logic_error(what + ": no signed self-stress");
  double cable_sum = 0.0;
  int cables = 0;
  for (int e = 0; e < s.num_elements(); ++e)
    if (s.elements[e].kind == ElementKind::Cable) {
      cable_sum += f[e];
      ++cables;
    }
  return f * (cables / cable_sum);
}

// The six short cables between same-side ends of parallel struts.
void add_pair_cables(Structure& s, std::vector<std::string>& names) {
  for (int pair = 0; pair < 3; ++pair)
    for (int end = 0; end < 2; ++end) {
      const int a = 4 * pair + end, c = 4 * pair + 2 + end;
      add_named(s, names, a, c, ElementKind::Cable, "pair-" + std::to_string(a) + "-" + std::to_string(c));
    }
}

}  // namespace

Block make_braced_icosahedron_block(double pair_offset) {
  Block b = make_icosahedron_block();
  b.name = "icosahedron-braced";
  b.structure.name = b.name;
  auto& s = b.structure;
  for (int i = 0; i < s.num_nodes(); ++i)
    for (int k = 0; k < 3; ++k)
      if (std::abs(std::abs(s.positions(k, i)) - 0.5) < kSamePosition)
        s.positions(k, i) = std::copysign(pair_offset, s.positions(k, i));
  std::vector<std::string> names;
  for (int e = 0; e < s.num_elements(); ++e) names.push_back(s.element_extra[e].value("name", ""));
  add_pair_cables(s, names);
  ensure_extras(s);
  b.cables.clear();
  set_cable_names(b, names);
  b.forces = normalised_self_stress(s, b.name);
  std::ostringstream src;
  src << "expandable octahedron (half strut length 1) with its parallel strut pairs " << 2 * pair_offset
      << " apart and the 6 short cables between the same-side ends of each pair: every one of the 20 "
         "icosahedron faces is a cable triangle (30 cables); self-stress by alternating projections "
         "(model/blocks.cpp)";
  b.source = src.str();
  add_interior_ties(b, 30);
  return b;
}

Block make_braced_prism_block(int n) {
  Block b = make_diamond_block(n);
  b.name = "prism-" + std::to_string(n) + "-braced";
  b.structure.name = b.name;
  b.source = "the " + std::to_string(n) + "-strut prism braced with a diagonal cable on every side face: " + b.source;
  add_interior_ties(b, 4 * n);
  return b;
}

Block make_braced_double_icosahedron_block(double pair_offset) {
  Block b = make_double_icosahedron_block();
  b.name = "double-icosahedron-braced";
  b.structure.name = b.name;
  auto& s = b.structure;
  // Rebuild from the braced geometry: same construction, pair offset changed.
  const Block ico = make_braced_icosahedron_block(pair_offset);
  const Block plain = make_icosahedron_block();
  const auto& shared = plain.faces.at("x+y+z+");
  const Eigen::Vector3d normal = Eigen::Vector3d(1, 1, 1).normalized();
  const Eigen::Vector3d shared_centre =
      (ico.structure.positions.col(shared[0]) + ico.structure.positions.col(shared[1]) +
       ico.structure.positions.col(shared[2])) / 3.0;
  const double offset = normal.dot(shared_centre);
  const Eigen::Matrix3d R = Eigen::Quaterniond::FromTwoVectors(normal, Eigen::Vector3d::UnitX()).toRotationMatrix();
  const Eigen::Vector3d centre = offset * normal;
  // Node maps of make_double_icosahedron_block: copy A is nodes 0..11, copy B
  // the mirror images of the nine nodes off the shared face, in order.
  std::vector<int> map_b(12);
  int next = 12;
  for (int i = 0; i < 12; ++i) {
    const bool on_face = i == shared[0] || i == shared[1] || i == shared[2];
    map_b[i] = on_face ? i : next++;
    Eigen::Vector3d x = ico.structure.positions.col(i);
    s.positions.col(i) = R * (x - centre);
    if (!on_face) {
      x -= 2.0 * (normal.dot(x) - offset) * normal;
      s.positions.col(map_b[i]) = R * (x - centre);
    }
  }
  std::vector<std::string> names;
  for (int e = 0; e < s.num_elements(); ++e) names.push_back(s.element_extra[e].value("name", ""));
  for (int pair = 0; pair < 3; ++pair)
    for (int end = 0; end < 2; ++end) {
      const int a = 4 * pair + end, c = 4 * pair + 2 + end;
      add_named(s, names, a, c, ElementKind::Cable, "a.pair-" + std::to_string(a) + "-" + std::to_string(c));
      add_named(s, names, map_b[a], map_b[c], ElementKind::Cable,
                "b.pair-" + std::to_string(map_b[a]) + "-" + std::to_string(map_b[c]));
    }
  ensure_extras(s);
  b.cables.clear();
  set_cable_names(b, names);
  b.forces = normalised_self_stress(s, b.name);
  std::ostringstream src;
  src << "two braced icosahedra (pair offset " << pair_offset
      << ", 30 cables each) sharing one all-cable face, the second the mirror image of the first in that face's "
         "plane: 57 cables; self-stress by alternating projections (model/blocks.cpp)";
  b.source = src.str();
  add_interior_ties(b, 60);
  return b;
}

std::vector<Block> make_standard_blocks() {
  std::vector<Block> blocks;
  for (int n = 3; n <= 12; ++n) blocks.push_back(make_prism_block(n));
  blocks.push_back(make_quadruplex_block());
  blocks.push_back(make_icosahedron_block());
  blocks.push_back(make_diamond_block());
  blocks.push_back(make_double_icosahedron_block());
  for (int n = 3; n <= 12; ++n) blocks.push_back(make_braced_prism_block(n));
  blocks.push_back(make_braced_icosahedron_block());
  blocks.push_back(make_braced_double_icosahedron_block());
  return blocks;
}
}  // namespace tensegrity
