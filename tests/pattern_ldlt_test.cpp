// PatternLdlt (kernels/pattern_ldlt.hpp) against Eigen's SimplicialLDLT with
// the same ordering: L, D and solutions equal to the bit, over several
// refactorizations of one pattern, and the same failure on a zero pivot; with
// the caller's elimination order, against Eigen on the matrix permuted by it.
#include "kernels/pattern_ldlt.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <set>
#include <vector>

namespace tensegrity {
namespace {

using SparseMatrix = Eigen::SparseMatrix<double>;
using EigenLdlt = Eigen::SimplicialLDLT<SparseMatrix, Eigen::Lower, Eigen::AMDOrdering<int>>;

// The lower triangle of B^T B + shift I with a random sparse B (rows x n, a
// few entries per column), bordered by a dense last row c^T and -1 on the
// corner: the shape of the stress QP's quasi-definite matrix.
SparseMatrix quasi_definite(int n, int rows, unsigned seed, double shift) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> row(0, rows - 1);
  std::uniform_real_distribution<double> value(-1.0, 1.0);
  std::vector<Eigen::Triplet<double>> b;
  for (int j = 0; j < n; ++j)
    for (int k = 0; k < 4; ++k) b.emplace_back(row(rng), j, value(rng));
  SparseMatrix B(rows, n);
  B.setFromTriplets(b.begin(), b.end());
  SparseMatrix N = SparseMatrix(B.transpose()) * B;
  std::vector<Eigen::Triplet<double>> k;
  for (int j = 0; j < n; ++j) {
    for (SparseMatrix::InnerIterator it(N, j); it; ++it)
      if (it.row() >= j) k.emplace_back(it.row(), j, it.value() + (it.row() == j ? shift : 0.0));
    k.emplace_back(n, j, value(rng));
  }
  k.emplace_back(n, n, -1.0);
  SparseMatrix K(n + 1, n + 1);
  K.setFromTriplets(k.begin(), k.end());
  K.makeCompressed();
  return K;
}

void expect_bitwise_equal(const EigenLdlt& eigen, const PatternLdlt& ours) {
  const Eigen::VectorXd d_eigen = eigen.vectorD(), d_ours = ours.vectorD();
  ASSERT_EQ(d_eigen.size(), d_ours.size());
  for (int i = 0; i < d_eigen.size(); ++i) ASSERT_EQ(d_eigen[i], d_ours[i]) << "D " << i;
  const SparseMatrix& l_eigen = eigen.matrixL().nestedExpression();
  const SparseMatrix& l_ours = ours.matrixL().nestedExpression();
  ASSERT_EQ(l_eigen.nonZeros(), l_ours.nonZeros());
  for (int p = 0; p < l_eigen.nonZeros(); ++p) {
    ASSERT_EQ(l_eigen.innerIndexPtr()[p], l_ours.innerIndexPtr()[p]) << p;
    ASSERT_EQ(l_eigen.valuePtr()[p], l_ours.valuePtr()[p]) << p;
  }
}

TEST(PatternLdlt, EqualsEigensFactorizationToTheBit) {
  SparseMatrix K = quasi_definite(300, 200, 7, 1e-8);
  EigenLdlt eigen;
  eigen.analyzePattern(K);
  PatternLdlt ours;
  ours.analyze(K);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> factor(0.5, 1.5);
  for (int round = 0; round < 4; ++round) {
    SCOPED_TRACE(round);
    eigen.factorize(K);
    ASSERT_EQ(eigen.info(), Eigen::Success);
    ASSERT_TRUE(ours.factorize_values(K.valuePtr()));
    EXPECT_EQ(ours.info(), Eigen::Success);
    expect_bitwise_equal(eigen, ours);
    const Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(K.rows(), -1.0, 2.0);
    const Eigen::VectorXd x_eigen = eigen.solve(b), x_ours = ours.solve(b);
    for (int i = 0; i < b.size(); ++i) ASSERT_EQ(x_eigen[i], x_ours[i]) << i;
    EXPECT_LT((K.selfadjointView<Eigen::Lower>() * x_ours - b).norm(), 1e-6 * b.norm());
    // New values in the same pattern (the diagonal kept dominant enough to factorize).
    for (int p = 0; p < K.nonZeros(); ++p) K.valuePtr()[p] *= factor(rng);
  }
}

// analyze(lower, order): the factors are those of the matrix with its
// variables renumbered in `order` (Eigen, natural ordering; the entries are
// summed in another order, hence 1e-12 on entries of order one), and solve() answers in
// the caller's numbering.
TEST(PatternLdlt, FollowsTheCallersEliminationOrder) {
  const SparseMatrix K = quasi_definite(120, 90, 5, 1e-6);
  const int n = static_cast<int>(K.rows());
  Eigen::VectorXi order(n);
  for (int k = 0; k < n; ++k) order[k] = (k * 37 + 11) % n;  // 37 is prime to n = 121: a permutation
  ASSERT_EQ(std::set<int>(order.data(), order.data() + n).size(), static_cast<std::size_t>(n));
  Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> renumber(n);  // variable -> position
  for (int k = 0; k < n; ++k) renumber.indices()[order[k]] = k;
  SparseMatrix permuted(n, n);
  permuted.selfadjointView<Eigen::Lower>() = K.selfadjointView<Eigen::Lower>().twistedBy(renumber);
  Eigen::SimplicialLDLT<SparseMatrix, Eigen::Lower, Eigen::NaturalOrdering<int>> eigen(permuted);
  ASSERT_EQ(eigen.info(), Eigen::Success);
  PatternLdlt ours;
  ours.analyze(K, order);
  ASSERT_TRUE(ours.factorize_values(K.valuePtr()));
  const Eigen::VectorXd d_eigen = eigen.vectorD(), d_ours = ours.vectorD();
  for (int i = 0; i < n; ++i) ASSERT_NEAR(d_eigen[i], d_ours[i], 1e-12) << "D " << i;
  ASSERT_EQ(eigen.matrixL().nestedExpression().nonZeros(), ours.matrixL().nestedExpression().nonZeros());
  const Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(n, -1.0, 2.0);
  const Eigen::VectorXd x = ours.solve(b);
  EXPECT_LT((K.selfadjointView<Eigen::Lower>() * x - b).norm(), 1e-8 * b.norm());
}

TEST(PatternLdlt, ReportsAZeroPivotAsEigenDoes) {
  SparseMatrix K = quasi_definite(40, 30, 3, 1.0);
  PatternLdlt ours;
  ours.analyze(K);
  ASSERT_TRUE(ours.factorize_values(K.valuePtr()));
  for (int p = 0; p < K.nonZeros(); ++p) K.valuePtr()[p] = 0.0;  // the same pattern, every pivot zero
  EigenLdlt eigen;
  eigen.compute(K);
  EXPECT_EQ(eigen.info(), Eigen::NumericalIssue);
  EXPECT_FALSE(ours.factorize_values(K.valuePtr()));
  EXPECT_EQ(ours.info(), Eigen::NumericalIssue);
}

}  // namespace
}  // namespace tensegrity
