#include "model/blocks.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>
#include <tuple>
#include <Eigen/Geometry>

#include "model/errors.hpp"
#include "model/json_io.hpp"
#include "model/json_text.hpp"
#include "model/known_keys.hpp"
#include "model/reference_scenes.hpp"
#include "model/scene_io.hpp"

namespace tensegrity {

namespace {

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

void set_cable_names(Block& b, const std::vector<std::string>& names) {
  for (int e = 0; e < b.structure.num_elements(); ++e) {
    b.structure.element_extra[e] = nlohmann::json::object();
    if (!names[e].empty()) b.structure.element_extra[e]["name"] = names[e];
    if (b.structure.elements[e].kind == ElementKind::Cable && !names[e].empty()) b.cables[names[e]] = e;
  }
}

// The keys of a block file (docs/FORMATS.md).
const std::vector<std::string_view> kBlockKeys = {"format", "version", "name",     "source",
                                                                "counts", "nodes",   "elements", "faces", "ties"};
const std::vector<std::string_view> kBlockCountKeys = {"nodes", "struts", "cables"};
const std::vector<std::string_view> kBlockElementKeys = {"kind", "nodes", "force", "name"};
const std::vector<std::string_view> kBlockFaceKeys = {"name", "nodes", "normal"};

void ensure_extras(Structure& s) {
  s.node_extra.resize(s.num_nodes(), nlohmann::json::object());
  s.element_extra.resize(s.num_elements(), nlohmann::json::object());
}

Eigen::Vector3d face_normal(const Structure& s, const std::array<int, 3>& f) {
  const Eigen::Vector3d a = s.positions.col(f[0]), b = s.positions.col(f[1]), c = s.positions.col(f[2]);
  Eigen::Vector3d nrm = (b - a).cross(c - a).normalized();
  const Eigen::Vector3d centre = s.positions.rowwise().mean();
  if (nrm.dot((a + b + c) / 3.0 - centre) < 0.0) nrm = -nrm;
  return nrm;
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
            if ((s.positions.col(i) - want[k]).norm() < 1e-9) f[k] = i;
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
  const int steps = 20;
  for (int step = 1; step <= steps; ++step) {
    const double c = c_final * step / steps;
    for (int it = 0; it < 30; ++it) {
      const auto r = residual(p, c);
      Eigen::Matrix<double, 6, 3> J;
      for (int j = 0; j < 3; ++j) {
        Eigen::Vector3d hi = p, lo = p;
        const double h = 1e-7;
        hi[j] += h;
        lo[j] -= h;
        J.col(j) = (residual(hi, c) - residual(lo, c)) / (2.0 * h);
      }
      const Eigen::Vector3d dp = J.colPivHouseholderQr().solve(r);
      p -= dp;
      if (dp.norm() < 1e-15) break;
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

double segment_distance(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1, const Eigen::Vector3d& q0,
                        const Eigen::Vector3d& q1) {
  // Closest points of two segments (Ericson, Real-Time Collision Detection, 5.1.9).
  const Eigen::Vector3d d1 = p1 - p0, d2 = q1 - q0, r = p0 - q0;
  const double a = d1.squaredNorm(), e = d2.squaredNorm(), f = d2.dot(r);
  const double c = d1.dot(r), b = d1.dot(d2), denom = a * e - b * b;
  double s = denom > 1e-14 * a * e ? std::clamp((b * f - c * e) / denom, 0.0, 1.0) : 0.0;
  double t = (b * s + f) / e;
  if (t < 0.0) {
    t = 0.0;
    s = std::clamp(-c / a, 0.0, 1.0);
  } else if (t > 1.0) {
    t = 1.0;
    s = std::clamp((b - c) / a, 0.0, 1.0);
  }
  return ((p0 + s * d1) - (q0 + t * d2)).norm();
}

bool find_signed_self_stress(const Structure& s, Eigen::VectorXd* forces) {
  const int n = s.num_nodes(), m = s.num_elements();
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(3 * n, m);
  for (int e = 0; e < m; ++e) {
    const auto& el = s.elements[e];
    const Eigen::Vector3d u = (s.positions.col(el.b) - s.positions.col(el.a)).normalized();
    A.block<3, 1>(3 * el.a, e) = u;
    A.block<3, 1>(3 * el.b, e) = -u;
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(A, Eigen::ComputeFullV);
  const Eigen::VectorXd& sv = svd.singularValues();
  int rank = 0;
  for (int k = 0; k < sv.size(); ++k) rank += sv[k] > 1e-10 * sv[0];
  if (rank == m) return false;
  const Eigen::MatrixXd N = svd.matrixV().rightCols(m - rank);
  Eigen::VectorXd sign(m);
  for (int e = 0; e < m; ++e) sign[e] = s.elements[e].kind == ElementKind::Cable ? 1.0 : -1.0;
  constexpr int kMaxSweeps = 5000;
  constexpr double kAcceptedMargin = 0.5;  // of the box's margin 1
  constexpr double kStalledStep = 1e-10;   // relative change of a sweep at a fixed point
  // The projections run thousands of times per candidate tie: buffers are
  // allocated once so the loop itself does not allocate.
  Eigen::VectorXd coefficients = N.transpose() * sign;
  Eigen::VectorXd sigma = N * coefficients;
  Eigen::VectorXd signed_sigma(m), boxed(m);
  for (int sweep = 0; sweep < kMaxSweeps; ++sweep) {
    signed_sigma = sigma.cwiseProduct(sign);
    const double margin = signed_sigma.minCoeff();
    if (margin >= kAcceptedMargin) {
      *forces = sigma / margin;
      return true;
    }
    boxed = signed_sigma.cwiseMax(1.0).cwiseProduct(sign);
    coefficients.noalias() = N.transpose() * boxed;
    // Projections onto two convex sets converge; once they no longer move, the
    // sets do not meet within reach and further sweeps cannot find a margin.
    boxed.noalias() = N * coefficients;
    const double step = (boxed - sigma).norm();
    sigma.swap(boxed);
    if (step <= kStalledStep * sigma.norm()) return false;
  }
  return false;
}

Structure with_ties(const Block& b, int count) {
  Structure s = b.structure;
  ensure_extras(s);
  for (int k = 0; k < count; ++k) {
    const int e = s.add_element(b.ties[k][0], b.ties[k][1], ElementKind::Cable);
    s.element_extra.resize(s.num_elements(), nlohmann::json::object());
    s.element_extra[e] = {{"name", "tie-" + std::to_string(k)}};
  }
  return s;
}

void add_interior_ties(Block& b, int max_ties, double tie_clearance) {
  const Structure& s = b.structure;
  double strut_length = 0.0;
  std::set<std::pair<int, int>> joined;
  for (const auto& el : s.elements) {
    joined.insert(std::minmax(el.a, el.b));
    if (el.kind == ElementKind::Strut)
      strut_length = std::max(strut_length, (s.positions.col(el.b) - s.positions.col(el.a)).norm());
  }
  for (const auto& t : b.ties) joined.insert(std::minmax(t[0], t[1]));
  std::vector<std::tuple<double, int, int>> candidates;
  for (int i = 0; i < s.num_nodes(); ++i)
    for (int j = i + 1; j < s.num_nodes(); ++j)
      if (!joined.count({i, j})) candidates.emplace_back((s.positions.col(j) - s.positions.col(i)).norm(), i, j);
  std::sort(candidates.begin(), candidates.end());
  const double clearance = tie_clearance * strut_length;
  int added = 0;
  for (const auto& [length, i, j] : candidates) {
    if (added == max_ties) break;
    Structure trial = with_ties(b, static_cast<int>(b.ties.size()));
    bool clear = true;
    for (const auto& el : trial.elements) {
      if (el.a == i || el.a == j || el.b == i || el.b == j) continue;
      if (segment_distance(s.positions.col(i), s.positions.col(j), s.positions.col(el.a), s.positions.col(el.b)) <
          clearance) {
        clear = false;
        break;
      }
    }
    if (!clear) continue;
    trial.add_element(i, j, ElementKind::Cable);
    Eigen::VectorXd sigma;
    if (!find_signed_self_stress(trial, &sigma)) continue;
    b.ties.push_back({i, j});
    ++added;
  }
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
      if (std::abs(std::abs(s.positions(k, i)) - 0.5) < 1e-12) s.positions(k, i) = std::copysign(pair_offset, s.positions(k, i));
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

nlohmann::json block_to_json(const Block& b) {
  using nlohmann::json;
  json j;
  j["format"] = "tensegrity-block";
  j["version"] = 1;
  j["name"] = b.name;
  j["source"] = b.source;
  j["counts"] = {{"nodes", b.structure.num_nodes()}, {"struts", b.num_struts()}, {"cables", b.num_cables()}};
  json nodes = json::array();
  for (int i = 0; i < b.structure.num_nodes(); ++i) {
    const Eigen::Vector3d x = b.structure.positions.col(i);
    nodes.push_back({x.x(), x.y(), x.z()});
  }
  j["nodes"] = nodes;
  json elements = json::array();
  for (int e = 0; e < b.structure.num_elements(); ++e) {
    const auto& el = b.structure.elements[e];
    json je;
    je["kind"] = to_string(el.kind);
    je["nodes"] = {el.a, el.b};
    je["force"] = b.forces[e];
    if (e < static_cast<int>(b.structure.element_extra.size()) && b.structure.element_extra[e].contains("name"))
      je["name"] = b.structure.element_extra[e]["name"];
    elements.push_back(je);
  }
  j["elements"] = elements;
  json faces = json::array();
  for (const auto& [name, f] : b.faces) {
    const Eigen::Vector3d nrm = face_normal(b.structure, f);
    faces.push_back({{"name", name}, {"nodes", {f[0], f[1], f[2]}}, {"normal", {nrm.x(), nrm.y(), nrm.z()}}});
  }
  j["faces"] = faces;
  if (!b.ties.empty()) {
    json ties = json::array();
    for (const auto& t : b.ties) ties.push_back({t[0], t[1]});
    j["ties"] = ties;
  }
  return j;
}

Block block_from_json(const nlohmann::json& j, const std::string& source) {
  json_expect_header(j, "tensegrity-block", source);
  KeyChecker keys(source);
  keys.check(j, kBlockKeys, "");
  if (j.contains("counts")) keys.check(j["counts"], kBlockCountKeys, "counts");
  Block b;
  if (!j.contains("name")) throw InputError(source, "name", "missing");
  b.name = json_string(j["name"], source, "name");
  if (j.contains("source")) b.source = json_string(j["source"], source, "source");
  b.structure.name = b.name;
  if (!j.contains("nodes") || !j["nodes"].is_array() || j["nodes"].empty())
    throw InputError(source, "nodes", "missing or not a non-empty array");
  for (std::size_t i = 0; i < j["nodes"].size(); ++i)
    b.structure.add_node(json_vector3(j["nodes"][i], source, "nodes[" + std::to_string(i) + "]"));
  const int n = b.structure.num_nodes();
  if (!j.contains("elements") || !j["elements"].is_array() || j["elements"].empty())
    throw InputError(source, "elements", "missing or not a non-empty array");
  const auto& elements = j["elements"];
  b.forces.resize(elements.size());
  std::vector<std::string> names;
  for (std::size_t e = 0; e < elements.size(); ++e) {
    const std::string item = "elements[" + std::to_string(e) + "]";
    const auto& je = elements[e];
    if (!je.is_object()) throw InputError(source, item, "not an object");
    keys.check(je, kBlockElementKeys, item);
    const std::string kind = je.contains("kind") ? json_string(je["kind"], source, item + ".kind") : "";
    ElementKind k;
    if (kind == "strut")
      k = ElementKind::Strut;
    else if (kind == "cable")
      k = ElementKind::Cable;
    else
      throw InputError(source, item + ".kind", "must be \"strut\" or \"cable\"");
    if (!je.contains("nodes") || !je["nodes"].is_array() || je["nodes"].size() != 2)
      throw InputError(source, item + ".nodes", "must be two node indices");
    const int a = json_index(je["nodes"][0], n, "node", source, item + ".nodes[0]");
    const int c = json_index(je["nodes"][1], n, "node", source, item + ".nodes[1]");
    if (!je.contains("force")) throw InputError(source, item + ".force", "missing");
    const double f = json_finite_number(je["force"], source, item + ".force");
    if (k == ElementKind::Cable ? f <= 0.0 : f >= 0.0)
      throw InputError(source, item + ".force", "a " + kind + " force must be " + (k == ElementKind::Cable ? "> 0" : "< 0"));
    b.forces[e] = f;
    names.push_back(je.contains("name") ? json_string(je["name"], source, item + ".name") : "");
    b.structure.add_element(a, c, k);
  }
  ensure_extras(b.structure);
  for (std::size_t e = 0; e < names.size(); ++e) {
    if (names[e].empty()) continue;
    if (b.structure.elements[e].kind == ElementKind::Cable && b.cables.count(names[e]))
      throw InputError(source, "elements[" + std::to_string(e) + "].name", "duplicate cable name '" + names[e] + "'");
  }
  set_cable_names(b, names);
  if (j.contains("faces")) {
    if (!j["faces"].is_array()) throw InputError(source, "faces", "must be an array");
    for (std::size_t i = 0; i < j["faces"].size(); ++i) {
      const std::string item = "faces[" + std::to_string(i) + "]";
      const auto& jf = j["faces"][i];
      keys.check(jf, kBlockFaceKeys, item);
      if (!jf.is_object() || !jf.contains("name") || !jf.contains("nodes") || !jf["nodes"].is_array() ||
          jf["nodes"].size() != 3)
        throw InputError(source, item, "must be an object with a name and three node indices");
      std::array<int, 3> f{};
      for (int k = 0; k < 3; ++k) f[k] = json_index(jf["nodes"][k], n, "node", source, item + ".nodes");
      if (f[0] == f[1] || f[1] == f[2] || f[0] == f[2]) throw InputError(source, item, "repeats a node");
      const std::string name = json_string(jf["name"], source, item + ".name");
      if (b.faces.count(name)) throw InputError(source, item, "duplicate face name '" + name + "'");
      b.faces[name] = f;
    }
  }
  if (j.contains("ties")) {
    if (!j["ties"].is_array()) throw InputError(source, "ties", "must be an array of node pairs");
    std::set<std::pair<int, int>> joined;
    for (const auto& el : b.structure.elements) joined.insert(std::minmax(el.a, el.b));
    for (std::size_t i = 0; i < j["ties"].size(); ++i) {
      const std::string item = "ties[" + std::to_string(i) + "]";
      const auto& jt = j["ties"][i];
      if (!jt.is_array() || jt.size() != 2) throw InputError(source, item, "must be two node indices");
      const int a = json_index(jt[0], n, "node", source, item + "[0]");
      const int c = json_index(jt[1], n, "node", source, item + "[1]");
      if (a == c) throw InputError(source, item, "joins a node to itself");
      if (!joined.insert(std::minmax(a, c)).second)
        throw InputError(source, item, "joins two nodes already joined");
      b.ties.push_back({a, c});
    }
  }
  validate(b.structure, source);
  keys.report();
  return b;
}

Block read_block_file(const std::string& path) { return block_from_json(read_json_file(path), path); }

void write_block_file(const Block& b, const std::string& path) {
  write_text_file_atomically(path, to_json_text(block_to_json(b)) + "\n");
}

BlockLibrary BlockLibrary::load(const std::string& directory) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::is_directory(directory, ec)) throw InputError(directory, "", "block library folder not found");
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(directory, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.size() > 11 && name.substr(name.size() - 11) == ".block.json") files.push_back(entry.path());
  }
  if (files.empty()) throw InputError(directory, "", "no *.block.json files in the block library folder");
  std::sort(files.begin(), files.end());
  BlockLibrary lib;
  for (const auto& f : files) lib.add(read_block_file(f.string()));
  return lib;
}

BlockLibrary BlockLibrary::standard() {
  BlockLibrary lib;
  for (auto& b : make_standard_blocks()) lib.add(std::move(b));
  return lib;
}

void BlockLibrary::add(Block b) {
  std::string name = b.name;
  blocks_[name] = std::move(b);
}

const Block& BlockLibrary::get(const std::string& name, const std::string& source,
                               const std::string& item) const {
  auto it = blocks_.find(name);
  if (it == blocks_.end()) {
    std::string known;
    for (const auto& [n, b] : blocks_) known += (known.empty() ? "" : ", ") + n;
    throw InputError(source, item, "unknown block type '" + name + "' (library: " + known + ")");
  }
  return it->second;
}

std::vector<std::string> BlockLibrary::names() const {
  std::vector<std::string> out;
  for (const auto& [n, b] : blocks_) out.push_back(n);
  return out;
}

Eigen::Matrix3Xd instance_positions(const Block& b, const BlockTransform& t) {
  Eigen::Matrix3Xd x = b.structure.positions;
  for (const auto& [node, d] : t.displacements) x.col(node) += d;
  Eigen::Matrix3Xd out = (t.scale * t.rotation) * x;
  out.colwise() += t.translation;
  return out;
}

double relative_self_stress_residual(const Structure& s, const Eigen::Matrix3Xd& positions,
                                     const Eigen::VectorXd& forces) {
  Eigen::Matrix3Xd net = Eigen::Matrix3Xd::Zero(3, s.num_nodes());
  for (int e = 0; e < s.num_elements(); ++e) {
    const auto& el = s.elements[e];
    const Eigen::Vector3d u = (positions.col(el.b) - positions.col(el.a)).normalized();
    net.col(el.a) += forces[e] * u;
    net.col(el.b) -= forces[e] * u;
  }
  double worst = 0.0;
  for (int i = 0; i < s.num_nodes(); ++i)
    if (!s.fixed[i]) worst = std::max(worst, net.col(i).norm());
  return worst / forces.cwiseAbs().maxCoeff();
}

}  // namespace tensegrity
