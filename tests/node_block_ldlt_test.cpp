// NodeBlockLdlt (kernels/node_block_ldlt.hpp) against the scalar LDL^T of
// PatternLdlt in the same elimination order, on matrices with the structure
// of Eq. 5's KKT matrix: D to rounding, the same inertia, solutions to
// rounding, over refactorizations of one pattern; a zero pivot is a failure,
// coupled scalars are refused.
#include "kernels/node_block_ldlt.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <stdexcept>
#include <utility>
#include <vector>

#include "kernels/pattern_ldlt.hpp"

namespace tensegrity {
namespace {

using SparseMatrix = Eigen::SparseMatrix<double>;
constexpr double kRoundingShare = 1e-7;  // relative agreement of two factorizations in different rounding

// The KKT matrix [H, J^T; J, -delta I] of a network of `nodes` nodes joined by
// a ring and random chords, one force per member: positions q (3 per node,
// first), the forces, then the equilibrium multipliers (3 per node) and one
// force-scale row on every other force. H couples the positions of joined
// nodes and each force to its two nodes; the forces' own diagonal spans
// eight orders of magnitude, as the barrier terms do. `curvature_shift` is
// added to the positions' diagonal (negative: an indefinite H).
struct Kkt {
  SparseMatrix lower;
  int nodes = 0, members = 0, n = 0;
  std::vector<std::pair<int, int>> joined;
};

Kkt structured_kkt(int nodes, int chords, unsigned seed, double curvature_shift) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> value(-1.0, 1.0), exponent(-6.0, 2.0);
  std::uniform_int_distribution<int> node(0, nodes - 1);
  Kkt kkt;
  kkt.nodes = nodes;
  for (int a = 0; a < nodes; ++a) kkt.joined.emplace_back(a, (a + 1) % nodes);
  for (int c = 0; c < chords; ++c) {
    const int a = node(rng), b = node(rng);
    if (a != b) kkt.joined.emplace_back(a, b);
  }
  kkt.members = static_cast<int>(kkt.joined.size());
  kkt.n = 3 * nodes + kkt.members;
  const int multiplier = kkt.n, tail = kkt.n + 3 * nodes, size = tail + 1;
  std::vector<Eigen::Triplet<double>> t;
  auto add = [&](int r, int c, double v) { t.emplace_back(std::max(r, c), std::min(r, c), v); };
  for (int a = 0; a < nodes; ++a)
    for (int i = 0; i < 3; ++i) {
      add(3 * a + i, 3 * a + i, 4.0 + curvature_shift);
      for (int k = 0; k < i; ++k) add(3 * a + i, 3 * a + k, 0.3 * value(rng));
    }
  for (int e = 0; e < kkt.members; ++e) {
    const auto [a, b] = kkt.joined[e];
    const int force = 3 * nodes + e;
    add(force, force, std::pow(10.0, exponent(rng)));
    for (int i = 0; i < 3; ++i) {
      for (int k = 0; k < 3; ++k) add(3 * a + i, 3 * b + k, 0.2 * value(rng));
      add(force, 3 * a + i, 0.5 * value(rng));
      add(force, 3 * b + i, 0.5 * value(rng));
      // Equilibrium rows of both nodes: df/dq and df/dsigma.
      for (int k = 0; k < 3; ++k) {
        add(multiplier + 3 * a + i, 3 * b + k, value(rng));
        add(multiplier + 3 * b + i, 3 * a + k, value(rng));
      }
      add(multiplier + 3 * a + i, force, value(rng));
      add(multiplier + 3 * b + i, force, value(rng));
    }
    if (e % 2 == 0) add(tail, force, 1.0);
  }
  for (int a = 0; a < nodes; ++a)
    for (int i = 0; i < 3; ++i)
      for (int k = 0; k < 3; ++k) add(multiplier + 3 * a + i, 3 * a + k, value(rng));
  for (int r = multiplier; r < size; ++r) add(r, r, -1e-10);
  kkt.lower.resize(size, size);
  kkt.lower.setFromTriplets(t.begin(), t.end());
  kkt.lower.makeCompressed();
  return kkt;
}

// The groups: the forces, then per node (in a shuffled order) its positions
// and multipliers, then the force-scale row.
struct Groups {
  std::vector<int> scalars, tail;
  std::vector<NodeBlockLdlt::Block> blocks;
  Eigen::VectorXi order;  // the same elimination order for PatternLdlt
};

Groups groups_of(const Kkt& kkt, unsigned seed) {
  Groups g;
  for (int e = 0; e < kkt.members; ++e) g.scalars.push_back(3 * kkt.nodes + e);
  std::vector<int> node_order(kkt.nodes);
  std::iota(node_order.begin(), node_order.end(), 0);
  std::shuffle(node_order.begin(), node_order.end(), std::mt19937(seed));
  for (int a : node_order)
    g.blocks.push_back({3 * a, 3 * a + 1, 3 * a + 2, kkt.n + 3 * a, kkt.n + 3 * a + 1, kkt.n + 3 * a + 2});
  g.tail.push_back(static_cast<int>(kkt.lower.rows()) - 1);
  std::vector<int> order = g.scalars;
  for (const auto& block : g.blocks) order.insert(order.end(), block.begin(), block.end());
  order.insert(order.end(), g.tail.begin(), g.tail.end());
  g.order = Eigen::Map<Eigen::VectorXi>(order.data(), static_cast<int>(order.size()));
  return g;
}

TEST(NodeBlockLdlt, EqualsTheScalarFactorizationInTheSameOrder) {
  Kkt kkt = structured_kkt(60, 40, 3, 0.0);
  const Groups g = groups_of(kkt, 5);
  NodeBlockLdlt blocks;
  blocks.analyze(kkt.lower, g.scalars, g.blocks, g.tail);
  PatternLdlt scalar;
  scalar.analyze(kkt.lower, g.order);
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> factor(0.5, 1.5);
  const int size = static_cast<int>(kkt.lower.rows());
  for (int round = 0; round < 3; ++round) {
    SCOPED_TRACE(round);
    ASSERT_TRUE(scalar.factorize_values(kkt.lower.valuePtr()));
    ASSERT_TRUE(blocks.factorize(kkt.lower.valuePtr()));
    // The forces' pivots down to 1e-6 put entries up to 1e6 into the blocks'
    // Schur complement, so rounding in another order differs by some 1e-9.
    const Eigen::VectorXd d_scalar = scalar.vectorD(), d_blocks = blocks.pivots();
    for (int k = 0; k < size; ++k)
      ASSERT_NEAR(d_blocks[k], d_scalar[k], kRoundingShare * std::abs(d_scalar[k])) << "pivot " << k;
    // Quasi-definite: one positive pivot per primal variable, one negative per row.
    EXPECT_EQ(blocks.positive_pivots(), kkt.n);
    EXPECT_EQ(blocks.negative_pivots(), size - kkt.n);
    const Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(size, -1.0, 2.0);
    Eigen::VectorXd x_blocks;
    blocks.solve(b, x_blocks);
    const Eigen::VectorXd x_scalar = scalar.solve(b);
    EXPECT_LE((x_blocks - x_scalar).cwiseAbs().maxCoeff(), kRoundingShare * x_scalar.cwiseAbs().maxCoeff());
    const Eigen::VectorXd residual = kkt.lower.selfadjointView<Eigen::Lower>() * x_blocks - b;
    EXPECT_LE(residual.cwiseAbs().maxCoeff(), 1e-8 * b.cwiseAbs().maxCoeff());
    for (int p = 0; p < kkt.lower.nonZeros(); ++p) kkt.lower.valuePtr()[p] *= factor(rng);
  }
}

TEST(NodeBlockLdlt, CountsTheInertiaOfAnIndefiniteMatrixAsTheScalarFactorizationDoes) {
  // A negative shift makes the positions' curvature indefinite: the inertia
  // is no longer (n, m), which is what the interior-point method watches for.
  const Kkt kkt = structured_kkt(50, 30, 4, -6.0);
  const Groups g = groups_of(kkt, 6);
  NodeBlockLdlt blocks;
  blocks.analyze(kkt.lower, g.scalars, g.blocks, g.tail);
  PatternLdlt scalar;
  scalar.analyze(kkt.lower, g.order);
  ASSERT_TRUE(scalar.factorize_values(kkt.lower.valuePtr()));
  ASSERT_TRUE(blocks.factorize(kkt.lower.valuePtr()));
  const Eigen::VectorXd d = scalar.vectorD();
  const int positive = static_cast<int>((d.array() > 0.0).count());
  EXPECT_EQ(blocks.positive_pivots(), positive);
  EXPECT_EQ(blocks.negative_pivots(), static_cast<int>(d.size()) - positive);
  EXPECT_LT(blocks.positive_pivots(), kkt.n);
  const Eigen::VectorXd b = Eigen::VectorXd::Ones(d.size());
  Eigen::VectorXd x;
  blocks.solve(b, x);
  const Eigen::VectorXd residual = kkt.lower.selfadjointView<Eigen::Lower>() * x - b;
  EXPECT_LE(residual.cwiseAbs().maxCoeff(), 1e-6 * x.cwiseAbs().maxCoeff());
}

TEST(NodeBlockLdlt, AZeroPivotIsAFailure) {
  Kkt kkt = structured_kkt(10, 4, 7, 0.0);
  const Groups g = groups_of(kkt, 8);
  NodeBlockLdlt blocks;
  blocks.analyze(kkt.lower, g.scalars, g.blocks, g.tail);
  // The first force's diagonal: the first pivot.
  const int force = g.scalars.front();
  for (SparseMatrix::InnerIterator it(kkt.lower, force); it; ++it)
    if (it.row() == force) it.valueRef() = 0.0;
  EXPECT_FALSE(blocks.factorize(kkt.lower.valuePtr()));
}

TEST(NodeBlockLdlt, RefusesCoupledScalarsAndGroupsThatDoNotPartition) {
  Kkt kkt = structured_kkt(8, 2, 9, 0.0);
  Groups g = groups_of(kkt, 10);
  NodeBlockLdlt blocks;
  // A position among the scalars: it is coupled to another position.
  std::vector<int> scalars = g.scalars;
  std::vector<NodeBlockLdlt::Block> rest = g.blocks;
  std::vector<int> tail = g.tail;
  const NodeBlockLdlt::Block first = rest.front();
  rest.erase(rest.begin());
  scalars.insert(scalars.end(), first.begin(), first.end());
  EXPECT_THROW(blocks.analyze(kkt.lower, scalars, rest, tail), std::invalid_argument);
  // The force-scale row left out.
  EXPECT_THROW(blocks.analyze(kkt.lower, g.scalars, g.blocks, {}), std::invalid_argument);
}

}  // namespace
}  // namespace tensegrity
