// The block library: every template (and every prefix of its interior ties) is
// in equilibrium at its template geometry (stress QP relative residual <= 1e-10)
// and prestress stable, with the documented counts; the data
// files match the generators; instancing by a similarity keeps equilibrium.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <fstream>

#include "formulations/equilibrium.hpp"
#include "formulations/force_scale.hpp"
#include "kernels/stress_qp.hpp"
#include "model/blocks.hpp"
#include "model/errors.hpp"
#include "model/verify.hpp"
#include "simulation/stability.hpp"

namespace tensegrity {
namespace {

const std::string kBlockDir = std::string(TENSEGRITY_SOURCE_DIR) + "/data/blocks";

// Relative residual of the stress QP at the template geometry: max free-node
// net force over the reference force F0 (= 1 N here, no gravity).
double stress_qp_relative_residual(const Structure& s, Eigen::VectorXd* sigma_out = nullptr) {
  Equilibrium eq(s);
  eq.set_positions(s.positions);
  const ForceScale scale = make_force_scale(s);
  StressQp qp(eq, scale);
  const StressQpResult r = qp.solve();
  if (sigma_out) *sigma_out = r.sigma;
  return r.max_node_residual / scale.reference_force;
}

struct ExpectedCounts {
  std::string name;
  int nodes, struts, cables;
};

std::vector<ExpectedCounts> expected_counts() {
  std::vector<ExpectedCounts> out;
  for (int n = 3; n <= 12; ++n) out.push_back({"prism-" + std::to_string(n), 2 * n, n, 3 * n});
  out.push_back({"quadruplex", 8, 4, 12});
  out.push_back({"icosahedron", 12, 6, 24});
  out.push_back({"diamond", 8, 4, 16});
  out.push_back({"double-icosahedron", 21, 12, 45});
  for (int n = 3; n <= 12; ++n) out.push_back({"prism-" + std::to_string(n) + "-braced", 2 * n, n, 4 * n});
  out.push_back({"icosahedron-braced", 12, 6, 30});
  out.push_back({"double-icosahedron-braced", 21, 12, 57});
  return out;
}

TEST(Blocks, FileLibraryHoldsEveryStandardBlockWithItsCounts) {
  const BlockLibrary lib = BlockLibrary::load(kBlockDir);
  for (const auto& c : expected_counts()) {
    SCOPED_TRACE(c.name);
    ASSERT_TRUE(lib.contains(c.name));
    const Block& b = lib.get(c.name, "test", "");
    EXPECT_EQ(b.structure.num_nodes(), c.nodes);
    EXPECT_EQ(b.num_struts(), c.struts);
    EXPECT_EQ(b.num_cables(), c.cables);
    EXPECT_GE(b.faces.size(), 2u);
    EXPECT_EQ(static_cast<int>(b.cables.size()), c.cables);  // every cable is named
  }
}

TEST(Blocks, EveryTemplateIsInEquilibriumByTheStressQp) {
  const BlockLibrary lib = BlockLibrary::load(kBlockDir);
  for (const auto& name : lib.names()) {
    SCOPED_TRACE(name);
    const Block& b = lib.get(name, "test", "");
    Eigen::VectorXd sigma;
    const double rel = stress_qp_relative_residual(b.structure, &sigma);
    EXPECT_LE(rel, 1e-10);
    const Verification v = verify(b.structure, b.structure.positions, sigma, 1e-10);
    EXPECT_TRUE(v.ok) << (v.problems.empty() ? "" : v.problems.front());
    EXPECT_EQ(v.wrong_signs, 0);
  }
}

TEST(Blocks, StoredSelfStressBalancesEveryNode) {
  const BlockLibrary lib = BlockLibrary::load(kBlockDir);
  for (const auto& name : lib.names()) {
    SCOPED_TRACE(name);
    const Block& b = lib.get(name, "test", "");
    EXPECT_LE(relative_self_stress_residual(b.structure, b.structure.positions, b.forces), 1e-12);
    // Normalised to a mean cable force of 1 N.
    double sum = 0.0;
    for (int e = 0; e < b.structure.num_elements(); ++e)
      if (b.structure.elements[e].kind == ElementKind::Cable) sum += b.forces[e];
    EXPECT_NEAR(sum / b.num_cables(), 1.0, 1e-12);
  }
}

TEST(Blocks, AnalyticForceRatios) {
  // Expandable octahedron: |strut| / cable = sqrt(6), strut / cable length sqrt(8/3).
  const Block ico = make_icosahedron_block();
  EXPECT_NEAR(ico.forces[0], -std::sqrt(6.0), 1e-12);
  const auto& s = ico.structure;
  const double strut = (s.positions.col(s.elements[0].b) - s.positions.col(s.elements[0].a)).norm();
  const double cable = (s.positions.col(s.elements[6].b) - s.positions.col(s.elements[6].a)).norm();
  EXPECT_NEAR(strut / cable, std::sqrt(8.0 / 3.0), 1e-12);
  // Double icosahedron: 42 single cables of force f and 3 shared ones of 2f,
  // normalised to a mean of 1 N: f = 45/48.
  const Block dbl = make_double_icosahedron_block();
  int shared = 0;
  for (const auto& [name, e] : dbl.cables) {
    const bool is_shared = name.rfind("shared-", 0) == 0;
    shared += is_shared;
    EXPECT_NEAR(dbl.forces[e], (is_shared ? 2.0 : 1.0) * 45.0 / 48.0, 1e-12) << name;
  }
  EXPECT_EQ(shared, 3);
}

TEST(Blocks, FilesMatchTheGenerators) {
  for (const Block& g : make_standard_blocks()) {
    SCOPED_TRACE(g.name);
    const Block f = read_block_file(kBlockDir + "/" + g.name + ".block.json");
    ASSERT_EQ(f.structure.num_nodes(), g.structure.num_nodes());
    EXPECT_LE((f.structure.positions - g.structure.positions).cwiseAbs().maxCoeff(), 1e-15);
    EXPECT_LE((f.forces - g.forces).cwiseAbs().maxCoeff(), 1e-14);
    EXPECT_EQ(f.faces, g.faces);
    EXPECT_EQ(f.cables, g.cables);
    EXPECT_EQ(f.ties, g.ties);
  }
}

// Every template, with every prefix of its ties, is a tensegrity at its
// template geometry (stress QP) and prestress stable there.
TEST(Blocks, EveryTemplateAndTiePrefixIsPrestressStable) {
  const BlockLibrary lib = BlockLibrary::load(kBlockDir);
  int checked = 0;
  for (const auto& name : lib.names()) {
    const Block& b = lib.get(name, "test", "");
    for (int k = 0; k <= static_cast<int>(b.ties.size()); ++k) {
      SCOPED_TRACE(name + " with " + std::to_string(k) + " ties");
      const Structure s = with_ties(b, k);
      Eigen::VectorXd sigma;
      ASSERT_LE(stress_qp_relative_residual(s, &sigma), 1e-10);
      const Verification v = verify(s, s.positions, sigma, 1e-10);
      EXPECT_EQ(v.wrong_signs, 0);
      const PrestressReport p = prestress_stability(s, s.positions, sigma);
      EXPECT_TRUE(p.prestress_stable) << p.message;
      ++checked;
    }
  }
  EXPECT_GT(checked, 40);
}

// The braced icosahedron's symmetric force densities (header of
// model/blocks.hpp): cables 1, short pair cables (1 - 2h)/h, struts h - 2
// balance every node (half strut length 1, pair offset h).
TEST(Blocks, BracedIcosahedronSymmetricSelfStress) {
  for (double h : {0.3, 0.4, 0.45}) {
    const Block b = make_braced_icosahedron_block(h);
    const auto& s = b.structure;
    Eigen::VectorXd f(s.num_elements());
    for (int e = 0; e < s.num_elements(); ++e) {
      const auto& el = s.elements[e];
      const double l = (s.positions.col(el.b) - s.positions.col(el.a)).norm();
      const bool pair = std::abs(l - 2.0 * h) < 1e-12;
      const double q = el.kind == ElementKind::Strut ? h - 2.0 : pair ? (1.0 - 2.0 * h) / h : 1.0;
      f[e] = q * l;
    }
    EXPECT_LE(relative_self_stress_residual(s, s.positions, f), 1e-14);
    EXPECT_EQ(b.num_cables(), 30);
  }
}

TEST(Blocks, SegmentDistance) {
  EXPECT_NEAR(segment_distance({0, 0, 0}, {1, 0, 0}, {0.5, 1, 1}, {0.5, 1, -1}), 1.0, 1e-15);
  EXPECT_NEAR(segment_distance({0, 0, 0}, {1, 0, 0}, {2, 1, 0}, {3, 1, 0}), std::sqrt(2.0), 1e-15);
  EXPECT_NEAR(segment_distance({0, 0, 0}, {1, 0, 0}, {0, 2, 0}, {1, 2, 0}), 2.0, 1e-15);
}

TEST(Blocks, DiamondStrutsStayApart) {
  const Block d = make_diamond_block();
  const auto& s = d.structure;
  double closest = 1e300;
  for (int e = 0; e < 4; ++e)
    for (int f = e + 1; f < 4; ++f) {
      // Sampled distance between two strut segments (fine enough for a bound).
      for (int i = 0; i <= 200; ++i)
        for (int k = 0; k <= 200; ++k) {
          const Eigen::Vector3d p = s.positions.col(s.elements[e].a) +
                                    i / 200.0 * (s.positions.col(s.elements[e].b) - s.positions.col(s.elements[e].a));
          const Eigen::Vector3d q = s.positions.col(s.elements[f].a) +
                                    k / 200.0 * (s.positions.col(s.elements[f].b) - s.positions.col(s.elements[f].a));
          closest = std::min(closest, (p - q).norm());
        }
    }
  EXPECT_GT(closest, 0.1);  // unit radius: struts do not touch
}

TEST(Blocks, SimilarityInstancingKeepsEquilibrium) {
  const Block b = make_diamond_block();
  BlockTransform t;
  t.scale = 0.07;
  t.rotation = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  t.translation = Eigen::Vector3d(0.3, -1.0, 2.0);
  const Eigen::Matrix3Xd x = instance_positions(b, t);
  EXPECT_LE(relative_self_stress_residual(b.structure, x, b.forces), 1e-12);
  EXPECT_NEAR((x.col(1) - x.col(0)).norm(), 0.07 * (b.structure.positions.col(1) - b.structure.positions.col(0)).norm(),
              1e-15);
  // A displacement breaks it (form finding has work to do).
  t.displacements[0] = Eigen::Vector3d(0.0, 0.0, 0.3);
  EXPECT_GT(relative_self_stress_residual(b.structure, instance_positions(b, t), b.forces), 1e-3);
  EXPECT_NEAR((instance_positions(b, t).col(0) - x.col(0)).norm(), 0.07 * 0.3, 1e-14);
}

TEST(Blocks, BadBlockFileIsAnInputErrorNamingFileAndItem) {
  const std::string path = testing::TempDir() + "/bad.block.json";
  nlohmann::json j = block_to_json(make_prism_block(3));
  j["elements"][0]["force"] = 1.0;  // a strut in tension
  std::ofstream(path) << j.dump();
  try {
    read_block_file(path);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), path);
    EXPECT_EQ(e.item(), "elements[0].force");
  }
  j = block_to_json(make_prism_block(3));
  j["faces"][0]["nodes"][1] = 99;
  std::ofstream(path) << j.dump();
  EXPECT_THROW(read_block_file(path), InputError);
}

}  // namespace
}  // namespace tensegrity
