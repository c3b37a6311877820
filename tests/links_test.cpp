// Face and edge links: the elements each adds, where the face link's strut
// goes, and that a linked pair of blocks form-finds into a valid tensegrity.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <set>

#include "model/blocks.hpp"
#include "model/links.hpp"
#include "model/verify.hpp"

namespace tensegrity {
namespace {

struct Counts {
  int nodes = 0, struts = 0, cables = 0;
};
Counts count(const Structure& s) {
  Counts c;
  c.nodes = s.num_nodes();
  for (const auto& e : s.elements) (e.kind == ElementKind::Strut ? c.struts : c.cables)++;
  return c;
}

// Two blocks side by side along x, the second rotated half a turn so that
// facing faces are roughly parallel.
Structure two_blocks(const Block& b, double gap, std::vector<int>* second_offset = nullptr) {
  Structure s;
  BlockTransform t;
  t.scale = 0.1;
  for (int k = 0; k < 2; ++k) {
    t.translation = Eigen::Vector3d(k * gap, 0.0, 0.0);
    t.rotation = k == 0 ? Eigen::Matrix3d::Identity()
                        : Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    const Eigen::Matrix3Xd x = instance_positions(b, t);
    const int base = s.num_nodes();
    if (second_offset) second_offset->push_back(base);
    for (int i = 0; i < x.cols(); ++i) s.add_node(x.col(i));
    for (const auto& e : b.structure.elements) s.add_element(base + e.a, base + e.b, e.kind);
  }
  return s;
}

TEST(FaceLink, AddsOneStrutTwelveCablesAndPassesThroughBothFaces) {
  const Block ico = make_icosahedron_block();
  std::vector<int> base;
  Structure s = two_blocks(ico, 0.3, &base);
  const Counts before = count(s);
  // Face x+y+z+ of the first block (pointing partly to +x), and of the
  // second (turned half a turn about z, it points partly to -x).
  const auto& f = ico.faces.at("x+y+z+");
  const auto& g = ico.faces.at("x+y-z+");
  const std::array<int, 3> fa = {base[0] + f[0], base[0] + f[1], base[0] + f[2]};
  const std::array<int, 3> fb = {base[1] + g[0], base[1] + g[1], base[1] + g[2]};
  const LinkAddition add = add_face_link(s, fa, fb);
  const Counts after = count(s);
  EXPECT_EQ(after.struts - before.struts, 1);
  EXPECT_EQ(after.cables - before.cables, 12);
  EXPECT_EQ(after.nodes - before.nodes, 2);
  EXPECT_EQ(add.elements.size(), 13u);
  EXPECT_EQ(add.removed_elements, 0);

  // The strut is the first added element; it crosses both triangles.
  const Element& strut = s.elements[add.elements[0]];
  ASSERT_EQ(strut.kind, ElementKind::Strut);
  const Eigen::Vector3d p = s.positions.col(strut.a), q = s.positions.col(strut.b);
  EXPECT_TRUE(segment_crosses_triangle(p, q, s.positions.col(fa[0]), s.positions.col(fa[1]), s.positions.col(fa[2])));
  EXPECT_TRUE(segment_crosses_triangle(p, q, s.positions.col(fb[0]), s.positions.col(fb[1]), s.positions.col(fb[2])));
  // A segment beside the faces does not (the test is not vacuous).
  const Eigen::Vector3d off(0.0, 0.0, 1.0);
  EXPECT_FALSE(segment_crosses_triangle(p + off, q + off, s.positions.col(fa[0]), s.positions.col(fa[1]),
                                        s.positions.col(fa[2])));

  // Each strut end: exactly three cables, to its own face's corners. Each face
  // corner: two cables to the other face.
  std::map<int, std::set<int>> cable_ends;
  for (size_t k = 1; k < add.elements.size(); ++k) {
    const Element& e = s.elements[add.elements[k]];
    ASSERT_EQ(e.kind, ElementKind::Cable);
    cable_ends[e.a].insert(e.b);
    cable_ends[e.b].insert(e.a);
  }
  EXPECT_EQ(cable_ends[strut.a], std::set<int>(fa.begin(), fa.end()));
  EXPECT_EQ(cable_ends[strut.b], std::set<int>(fb.begin(), fb.end()));
  for (int i : fa) {
    std::set<int> across;
    for (int j : cable_ends[i]) across.insert(j);
    across.erase(strut.a);
    EXPECT_EQ(across.size(), 2u);
    for (int j : across) EXPECT_TRUE(std::find(fb.begin(), fb.end(), j) != fb.end());
  }
  validate(s, "face link");
}

TEST(EdgeLink, AddsFourStrutsThirtyEightCablesAndRemovesTwo) {
  const Block prism = make_prism_block(4);
  std::vector<int> base;
  Structure s = two_blocks(prism, 3.0 * 0.1, &base);
  const Counts before = count(s);
  // A vertical cable of each block, on the sides facing each other.
  const int m_block = prism.structure.num_elements();
  int ca = -1, cb = -1;
  double best_a = -1e300, best_b = 1e300;
  for (int e = 0; e < m_block; ++e) {
    if (prism.structure.elements[e].kind != ElementKind::Cable) continue;
    const Element& ea = s.elements[e];
    const double xa = 0.5 * (s.positions(0, ea.a) + s.positions(0, ea.b));
    if (std::abs(s.positions(2, ea.a) - s.positions(2, ea.b)) > 0.05 && xa > best_a) best_a = xa, ca = e;
    const Element& eb = s.elements[m_block + e];
    const double xb = 0.5 * (s.positions(0, eb.a) + s.positions(0, eb.b));
    if (std::abs(s.positions(2, eb.a) - s.positions(2, eb.b)) > 0.05 && xb < best_b) best_b = xb, cb = m_block + e;
  }
  ASSERT_GE(ca, 0);
  ASSERT_GE(cb, 0);
  const std::pair<int, int> removed_a = std::minmax(s.elements[ca].a, s.elements[ca].b);
  const LinkAddition add = add_edge_link(s, ca, cb);
  const Counts after = count(s);
  EXPECT_EQ(after.struts - before.struts, 4);
  EXPECT_EQ(after.cables - before.cables, 36);  // +38 -2
  EXPECT_EQ(add.removed_elements, 2);
  int new_cables = 0, new_struts = 0;
  for (int e : add.elements) (s.elements[e].kind == ElementKind::Cable ? new_cables : new_struts)++;
  EXPECT_EQ(new_cables, 38);
  EXPECT_EQ(new_struts, 4);
  EXPECT_EQ(after.nodes - before.nodes, 8);
  EXPECT_EQ(add.merged_nodes.size(), 4u);
  // The removed cable is gone; its end nodes now carry the inserted octahedron's cables.
  for (const auto& e : s.elements) EXPECT_FALSE(std::min(e.a, e.b) == removed_a.first && std::max(e.a, e.b) == removed_a.second);
  int touching = 0;
  for (int e : add.elements)
    touching += s.elements[e].a == removed_a.first || s.elements[e].b == removed_a.first;
  EXPECT_GE(touching, 4);
  validate(s, "edge link");
}

TEST(Links, DegenerateInputIsRejected) {
  Structure s = two_blocks(make_icosahedron_block(), 0.3);
  EXPECT_THROW(add_face_link(s, {0, 1, 1}, {12, 13, 14}), std::invalid_argument);
  EXPECT_THROW(add_face_link(s, {0, 1, 2}, {0, 1, 2}), std::invalid_argument);
  EXPECT_THROW(add_edge_link(s, 0, 7), std::invalid_argument);  // element 0 is a strut
}

}  // namespace
}  // namespace tensegrity
