#pragma once
// The tensegrity structure: nodes (position in m, fixed flag, lumped mass in kg),
// elements (two node indices, strut or cable, optional mass in kg lumped half to
// each end) and a gravity vector (m/s^2; all zero means no gravity terms).
// Sign convention (docs/FORMATS.md): an element force sigma > 0 is tension.
#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace tensegrity {

enum class ElementKind { Strut, Cable };

struct Element {
  int a = 0;                      // first node index
  int b = 0;                      // second node index
  ElementKind kind = ElementKind::Cable;
  double mass = 0.0;              // kg, lumped half to each end node
};

struct Structure {
  std::string name;
  Eigen::Matrix3Xd positions;     // 3 x n, metres
  std::vector<bool> fixed;        // n, contact nodes (bilateral supports)
  Eigen::VectorXd node_mass;      // n, the node's own mass in kg
  std::vector<Element> elements;
  Eigen::Vector3d gravity = Eigen::Vector3d::Zero();

  // Fields of the scene file that the model does not interpret (block ids,
  // names, materials...), kept so that they survive a read/write round trip.
  nlohmann::json extra = nlohmann::json::object();
  std::vector<nlohmann::json> node_extra;     // n objects
  std::vector<nlohmann::json> element_extra;  // m objects

  int num_nodes() const { return static_cast<int>(positions.cols()); }
  int num_elements() const { return static_cast<int>(elements.size()); }
  int num_free_nodes() const;
  bool has_gravity() const { return gravity.squaredNorm() > 0.0; }

  // Own mass plus half of every touching element's mass (kg), per node.
  Eigen::VectorXd lumped_mass() const;
  // Gravity load m_i * g on every node, 3 x n (N). Zero without gravity.
  Eigen::Matrix3Xd gravity_loads() const;
  // The largest gravity load |m_i g| on a free node (N); 0 without gravity.
  double max_free_node_weight() const;
  // Mean element length (m): the length scale used for relative tolerances.
  double mean_element_length() const;

  // Appends a node / element; convenience for generators and tests.
  int add_node(const Eigen::Vector3d& x, bool is_fixed = false, double mass = 0.0);
  int add_element(int a, int b, ElementKind kind, double mass = 0.0);
};

const char* to_string(ElementKind kind);

// Throws InputError(source, item, reason) when the structure breaks a rule of
// docs/FORMATS.md: indices, self-loops, zero length, duplicates, masses, finiteness,
// no elements, no free node.
void validate(const Structure& s, const std::string& source);

}  // namespace tensegrity
