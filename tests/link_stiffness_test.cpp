// Link mechanics: the rotational stiffness of two blocks joined by a link
// (simulation/link_stiffness.hpp) against an analytic case, its frame
// invariance, and the paper's claim (section 4) that the face link is about
// isotropic while the edge link is a hinge, measured on form-found pairs (our
// links measure the other way round).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>

#include "model/blocks.hpp"
#include "simulation/link_stiffness.hpp"
#include "simulation/link_suggestion.hpp"

namespace tensegrity {
namespace {

const std::string kBlockDir = std::string(TENSEGRITY_SOURCE_DIR) + "/data/blocks";

// Block A: three nodes on the unit circle at z = 0; block B: the same at
// z = h; three vertical cables of tension T and axial stiffness EA / h. B's
// rotation about x or y stretches the cables (k sum y_i^2 = 1.5 EA r^2 / h),
// about z only swings them (geometric stiffness T/h per node: 3 T r^2 / h).
TEST(LinkStiffness, ThreeVerticalCablesAnalytic) {
  const double h = 1.0, ea = 20.0, tension = 2.0;
  Structure s;
  for (int side = 0; side < 2; ++side)
    for (int k = 0; k < 3; ++k) {
      const double t = 2.0 * M_PI * k / 3.0;
      s.add_node({std::cos(t), std::sin(t), side * h});
    }
  for (int k = 0; k < 3; ++k) s.add_element(k, 3 + k, ElementKind::Cable);
  const Eigen::VectorXd forces = Eigen::VectorXd::Constant(3, tension);
  LinkStiffnessOptions o;
  o.cable_ea = ea;
  const LinkStiffness k = relative_rotation_stiffness(s, s.positions, forces, {0, 1, 2}, {3, 4, 5}, o);
  EXPECT_NEAR(k.rotation(0, 0), 1.5 * ea / h, 1e-9);
  EXPECT_NEAR(k.rotation(1, 1), 1.5 * ea / h, 1e-9);
  EXPECT_NEAR(k.rotation(2, 2), 3.0 * tension / h, 1e-9);
  EXPECT_NEAR(k.rotation(0, 1), 0.0, 1e-9);
  EXPECT_NEAR(k.anisotropy, (1.5 * ea) / (3.0 * tension), 1e-9);
  EXPECT_NEAR(k.about(Eigen::Vector3d(1, 0, 1)), 0.5 * (1.5 * ea / h + 3.0 * tension / h), 1e-9);
}

// Rotating the whole configuration rotates the stiffness: S' = R S R^T.
TEST(LinkStiffness, FrameInvariant) {
  Structure s;
  const Block ico = make_icosahedron_block();
  s = ico.structure;
  // Two halves of one block as "blocks": every node but two is in A or B.
  std::vector<int> a, b;
  for (int i = 0; i < s.num_nodes(); ++i) (s.positions(0, i) < -0.1 ? a : b).push_back(i);
  const LinkStiffness k0 = relative_rotation_stiffness(s, s.positions, ico.forces, a, b);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.8, Eigen::Vector3d(1, -2, 0.5).normalized()).toRotationMatrix();
  const Eigen::Matrix3Xd x = R * s.positions;
  const LinkStiffness k1 = relative_rotation_stiffness(s, x, ico.forces, a, b);
  EXPECT_LE((k1.rotation - R * k0.rotation * R.transpose()).norm(), 1e-8 * k0.rotation.norm());
  EXPECT_GT(k0.rotation.norm(), 0.0);
}

nlohmann::json pair_character(const std::string& type, double spacing) {
  return {{"format", "tensegrity-character"},
          {"version", 1},
          {"name", "pair"},
          {"blocks",
           {{{"id", "a"}, {"type", type}, {"scale", 0.05}, {"translation", {0.0, 0.0, 0.0}}},
            {{"id", "b"}, {"type", type}, {"scale", 0.05}, {"translation", {spacing, 0.0, 0.0}}}}}};
}

struct Measured {
  LinkCandidate face, edge;
};

Measured measure_pair(const std::string& type, double spacing) {
  const BlockLibrary lib = BlockLibrary::load(kBlockDir);
  LinkRequest stiff;
  stiff.stiff = true;
  LinkSuggestionOptions o;
  o.faces_per_block = 1;
  o.cables_per_block = 1;
  const auto ranked = suggest_links(pair_character(type, spacing), "pair", lib, "a", "b", stiff, o);
  Measured m;
  for (const auto& c : ranked) (c.type == "face" ? m.face : m.edge) = c;
  for (const auto* c : {&m.face, &m.edge}) {
    const auto& p = c->stiffness.principal;
    std::printf("%-20s %-4s link %-10s k = %10.5g %10.5g %10.5g N m/rad  anisotropy %7.2f\n", type.c_str(),
                c->type.c_str(), c->status.c_str(), p[0], p[1], p[2], c->stiffness.anisotropy);
  }
  return m;
}

// The paper (section 4) calls the face link about isotropic and the edge link
// a hinge. Our links measure the other way round: the face link (one strut on
// the line through the two face centroids, tied by a zigzag of six cables) is
// by far the more anisotropic (icosahedra 12.8 against 3.7, triplexes 768
// against 4.7, cable EA 20 N, mean cable force 1 N). The test asserts what we
// measure; docs/CLAIMS.md row 8 discusses it.
TEST(LinkStiffness, EdgeLinkIsMoreIsotropicThanFaceLink) {
  for (const auto& [type, spacing] : {std::pair<std::string, double>{"icosahedron", 0.16},
                                      std::pair<std::string, double>{"prism-3", 0.16}}) {
    SCOPED_TRACE(type);
    const Measured m = measure_pair(type, spacing);
    ASSERT_TRUE(m.face.measured) << m.face.status;
    ASSERT_TRUE(m.edge.measured) << m.edge.status;
    EXPECT_GT(m.face.stiffness.anisotropy, 2.0 * m.edge.stiffness.anisotropy);
    EXPECT_GT(m.edge.stiffness.anisotropy, 1.5);  // neither is a spherical joint
    const Eigen::Vector3d soft = m.face.stiffness.principal_axes.col(0);
    std::printf("%s face link: softest rotation axis (%.3f %.3f %.3f)\n", type.c_str(), soft.x(), soft.y(), soft.z());
  }
}

}  // namespace
}  // namespace tensegrity
