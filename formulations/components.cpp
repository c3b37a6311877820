#include "formulations/components.hpp"

#include <algorithm>
#include <numeric>

namespace tensegrity {
namespace {

bool node_is_fixed(const Structure& s, int i) {
  return i < static_cast<int>(s.fixed.size()) && s.fixed[i];
}

class DisjointSets {
 public:
  explicit DisjointSets(int n) : parent_(n) { std::iota(parent_.begin(), parent_.end(), 0); }
  int find(int i) {
    while (parent_[i] != i) {
      parent_[i] = parent_[parent_[i]];  // path halving
      i = parent_[i];
    }
    return i;
  }
  // The lower index becomes the root, so a root is its set's lowest node.
  void unite(int i, int j) {
    i = find(i);
    j = find(j);
    if (i == j) return;
    if (j < i) std::swap(i, j);
    parent_[j] = i;
  }

 private:
  std::vector<int> parent_;
};

}  // namespace

Partition split_into_parts(const Structure& s) {
  const int n = s.num_nodes();
  const int m = s.num_elements();
  DisjointSets sets(n);
  std::vector<bool> touched(n, false);
  for (const Element& e : s.elements) {
    touched[e.a] = touched[e.b] = true;
    if (!node_is_fixed(s, e.a) && !node_is_fixed(s, e.b)) sets.unite(e.a, e.b);
  }

  Partition partition;
  // part_of_root[root] = index into partition.parts; roots are lowest nodes,
  // so scanning nodes in order numbers parts by their lowest scene node.
  std::vector<int> part_of_root(n, -1);
  for (int i = 0; i < n; ++i) {
    if (node_is_fixed(s, i)) continue;
    if (!touched[i]) {
      partition.isolated_nodes.push_back(i);
      continue;
    }
    const int root = sets.find(i);
    if (part_of_root[root] < 0) {
      part_of_root[root] = static_cast<int>(partition.parts.size());
      partition.parts.emplace_back();
    }
  }

  auto part_of_element = [&](const Element& e) {
    const int free_end = !node_is_fixed(s, e.a) ? e.a : (!node_is_fixed(s, e.b) ? e.b : -1);
    return free_end < 0 ? -1 : part_of_root[sets.find(free_end)];
  };

  for (int e = 0; e < m; ++e) {
    const Element& el = s.elements[e];
    const int k = part_of_element(el);
    if (k < 0) {
      partition.unattached_elements.push_back(e);
      continue;
    }
    partition.parts[k].elements.push_back(e);
    // Free members and the fixed nodes the part touches; sorted below.
    partition.parts[k].nodes.push_back(el.a);
    partition.parts[k].nodes.push_back(el.b);
  }

  const bool has_node_mass = s.node_mass.size() == n;
  const bool has_node_extra = static_cast<int>(s.node_extra.size()) == n;
  const bool has_element_extra = static_cast<int>(s.element_extra.size()) == m;
  std::vector<int> local(n, -1);
  for (std::size_t k = 0; k < partition.parts.size(); ++k) {
    Part& part = partition.parts[k];
    std::sort(part.nodes.begin(), part.nodes.end());
    part.nodes.erase(std::unique(part.nodes.begin(), part.nodes.end()), part.nodes.end());

    Structure& p = part.structure;
    p.name = s.name;
    p.gravity = s.gravity;
    p.extra = s.extra;
    const int pn = static_cast<int>(part.nodes.size());
    p.positions.resize(3, pn);
    p.fixed.assign(pn, false);
    p.node_mass = Eigen::VectorXd::Zero(pn);
    if (has_node_extra) p.node_extra.reserve(pn);
    for (int li = 0; li < pn; ++li) {
      const int i = part.nodes[li];
      local[i] = li;
      p.positions.col(li) = s.positions.col(i);
      p.fixed[li] = node_is_fixed(s, i);
      if (has_node_mass) p.node_mass[li] = s.node_mass[i];
      if (has_node_extra) p.node_extra.push_back(s.node_extra[i]);
    }
    p.elements.reserve(part.elements.size());
    if (has_element_extra) p.element_extra.reserve(part.elements.size());
    for (int e : part.elements) {
      Element el = s.elements[e];
      el.a = local[el.a];
      el.b = local[el.b];
      p.elements.push_back(el);
      if (has_element_extra) p.element_extra.push_back(s.element_extra[e]);
    }
    for (int i : part.nodes) local[i] = -1;
  }
  return partition;
}

}  // namespace tensegrity
