#include "model/structure.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <utility>

#include "model/errors.hpp"

namespace tensegrity {

namespace {

// Generators may fill `positions` directly and leave the per-node vectors
// short; missing entries mean "free" and "massless".
bool node_is_fixed(const Structure& s, int i) {
  return i < static_cast<int>(s.fixed.size()) && s.fixed[i];
}

double node_own_mass(const Structure& s, int i) {
  return i < s.node_mass.size() ? s.node_mass[i] : 0.0;
}

std::string element_item(int e) { return "elements[" + std::to_string(e) + "]"; }
std::string node_item(int i) { return "nodes[" + std::to_string(i) + "]"; }

std::string format_number(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.6g", v);
  return buffer;
}

}  // namespace

int Structure::num_free_nodes() const {
  int count = 0;
  for (int i = 0; i < num_nodes(); ++i) count += node_is_fixed(*this, i) ? 0 : 1;
  return count;
}

Eigen::VectorXd Structure::lumped_mass() const {
  Eigen::VectorXd m(num_nodes());
  for (int i = 0; i < num_nodes(); ++i) m[i] = node_own_mass(*this, i);
  for (const Element& e : elements) {
    m[e.a] += 0.5 * e.mass;
    m[e.b] += 0.5 * e.mass;
  }
  return m;
}

Eigen::Matrix3Xd Structure::gravity_loads() const {
  Eigen::Matrix3Xd loads = Eigen::Matrix3Xd::Zero(3, num_nodes());
  if (!has_gravity()) return loads;
  const Eigen::VectorXd m = lumped_mass();
  for (int i = 0; i < num_nodes(); ++i) loads.col(i) = m[i] * gravity;
  return loads;
}

double Structure::max_free_node_weight() const {
  if (!has_gravity()) return 0.0;
  const Eigen::Matrix3Xd loads = gravity_loads();
  double worst = 0.0;
  for (int i = 0; i < num_nodes(); ++i)
    if (!fixed[i]) worst = std::max(worst, loads.col(i).norm());
  return worst;
}

double Structure::mean_element_length() const {
  if (elements.empty()) return 0.0;
  double total = 0.0;
  for (const Element& e : elements) total += (positions.col(e.b) - positions.col(e.a)).norm();
  return total / static_cast<double>(elements.size());
}

int Structure::add_node(const Eigen::Vector3d& x, bool is_fixed, double mass) {
  const int n = num_nodes();
  // Bring the per-node vectors to full length first, in case a caller filled
  // `positions` directly.
  fixed.resize(n, false);
  const Eigen::Index old_mass_size = node_mass.size();
  node_mass.conservativeResize(n + 1);
  for (Eigen::Index i = std::min<Eigen::Index>(old_mass_size, n); i < n; ++i) node_mass[i] = 0.0;
  node_extra.resize(n, nlohmann::json::object());

  positions.conservativeResize(3, n + 1);
  positions.col(n) = x;
  fixed.push_back(is_fixed);
  node_mass[n] = mass;
  node_extra.push_back(nlohmann::json::object());
  return n;
}

int Structure::add_element(int a, int b, ElementKind kind, double mass) {
  element_extra.resize(elements.size(), nlohmann::json::object());
  elements.push_back(Element{a, b, kind, mass});
  element_extra.push_back(nlohmann::json::object());
  return num_elements() - 1;
}

const char* to_string(ElementKind kind) {
  switch (kind) {
    case ElementKind::Strut: return "strut";
    case ElementKind::Cable: return "cable";
  }
  return "unknown";
}

void validate(const Structure& s, const std::string& source) {
  const int n = s.num_nodes();
  if (static_cast<int>(s.fixed.size()) != n)
    throw InputError(source, "nodes", "internal: " + std::to_string(s.fixed.size()) +
                                          " fixed flags for " + std::to_string(n) + " nodes");
  if (s.node_mass.size() != n)
    throw InputError(source, "nodes", "internal: " + std::to_string(s.node_mass.size()) +
                                          " masses for " + std::to_string(n) + " nodes");
  for (int i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k)
      if (!std::isfinite(s.positions(k, i)))
        throw InputError(source, node_item(i) + ".x[" + std::to_string(k) + "]",
                         "position is not a finite number");
    if (!std::isfinite(s.node_mass[i]) || s.node_mass[i] < 0.0)
      throw InputError(source, node_item(i) + ".mass",
                       "mass must be a finite number >= 0 kg, got " + format_number(s.node_mass[i]));
  }
  for (int k = 0; k < 3; ++k)
    if (!std::isfinite(s.gravity[k]))
      throw InputError(source, "gravity[" + std::to_string(k) + "]", "gravity is not a finite number");

  if (s.elements.empty()) throw InputError(source, "elements", "the scene has no elements");

  std::map<std::pair<int, int>, int> first_element_of_pair;
  for (int e = 0; e < s.num_elements(); ++e) {
    const Element& el = s.elements[e];
    const int ends[2] = {el.a, el.b};
    for (int k = 0; k < 2; ++k)
      if (ends[k] < 0 || ends[k] >= n)
        throw InputError(source, element_item(e) + ".nodes[" + std::to_string(k) + "]",
                         "node index " + std::to_string(ends[k]) + " is out of range (the scene has " +
                             std::to_string(n) + " nodes, indices 0.." + std::to_string(n - 1) + ")");
    if (el.kind != ElementKind::Strut && el.kind != ElementKind::Cable)
      throw InputError(source, element_item(e) + ".kind", "unknown element kind");
    if (el.a == el.b)
      throw InputError(source, element_item(e) + ".nodes",
                       "element joins node " + std::to_string(el.a) + " to itself");
    // Zero length is judged against the size of the coordinates so that a
    // coincident pair with rounding noise is caught too, whatever the units.
    const double length = (s.positions.col(el.b) - s.positions.col(el.a)).norm();
    const double size = std::max(s.positions.col(el.a).cwiseAbs().maxCoeff(),
                                 s.positions.col(el.b).cwiseAbs().maxCoeff());
    if (!(length > 1e-12 * size))
      throw InputError(source, element_item(e),
                       "zero-length element: nodes " + std::to_string(el.a) + " and " +
                           std::to_string(el.b) + " are at the same position");
    const auto key = std::minmax(el.a, el.b);
    const auto [it, inserted] = first_element_of_pair.emplace(std::pair<int, int>(key.first, key.second), e);
    if (!inserted)
      throw InputError(source, element_item(e) + ".nodes",
                       "nodes " + std::to_string(el.a) + " and " + std::to_string(el.b) +
                           " are already joined by " + element_item(it->second));
    if (!std::isfinite(el.mass) || el.mass < 0.0)
      throw InputError(source, element_item(e) + ".mass",
                       "mass must be a finite number >= 0 kg, got " + format_number(el.mass));
  }
  if (s.num_free_nodes() == 0)
    throw InputError(source, "nodes", "every node is fixed: the scene has no free node");
}

}  // namespace tensegrity
