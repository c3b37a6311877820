// Connected parts (formulations/components.hpp), the free-node map and the
// project's force-scale convention (formulations/force_scale.hpp).
#include "formulations/components.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "formulations/force_scale.hpp"
#include "formulations/free_nodes.hpp"
#include "model/reference_scenes.hpp"

namespace tensegrity {
namespace {

// Appends `other` to `s`, shifted by `offset`.
void append(Structure& s, const Structure& other, const Eigen::Vector3d& offset) {
  const int base = s.num_nodes();
  for (int i = 0; i < other.num_nodes(); ++i)
    s.add_node(other.positions.col(i) + offset, other.fixed[i], other.node_mass[i]);
  for (const Element& e : other.elements) s.add_element(base + e.a, base + e.b, e.kind, e.mass);
}

// Every local item of a part is the scene item it maps to.
void expect_consistent(const Structure& scene, const Part& part) {
  const Structure& p = part.structure;
  ASSERT_EQ(static_cast<int>(part.nodes.size()), p.num_nodes());
  ASSERT_EQ(static_cast<int>(part.elements.size()), p.num_elements());
  ASSERT_EQ(static_cast<int>(p.fixed.size()), p.num_nodes());
  ASSERT_EQ(p.node_mass.size(), p.num_nodes());
  EXPECT_EQ(static_cast<int>(p.node_extra.size()), p.num_nodes());
  EXPECT_EQ(static_cast<int>(p.element_extra.size()), p.num_elements());
  EXPECT_EQ(p.name, scene.name);
  EXPECT_EQ(p.gravity, scene.gravity);
  for (int i = 0; i < p.num_nodes(); ++i) {
    const int g = part.nodes[i];
    EXPECT_EQ(p.positions.col(i), scene.positions.col(g));
    EXPECT_EQ(p.fixed[i], scene.fixed[g]);
    EXPECT_EQ(p.node_mass[i], scene.node_mass[g]);
    EXPECT_EQ(p.node_extra[i], scene.node_extra[g]);
  }
  for (int e = 0; e < p.num_elements(); ++e) {
    const Element& local = p.elements[e];
    const Element& global = scene.elements[part.elements[e]];
    EXPECT_EQ(part.nodes[local.a], global.a);
    EXPECT_EQ(part.nodes[local.b], global.b);
    EXPECT_EQ(local.kind, global.kind);
    EXPECT_EQ(local.mass, global.mass);
    EXPECT_EQ(p.element_extra[e], scene.element_extra[part.elements[e]]);
  }
  EXPECT_NO_THROW(validate(p, "part"));
}

TEST(Components, TwoDisjointPrismsGiveTwoParts) {
  PrismParameters three;
  three.n = 3;
  three.strut_mass = 0.1;
  PrismParameters five;
  five.n = 5;
  five.cable_mass = 0.02;
  Structure scene;
  scene.name = "two prisms";
  scene.gravity = Eigen::Vector3d(0.0, 0.0, -9.81);
  append(scene, make_regular_prism(three), Eigen::Vector3d::Zero());
  append(scene, make_regular_prism(five), Eigen::Vector3d(5.0, 0.0, 0.0));
  scene.node_extra[7]["label"] = "marked";
  scene.element_extra[12]["material"] = "steel";
  scene.node_mass[8] = 0.25;
  validate(scene, "scene");

  const Partition partition = split_into_parts(scene);
  ASSERT_EQ(partition.parts.size(), 2u);
  EXPECT_TRUE(partition.unattached_elements.empty());
  EXPECT_TRUE(partition.isolated_nodes.empty());
  // Ordered by lowest scene node; scene order kept inside a part.
  const Part& first = partition.parts[0];
  const Part& second = partition.parts[1];
  ASSERT_EQ(first.nodes.size(), 6u);
  ASSERT_EQ(second.nodes.size(), 10u);
  ASSERT_EQ(first.elements.size(), 12u);
  ASSERT_EQ(second.elements.size(), 20u);
  for (int i = 0; i < 6; ++i) EXPECT_EQ(first.nodes[i], i);
  for (int i = 0; i < 10; ++i) EXPECT_EQ(second.nodes[i], 6 + i);
  for (int e = 0; e < 12; ++e) EXPECT_EQ(first.elements[e], e);
  for (int e = 0; e < 20; ++e) EXPECT_EQ(second.elements[e], 12 + e);
  expect_consistent(scene, first);
  expect_consistent(scene, second);
  EXPECT_EQ(second.structure.node_extra[1]["label"], "marked");
  EXPECT_EQ(second.structure.element_extra[0]["material"], "steel");
  EXPECT_EQ(second.structure.node_mass[2], 0.25);
  // Lumped masses survive the split: the part sees the scene's element masses.
  const Eigen::VectorXd scene_mass = scene.lumped_mass();
  const Eigen::VectorXd part_mass = second.structure.lumped_mass();
  for (int i = 0; i < 10; ++i) EXPECT_DOUBLE_EQ(part_mass[i], scene_mass[6 + i]);
}

TEST(Components, SharedFixedNodeIsCopiedAndFixedPairIsUnattached) {
  Structure s;
  s.name = "shared support";
  const int support = s.add_node({0.0, 0.0, 0.0}, true);
  const int left = s.add_node({-1.0, 0.0, 1.0}, false, 0.1);
  const int other_support = s.add_node({2.0, 0.0, 0.0}, true);
  const int right = s.add_node({1.0, 0.0, 1.0}, false, 0.2);
  const int lonely = s.add_node({0.0, 3.0, 1.0}, false);
  s.add_element(support, left, ElementKind::Strut);           // 0: part of `left`
  s.add_element(support, other_support, ElementKind::Cable);  // 1: both fixed
  s.add_element(right, support, ElementKind::Cable);          // 2: part of `right`
  s.add_element(other_support, right, ElementKind::Strut);    // 3: part of `right`
  validate(s, "scene");

  const Partition partition = split_into_parts(s);
  ASSERT_EQ(partition.parts.size(), 2u);
  ASSERT_EQ(partition.unattached_elements, std::vector<int>{1});
  EXPECT_EQ(partition.isolated_nodes, std::vector<int>{lonely});

  const Part& a = partition.parts[0];
  EXPECT_EQ(a.nodes, (std::vector<int>{support, left}));
  EXPECT_EQ(a.elements, std::vector<int>{0});
  const Part& b = partition.parts[1];
  EXPECT_EQ(b.nodes, (std::vector<int>{support, other_support, right}));
  EXPECT_EQ(b.elements, (std::vector<int>{2, 3}));
  expect_consistent(s, a);
  expect_consistent(s, b);
  EXPECT_TRUE(a.structure.fixed[0]);
  EXPECT_TRUE(b.structure.fixed[0]);
  EXPECT_EQ(b.structure.num_free_nodes(), 1);
  // Local numbering inside part b: element 2 joins right (local 2) to support (local 0).
  EXPECT_EQ(b.structure.elements[0].a, 2);
  EXPECT_EQ(b.structure.elements[0].b, 0);
}

TEST(Components, FixedNodesDoNotJoinParts) {
  // Two prisms with fixed bottoms standing on the same ground nodes: the
  // fixed nodes are constants, so the tops are independent problems.
  PrismParameters p;
  p.n = 4;
  p.fix_bottom = true;
  Structure s = make_regular_prism(p);
  const int base = s.num_nodes();
  for (int k = 0; k < 4; ++k) s.add_node(s.positions.col(4 + k) + Eigen::Vector3d(0, 0, 2.0));
  for (int k = 0; k < 4; ++k) s.add_element(k, base + (k + 1) % 4, ElementKind::Strut);
  for (int k = 0; k < 4; ++k) s.add_element(base + k, base + (k + 1) % 4, ElementKind::Cable);
  validate(s, "scene");
  const Partition partition = split_into_parts(s);
  ASSERT_EQ(partition.parts.size(), 2u);
  EXPECT_EQ(partition.unattached_elements.size(), 4u);  // the bottom ring
  for (const Part& part : partition.parts) {
    expect_consistent(s, part);
    EXPECT_EQ(part.structure.num_free_nodes(), 4);
    EXPECT_EQ(part.structure.num_nodes(), 8);
  }
}

TEST(FreeNodes, GatherScatterRoundTrip) {
  PrismParameters p;
  p.n = 3;
  p.fix_bottom = true;
  const Structure s = make_regular_prism(p);
  const FreeNodeMap map(s);
  EXPECT_EQ(map.num_nodes(), 6);
  EXPECT_EQ(map.num_free(), 3);
  EXPECT_EQ(map.free_nodes(), (std::vector<int>{3, 4, 5}));
  const Eigen::VectorXd q = map.gather(s.positions);
  ASSERT_EQ(q.size(), 9);
  EXPECT_EQ(q.segment<3>(3), s.positions.col(4));
  Eigen::Matrix3Xd x = Eigen::Matrix3Xd::Zero(3, 6);
  map.scatter(q, x);
  EXPECT_EQ(x.rightCols(3), s.positions.rightCols(3));
  EXPECT_EQ(x.leftCols(3).norm(), 0.0);
}

TEST(ForceScale, ReferenceForceIsTheFreeWeightWithGravity) {
  PrismParameters p;
  p.n = 4;
  p.gravity = true;
  p.fix_bottom = true;
  p.strut_mass = 0.1;
  p.cable_mass = 0.02;
  Structure s = make_regular_prism(p);
  s.node_mass[5] = 0.3;  // a top node
  s.node_mass[0] = 7.0;  // a fixed node: its weight goes to the support
  // Top node: half a strut, half a vertical, half of two top-ring cables.
  const double free_mass = 4 * (0.05 + 0.01 + 0.02) + 0.3;
  const ForceScale scale = make_force_scale(s, 2e-3);
  EXPECT_NEAR(scale.reference_force, 9.81 * free_mass, 1e-13);
  EXPECT_NEAR(scale.margin, 2e-3 * 9.81 * free_mass, 1e-15);
  EXPECT_EQ(scale.num_cables, 12);
  // Under gravity the load sets the scale: no equality, an upper bound for Eq. 5.
  EXPECT_FALSE(scale.has_normalisation());
  EXPECT_TRUE(scale.has_prestress_cap());
  EXPECT_NEAR(scale.prestress_cap, kDefaultPrestressFactor * 12 * 9.81 * free_mass, 1e-9);

  const double inf = std::numeric_limits<double>::infinity();
  for (int e = 0; e < s.num_elements(); ++e) {
    if (s.elements[e].kind == ElementKind::Cable) {
      EXPECT_EQ(scale.lower[e], scale.margin);
      EXPECT_EQ(scale.upper[e], inf);
      EXPECT_EQ(scale.normalisation_row[e], 1.0);
    } else {
      EXPECT_EQ(scale.lower[e], -inf);
      EXPECT_EQ(scale.upper[e], -scale.margin);
      EXPECT_EQ(scale.normalisation_row[e], 0.0);
    }
  }
  const Eigen::VectorXd sigma = reference_forces(s, scale);
  EXPECT_LE(scale.normalisation_row.dot(sigma), scale.prestress_cap);
  for (int e = 0; e < s.num_elements(); ++e) {
    EXPECT_GE(sigma[e], scale.lower[e]);
    EXPECT_LE(sigma[e], scale.upper[e]);
    EXPECT_EQ(std::abs(sigma[e]), scale.reference_force);
  }
}

TEST(ForceScale, OneNewtonWithoutGravityOrWithoutMass) {
  PrismParameters p;
  p.n = 3;
  p.strut_mass = 0.5;  // mass but no gravity
  const ForceScale no_gravity = make_force_scale(make_regular_prism(p));
  EXPECT_EQ(no_gravity.reference_force, 1.0);
  EXPECT_EQ(no_gravity.margin, 1e-3);
  EXPECT_EQ(no_gravity.num_cables, 9);
  EXPECT_EQ(no_gravity.normalisation_target, 9.0);

  PrismParameters massless;
  massless.n = 3;
  massless.gravity = true;
  const ForceScale weightless = make_force_scale(make_regular_prism(massless));
  EXPECT_EQ(weightless.reference_force, 1.0);
  EXPECT_TRUE(weightless.has_normalisation());  // no load: forces only up to a factor
  EXPECT_EQ(weightless.normalisation_target, 9.0);

  // Only struts: no normalisation row.
  Structure struts;
  struts.add_node({0, 0, 0}, true);
  struts.add_node({0, 0, 1});
  struts.add_element(0, 1, ElementKind::Strut);
  const ForceScale only_struts = make_force_scale(struts);
  EXPECT_FALSE(only_struts.has_normalisation());
  EXPECT_EQ(only_struts.normalisation_target, 0.0);
  EXPECT_EQ(reference_forces(struts, only_struts)[0], -1.0);
}

}  // namespace
}  // namespace tensegrity
