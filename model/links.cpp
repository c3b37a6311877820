#include "model/links.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <stdexcept>

#include "model/reference_scenes.hpp"

namespace tensegrity {

namespace {

Eigen::Vector3d centroid(const Structure& s, const std::array<int, 3>& f) {
  return (s.positions.col(f[0]) + s.positions.col(f[1]) + s.positions.col(f[2])) / 3.0;
}

double circumradius(const Structure& s, const std::array<int, 3>& f) {
  const Eigen::Vector3d c = centroid(s, f);
  double r = 0.0;
  for (int k = 0; k < 3; ++k) r += (s.positions.col(f[k]) - c).norm();
  return r / 3.0;
}

// Corners ordered by angle around axis u, so that both triangles of a link are
// walked in the same rotational sense.
std::array<int, 3> ordered_around(const Structure& s, const std::array<int, 3>& f, const Eigen::Vector3d& u) {
  const Eigen::Vector3d c = centroid(s, f);
  Eigen::Vector3d e1 = s.positions.col(f[0]) - c;
  e1 -= e1.dot(u) * u;
  e1.normalize();
  const Eigen::Vector3d e2 = u.cross(e1);
  std::array<std::pair<double, int>, 3> angle;
  for (int k = 0; k < 3; ++k) {
    const Eigen::Vector3d d = s.positions.col(f[k]) - c;
    angle[k] = {std::atan2(d.dot(e2), d.dot(e1)), f[k]};
  }
  std::sort(angle.begin(), angle.end());
  return {angle[0].second, angle[1].second, angle[2].second};
}

}  // namespace

bool segment_crosses_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& q, const Eigen::Vector3d& a,
                              const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d d = q - p, e1 = b - a, e2 = c - a;
  const Eigen::Vector3d h = d.cross(e2);
  const double det = e1.dot(h);
  if (std::abs(det) < 1e-300) return false;
  const Eigen::Vector3d s = p - a;
  const double u = s.dot(h) / det;
  if (u < 0.0 || u > 1.0) return false;
  const Eigen::Vector3d qv = s.cross(e1);
  const double v = d.dot(qv) / det;
  if (v < 0.0 || u + v > 1.0) return false;
  const double t = e2.dot(qv) / det;
  return t >= 0.0 && t <= 1.0;
}

LinkAddition add_face_link(Structure& s, const std::array<int, 3>& face_a, const std::array<int, 3>& face_b,
                           double depth_fraction) {
  for (const auto* f : {&face_a, &face_b})
    if ((*f)[0] == (*f)[1] || (*f)[1] == (*f)[2] || (*f)[0] == (*f)[2])
      throw std::invalid_argument("face link: a face repeats a node");
  if (!(depth_fraction > 0.0)) throw std::invalid_argument("face link: depth fraction must be > 0");
  const Eigen::Vector3d ca = centroid(s, face_a), cb = centroid(s, face_b);
  const double gap = (cb - ca).norm();
  if (!(gap > 1e-12)) throw std::invalid_argument("face link: the two face centroids coincide");
  const Eigen::Vector3d u = (cb - ca) / gap;

  LinkAddition out;
  const int pa = s.add_node(ca - depth_fraction * circumradius(s, face_a) * u);
  const int pb = s.add_node(cb + depth_fraction * circumradius(s, face_b) * u);
  out.nodes = {pa, pb};
  out.elements.push_back(s.add_element(pa, pb, ElementKind::Strut));
  for (int k = 0; k < 3; ++k) out.elements.push_back(s.add_element(pa, face_a[k], ElementKind::Cable));
  for (int k = 0; k < 3; ++k) out.elements.push_back(s.add_element(pb, face_b[k], ElementKind::Cable));

  const auto a = ordered_around(s, face_a, u), b = ordered_around(s, face_b, u);
  int best_k = 0;
  double best = 1e300;
  for (int k = 0; k < 3; ++k) {
    double total = 0.0;
    for (int i = 0; i < 3; ++i)
      total += (s.positions.col(a[i]) - s.positions.col(b[(i + k) % 3])).norm() +
               (s.positions.col(a[i]) - s.positions.col(b[(i + k + 1) % 3])).norm();
    if (total < best) {
      best = total;
      best_k = k;
    }
  }
  for (int i = 0; i < 3; ++i) {
    out.elements.push_back(s.add_element(a[i], b[(i + best_k) % 3], ElementKind::Cable));
    out.elements.push_back(s.add_element(a[i], b[(i + best_k + 1) % 3], ElementKind::Cable));
  }
  return out;
}

