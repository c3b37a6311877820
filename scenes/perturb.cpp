#include "scenes/perturb.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

namespace tensegrity::scenes {
namespace {

double element_length(const Structure& s, const Element& e) {
  return (s.positions.col(e.b) - s.positions.col(e.a)).norm();
}

double usable_length(double l) { return l > 0.0 && std::isfinite(l) ? l : 1.0; }

std::vector<int> free_nodes(const Structure& s) {
  std::vector<int> nodes;
  for (int i = 0; i < s.num_nodes(); ++i)
    if (!s.fixed[i]) nodes.push_back(i);
  return nodes;
}

int pick(const std::vector<int>& items, std::mt19937_64& rng) {
  std::uniform_int_distribution<std::size_t> u(0, items.size() - 1);
  return items[u(rng)];
}

}  // namespace

Eigen::Vector3d random_direction(std::mt19937_64& rng) {
  constexpr double kShortest = 1e-3;  // below this, normalising loses the uniform direction
  for (;;) {
    const Eigen::Vector3d d = random_offset(NoiseShape::UniformBall, rng);
    if (d.norm() > kShortest) return d.normalized();
  }
}

double measure_length(const Structure& s, LengthMeasure measure) {
  if (measure == LengthMeasure::OneMetre || s.elements.empty()) return 1.0;
  switch (measure) {
    case LengthMeasure::OneMetre:
      return 1.0;
    case LengthMeasure::FirstElement:
      return usable_length(element_length(s, s.elements.front()));
    case LengthMeasure::LongestStrut: {
      double longest = 0.0;
      for (const Element& e : s.elements)
        if (e.kind == ElementKind::Strut) longest = std::max(longest, element_length(s, e));
      return usable_length(longest);
    }
    case LengthMeasure::MeanStrut: {
      double sum = 0.0;
      int count = 0;
      for (const Element& e : s.elements)
        if (e.kind == ElementKind::Strut) sum += element_length(s, e), ++count;
      return usable_length(count > 0 ? sum / count : 0.0);
    }
    case LengthMeasure::MedianElement: {
      std::vector<double> lengths;
      for (const Element& e : s.elements) lengths.push_back(element_length(s, e));
      std::nth_element(lengths.begin(), lengths.begin() + lengths.size() / 2, lengths.end());
      return usable_length(lengths[lengths.size() / 2]);
    }
  }
  return 1.0;
}

Structure with_node_noise(Structure s, const NodeNoise& noise, unsigned seed) {
  std::mt19937 rng(seed);
  add_node_noise(s, noise, rng);
  return s;
}

void twist_upper_half(Structure& s, double degrees) {
  std::vector<double> z(s.num_nodes());
  for (int i = 0; i < s.num_nodes(); ++i) z[i] = s.positions(2, i);
  std::vector<double> sorted = z;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  const double median_z = sorted[sorted.size() / 2];
  std::vector<int> upper;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (int i = 0; i < s.num_nodes(); ++i)
    if (!s.fixed[i] && z[i] > median_z) {
      upper.push_back(i);
      centre += s.positions.col(i);
    }
  if (upper.empty()) return;
  centre /= static_cast<double>(upper.size());
  const double a = degrees * M_PI / 180.0;
  Eigen::Matrix3d r;
  r << std::cos(a), -std::sin(a), 0.0, std::sin(a), std::cos(a), 0.0, 0.0, 0.0, 1.0;
  for (int i : upper) s.positions.col(i) = centre + r * (s.positions.col(i) - centre);
}

void make_near_coincident(Structure& s, double distance, std::mt19937_64& rng) {
  const std::vector<int> movable = free_nodes(s);
  if (movable.empty() || s.num_nodes() < 2) return;
  const int j = pick(movable, rng);
  std::vector<int> others;
  for (int i = 0; i < s.num_nodes(); ++i)
    if (i != j) others.push_back(i);
  const int i = pick(others, rng);
  s.positions.col(j) = s.positions.col(i) + distance * random_direction(rng);
}

void make_near_parallel(Structure& s, double angle, std::mt19937_64& rng) {
  // Pairs of elements (a, b), (a, c) sharing node a with c free.
  std::vector<std::vector<int>> touching(s.num_nodes());
  for (int e = 0; e < s.num_elements(); ++e) {
    touching[s.elements[e].a].push_back(e);
    touching[s.elements[e].b].push_back(e);
  }
  std::vector<int> hubs;
  for (int a = 0; a < s.num_nodes(); ++a)
    if (touching[a].size() >= 2) hubs.push_back(a);
  if (hubs.empty()) return;
  const int a = pick(hubs, rng);
  auto other_end = [&](int e) { return s.elements[e].a == a ? s.elements[e].b : s.elements[e].a; };
  std::vector<int> free_ends;
  for (int e : touching[a])
    if (!s.fixed[other_end(e)]) free_ends.push_back(e);
  if (free_ends.empty()) return;
  const int moved = pick(free_ends, rng);
  std::vector<int> guides;
  for (int e : touching[a])
    if (e != moved) guides.push_back(e);
  const int guide = pick(guides, rng);
  const int b = other_end(guide), c = other_end(moved);
  const Eigen::Vector3d xa = s.positions.col(a);
  const Eigen::Vector3d u = (s.positions.col(b) - xa).normalized();
  const Eigen::Vector3d v = s.positions.col(c) - xa;
  constexpr double kParallel = 1e-12;  // relative: v already lies along u
  Eigen::Vector3d w = v - v.dot(u) * u;
  if (w.norm() < kParallel * v.norm()) w = u.unitOrthogonal();
  w.normalize();
  s.positions.col(c) = xa + v.norm() * (std::cos(angle) * u + std::sin(angle) * w);
}

void ensure_supports(Structure& s, const Eigen::Vector3d& down) {
  constexpr int kSupports = 3;
  if (std::any_of(s.fixed.begin(), s.fixed.end(), [](bool f) { return f; })) return;
  std::vector<std::pair<double, int>> depth;
  for (int i = 0; i < s.num_nodes(); ++i) depth.push_back({-s.positions.col(i).dot(down), i});
  std::sort(depth.begin(), depth.end());
  for (int k = 0; k < std::min(kSupports, s.num_nodes() - 1); ++k) s.fixed[depth[k].second] = true;
}

}  // namespace tensegrity::scenes
