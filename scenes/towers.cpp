#include "scenes/towers.hpp"

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <tuple>
#include <utility>
#include <vector>

#include "model/links.hpp"
#include "model/scene_io.hpp"
#include "scenes/perturb.hpp"
#include "model/reference_scenes.hpp"

namespace tensegrity::scenes {
namespace {

NodeNoise tower_noise(double fraction) {
  NodeNoise noise;
  noise.fraction = fraction;
  noise.length = LengthMeasure::FirstElement;
  noise.shape = NoiseShape::CubeClippedToBall;
  return noise;
}

}  // namespace

Structure with_tower_noise(Structure s, double fraction, unsigned seed) {
  return with_node_noise(std::move(s), tower_noise(fraction), seed);
}

Structure tower_equilibrium(const std::string& data_dir, bool gravity) {
  std::string path = data_dir;  // appended: GCC 12 warns falsely on chained operator+ once inlined
  path += "/bench/tower-80s-500c";
  path += gravity ? "-gravity.scene.json" : ".scene.json";
  return read_scene_file(path);
}

Structure perturbed_tower(const std::string& data_dir, bool gravity, double noise, unsigned seed) {
  return with_tower_noise(tower_equilibrium(data_dir, gravity), noise, seed);
}

Structure make_prism_tower(const TowerParameters& p) {
  Structure s;
  const int n = p.struts_per_layer;
  const double twist = prism_equilibrium_twist(n);
  const double rise = p.layer_height * (1.0 - p.overlap);
  std::vector<std::vector<int>> bottom(p.layers), top(p.layers);
  for (int l = 0; l < p.layers; ++l) {
    // Each layer turned by half a step so its bottom ring sits between the
    // previous top ring's nodes.
    const double turn = l * (twist + M_PI / n);
    for (int k = 0; k < n; ++k) {
      const double t = turn + 2.0 * M_PI * k / n;
      bottom[l].push_back(s.add_node({std::cos(t), std::sin(t), l * rise}, p.gravity && l == 0));
    }
    for (int k = 0; k < n; ++k) {
      const double t = turn + twist + 2.0 * M_PI * k / n;
      top[l].push_back(s.add_node({std::cos(t), std::sin(t), l * rise + p.layer_height}));
    }
    const double strut_mass = p.gravity ? 0.05 : 0.0, cable_mass = p.gravity ? 0.005 : 0.0;
    for (int k = 0; k < n; ++k) s.add_element(bottom[l][k], top[l][(k + 1) % n], ElementKind::Strut, strut_mass);
    for (int k = 0; k < n; ++k) s.add_element(bottom[l][k], top[l][k], ElementKind::Cable, cable_mass);
    for (int k = 0; k < n; ++k) s.add_element(bottom[l][k], bottom[l][(k + 1) % n], ElementKind::Cable, cable_mass);
    for (int k = 0; k < n; ++k) s.add_element(top[l][k], top[l][(k + 1) % n], ElementKind::Cable, cable_mass);
  }
  // Joining cables: round j links every top node of layer l to its j-th
  // nearest bottom node of layer l + 1.
  int cables = 3 * n * p.layers;
  for (int round = 0; round < n && cables < p.cables; ++round) {
    for (int l = 0; l + 1 < p.layers && cables < p.cables; ++l) {
      for (int a : top[l]) {
        if (cables >= p.cables) break;
        std::vector<std::pair<double, int>> near;
        for (int b : bottom[l + 1]) near.push_back({(s.positions.col(a) - s.positions.col(b)).norm(), b});
        std::sort(near.begin(), near.end());
        s.add_element(a, near[round].second, ElementKind::Cable, p.gravity ? 0.005 : 0.0);
        ++cables;
      }
    }
  }
  if (p.gravity) s.gravity = Eigen::Vector3d(0.0, 0.0, -9.81);
  s = with_tower_noise(std::move(s), p.noise, p.seed);
  s.name = "tower-" + std::to_string(p.layers * n) + "s-" + std::to_string(cables) + "c" +
           (p.gravity ? "-gravity" : "");
  return s;
}


Structure octahedron_chain(int blocks) {
  Structure s;
  s.name = "octahedron-chain-" + std::to_string(blocks);
  const Structure block = make_expandable_octahedron(OctahedronParameters{});
  const double a = 1.0;
  const Eigen::Vector3d step = Eigen::Vector3d::Ones().normalized() * (std::sqrt(3.0) * a + 0.8 * a);
  // One node of each strut pair: the corner of the face towards +-(1,1,1).
  auto face = [&](int offset, double sign) {
    std::array<int, 3> f{};
    for (int pair = 0; pair < 3; ++pair) {
      double best = -1e300;
      for (int k = 0; k < 4; ++k) {
        const int i = 4 * pair + k;
        const double score = sign * block.positions.col(i).sum();
        if (score > best) best = score, f[pair] = offset + i;
      }
    }
    return f;
  };
  for (int b = 0; b < blocks; ++b) {
    const int offset = s.num_nodes();
    for (int i = 0; i < block.num_nodes(); ++i) s.add_node(block.positions.col(i) + b * step);
    for (const auto& e : block.elements) s.add_element(e.a + offset, e.b + offset, e.kind);
    if (b > 0) add_face_link(s, face(offset - block.num_nodes(), +1.0), face(offset, -1.0));
  }
  return s;
}

namespace {

// Centre distance of grid neighbours in units of the half-length: the nearest
// nodes of neighbours are then about half a strut length apart.
constexpr double kGridSpacing = 2.5;

// The k shortest node pairs between blocks starting at offsets a and b
// (`nodes` nodes each), shortest first, ties by index.
std::vector<std::pair<int, int>> shortest_pairs(const Structure& s, int a, int b, int nodes, int k) {
  std::vector<std::tuple<double, int, int>> pairs;
  for (int i = 0; i < nodes; ++i)
    for (int j = 0; j < nodes; ++j)
      pairs.emplace_back((s.positions.col(a + i) - s.positions.col(b + j)).norm(), a + i, b + j);
  std::sort(pairs.begin(), pairs.end());
  std::vector<std::pair<int, int>> out;
  for (int n = 0; n < k && n < static_cast<int>(pairs.size()); ++n)
    out.emplace_back(std::get<1>(pairs[n]), std::get<2>(pairs[n]));
  return out;
}

}  // namespace

Structure octahedron_grid(const OctahedronGridParameters& p) {
  Structure s;
  s.name = "octahedron-grid-" + std::to_string(p.rows) + "x" + std::to_string(p.cols);
  const Structure block = make_expandable_octahedron(OctahedronParameters{});
  const int nodes = block.num_nodes();
  const double spacing = kGridSpacing * OctahedronParameters{}.half_length;
  for (int r = 0; r < p.rows; ++r)
    for (int c = 0; c < p.cols; ++c) {
      const int offset = s.num_nodes();
      for (int i = 0; i < nodes; ++i) s.add_node(block.positions.col(i) + Eigen::Vector3d(c * spacing, r * spacing, 0.0));
      for (const auto& e : block.elements) s.add_element(e.a + offset, e.b + offset, e.kind);
    }
  const auto offset_of = [&](int r, int c) { return (r * p.cols + c) * nodes; };
  for (int r = 0; r < p.rows; ++r)
    for (int c = 0; c < p.cols; ++c) {
      if (c + 1 < p.cols)
        for (const auto& [a, b] : shortest_pairs(s, offset_of(r, c), offset_of(r, c + 1), nodes, p.cables_per_join))
          s.add_element(a, b, ElementKind::Cable);
      if (r + 1 < p.rows)
        for (const auto& [a, b] : shortest_pairs(s, offset_of(r, c), offset_of(r + 1, c), nodes, p.cables_per_join))
          s.add_element(a, b, ElementKind::Cable);
    }
  return s;
}

}  // namespace tensegrity::scenes
