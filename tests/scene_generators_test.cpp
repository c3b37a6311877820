// The octahedron grid of scenes/towers.hpp: its counts, its joins (the
// shortest node pairs between grid neighbours), that it is far from
// equilibrium as built, and that `tensegrity generate grid` writes it.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <algorithm>
#include <set>
#include <string>
#include <utility>

#include "model/scene_io.hpp"
#include "process_runner.hpp"
#include "scenes/towers.hpp"
#include "solvers/solver.hpp"

namespace tensegrity {
namespace {

constexpr int kOctahedronNodes = 12, kOctahedronElements = 30, kOctahedronStruts = 6;

int block_of(int node) { return node / kOctahedronNodes; }

TEST(OctahedronGrid, DefaultGridHas84StrutsAnd572Elements) {
  const Structure s = scenes::octahedron_grid({});
  EXPECT_EQ(s.name, "octahedron-grid-2x7");
  EXPECT_EQ(s.num_nodes(), 14 * kOctahedronNodes);
  EXPECT_EQ(s.num_elements(), 572);
  const auto struts = std::count_if(s.elements.begin(), s.elements.end(),
                                    [](const Element& e) { return e.kind == ElementKind::Strut; });
  EXPECT_EQ(struts, 14 * kOctahedronStruts);
}

// Every join is 8 distinct cables between grid neighbours (2 x 7: 19 pairs),
// and no node pair of the two blocks is closer than the longest of them.
TEST(OctahedronGrid, JoinsAreTheShortestPairsBetweenNeighbours) {
  scenes::OctahedronGridParameters p;
  const Structure s = scenes::octahedron_grid(p);
  std::set<std::pair<int, int>> joined_blocks;
  std::set<std::pair<int, int>> join_cables;
  for (int e = 14 * kOctahedronElements; e < s.num_elements(); ++e) {
    const Element& el = s.elements[e];
    ASSERT_EQ(el.kind, ElementKind::Cable);
    const int a = block_of(el.a), b = block_of(el.b);
    ASSERT_LT(a, b);
    const bool same_row = a / p.cols == b / p.cols;
    EXPECT_TRUE((same_row && b == a + 1) || b == a + p.cols) << a << " " << b;
    joined_blocks.insert({a, b});
    EXPECT_TRUE(join_cables.insert({el.a, el.b}).second) << "a cable twice";
  }
  EXPECT_EQ(joined_blocks.size(), 19u);
  for (const auto& [a, b] : joined_blocks) {
    double longest = 0.0;
    for (int e = 14 * kOctahedronElements; e < s.num_elements(); ++e)
      if (block_of(s.elements[e].a) == a && block_of(s.elements[e].b) == b)
        longest = std::max(longest, (s.positions.col(s.elements[e].a) - s.positions.col(s.elements[e].b)).norm());
    int closer = 0;
    for (int i = 0; i < kOctahedronNodes; ++i)
      for (int j = 0; j < kOctahedronNodes; ++j)
        closer += (s.positions.col(a * kOctahedronNodes + i) - s.positions.col(b * kOctahedronNodes + j)).norm() <
                  longest;
    EXPECT_LT(closer, p.cables_per_join) << "blocks " << a << ", " << b;
  }
}

// The joining cables carry no force as built: the stress QP proves that the
// geometry is no tensegrity.
TEST(OctahedronGrid, IsFarFromEquilibriumAsBuilt) {
  const SolveResult r = solve_forces_only(scenes::octahedron_grid({}), SolveOptions{});
  EXPECT_EQ(r.status, Status::Infeasible) << r.message;
  EXPECT_GT(r.stats.relative_residual, 1e-4);
}

TEST(OctahedronGrid, GenerateGridWritesIt) {
  testing::ScratchDir dir("generate-grid");
  const std::string file = dir.file("grid.scene.json");
  const auto r = dir.run({"generate", "grid", "--rows", "3", "--cols", "2", "--cables-per-join", "5", "--out", file});
  ASSERT_EQ(r.exit_status, 0) << r.err;
  const Structure written = read_scene_file(file);
  scenes::OctahedronGridParameters p;
  p.rows = 3;
  p.cols = 2;
  p.cables_per_join = 5;
  const Structure expected = scenes::octahedron_grid(p);
  EXPECT_TRUE(written.positions == expected.positions);
  ASSERT_EQ(written.num_elements(), expected.num_elements());
  EXPECT_EQ(written.num_elements(), 6 * kOctahedronElements + 7 * 5);  // 3 x 2: 7 neighbour pairs
  const auto bad = dir.run({"generate", "grid", "--rows", "0", "--out", dir.file("bad.scene.json")});
  EXPECT_EQ(bad.exit_status, 2);
}

}  // namespace
}  // namespace tensegrity