LinkAddition add_edge_link(Structure& s, int cable_a, int cable_b) {
  const int m = s.num_elements();
  if (cable_a < 0 || cable_a >= m || cable_b < 0 || cable_b >= m || cable_a == cable_b)
    throw std::invalid_argument("edge link: two different element indices expected");
  if (s.elements[cable_a].kind != ElementKind::Cable || s.elements[cable_b].kind != ElementKind::Cable)
    throw std::invalid_argument("edge link: both elements must be cables");
  int ua = s.elements[cable_a].a, va = s.elements[cable_a].b;
  int ub = s.elements[cable_b].a, vb = s.elements[cable_b].b;
  {
    std::set<int> ends = {ua, va, ub, vb};
    if (ends.size() != 4) throw std::invalid_argument("edge link: the two cables share a node");
  }
  auto X = [&](int i) -> Eigen::Vector3d { return s.positions.col(i); };
  if ((X(va) - X(ua)).dot(X(vb) - X(ub)) < 0.0) std::swap(ub, vb);

  // Frame of the inserted octahedron: its x pair along the two cables, y from
  // cable A towards cable B, centred between them.
  const Eigen::Vector3d mid_a = 0.5 * (X(ua) + X(va)), mid_b = 0.5 * (X(ub) + X(vb));
  Eigen::Vector3d e1 = ((X(va) - X(ua)) + (X(vb) - X(ub))).normalized();
  Eigen::Vector3d e2 = mid_b - mid_a;
  e2 -= e2.dot(e1) * e1;
  if (e2.norm() < 1e-12 * (mid_b - mid_a).norm() || (mid_b - mid_a).norm() < 1e-12)
    throw std::invalid_argument("edge link: the cables are collinear or coincide");
  e2.normalize();
  const Eigen::Vector3d e3 = e1.cross(e2);
  Eigen::Matrix3d R;
  R << e1, e2, e3;
  const double separation = (mid_b - mid_a).norm();
  const double half_length = 0.25 * ((X(va) - X(ua)).norm() + (X(vb) - X(ub)).norm());
  const double a = 0.5 * (separation + half_length);  // template: separation = half length
  const Eigen::Vector3d centre = 0.5 * (mid_a + mid_b);

  OctahedronParameters op;
  op.half_length = 1.0;
  const Structure ico = make_expandable_octahedron(op);  // nodes 0,1 (y = -1/2) and 2,3 (y = +1/2): x pair
  const int existing_nodes = s.num_nodes();
  std::vector<int> map(12);
  map[0] = ua;
  map[1] = va;
  map[2] = ub;
  map[3] = vb;
  LinkAddition out;
  out.merged_nodes = {ua, va, ub, vb};
  for (int i = 4; i < 12; ++i) {
    map[i] = s.add_node(centre + a * (R * ico.positions.col(i)));
    out.nodes.push_back(map[i]);
  }
  std::vector<int> added;
  for (const auto& el : ico.elements) {
    const bool merged_strut = el.kind == ElementKind::Strut && el.a < 4;
    if (merged_strut) continue;  // cancels against the block cable it lies on
    added.push_back(s.add_element(map[el.a], map[el.b], el.kind));
  }

  // Tie cables: shortest pairs (new node, block node), seven per side, at most
  // two per node on either end.
  std::set<std::pair<int, int>> joined;
  for (const auto& el : s.elements) joined.insert(std::minmax(el.a, el.b));
  std::map<int, int> ties_of;
  for (int side = 0; side < 2; ++side) {
    const Eigen::Vector3d side_mid = side == 0 ? mid_a : mid_b;
    // Block nodes of this side: those nearer to this cable's midpoint.
    std::vector<std::tuple<double, int, int>> candidates;
    for (int i = 4; i < 12; ++i) {
      const int n_new = map[i];
      for (int j = 0; j < existing_nodes; ++j) {
        if (j == ua || j == va || j == ub || j == vb) continue;
        const Eigen::Vector3d other_mid = side == 0 ? mid_b : mid_a;
        if ((X(j) - side_mid).norm() > (X(j) - other_mid).norm()) continue;
        candidates.emplace_back((X(n_new) - X(j)).norm(), n_new, j);
      }
    }
    std::sort(candidates.begin(), candidates.end());
    int made = 0;
    for (const auto& [dist, n_new, j] : candidates) {
      if (made == 7) break;
      if (ties_of[n_new] >= 2 || ties_of[j] >= 2 || joined.count(std::minmax(n_new, j))) continue;
      added.push_back(s.add_element(n_new, j, ElementKind::Cable));
      joined.insert(std::minmax(n_new, j));
      ++ties_of[n_new];
      ++ties_of[j];
      ++made;
    }
    if (made < 7) throw std::invalid_argument("edge link: too few block nodes to tie the inserted octahedron to");
  }

  // Remove the two block cables (higher index first) and renumber the additions.
  const int hi = std::max(cable_a, cable_b), lo = std::min(cable_a, cable_b);
  for (int e : {hi, lo}) {
    s.elements.erase(s.elements.begin() + e);
    if (e < static_cast<int>(s.element_extra.size())) s.element_extra.erase(s.element_extra.begin() + e);
  }
  for (int e : added) out.elements.push_back(e - 2);
  out.removed_elements = 2;
  return out;
}

}  // namespace tensegrity
