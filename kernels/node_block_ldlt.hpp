#pragma once
// LDL^T without pivoting, in a fixed elimination order, of a symmetric matrix
// whose variables fall into three groups, eliminated in this order:
//
//   scalars  variables coupled to no other scalar (their block of the matrix
//            is diagonal): the member forces of Eq. 5's KKT matrix;
//   blocks   groups of kBlockSize variables, each factored as one dense block:
//            a node's three positions and its three equilibrium multipliers;
//   tail     a few variables that may couple to anything (a dense border):
//            the force-scale row.
//
// Each scalar costs one rank-one update of the blocks it touches; the blocks
// are then factored right-looking on the block graph with fixed-size dense
// kernels, where a scalar up-looking LDL^T spends its time on indirect
// addressing. Mathematically it is the scalar LDL^T in the same order (the
// same L and D up to rounding), so the signs of D give the inertia
// (Sylvester's law). The pattern is analysed once; each factorization writes
// values only, and neither it nor a solve allocates.
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <array>
#include <vector>

namespace tensegrity {

class NodeBlockLdlt {
 public:
  static constexpr int kBlockSize = 6;
  using Block = std::array<int, kBlockSize>;

  // `lower`: the lower triangle's pattern (compressed; values ignored). The
  // groups must partition the variables; the blocks are given in elimination
  // order. Throws std::invalid_argument when they do not, or when two scalars
  // are coupled.
  void analyze(const Eigen::SparseMatrix<double>& lower, const std::vector<int>& scalars,
               const std::vector<Block>& blocks, const std::vector<int>& tail);

  // Factorizes the matrix whose lower-triangle values, in the analysed
  // pattern's storage order, are `values`. False when a pivot is zero or not
  // finite.
  bool factorize(const double* values);
  // Signs of D of the last successful factorization.
  int positive_pivots() const { return positive_; }
  int negative_pivots() const { return negative_; }

  // D of the last successful factorization, in elimination order.
  Eigen::VectorXd pivots() const;

  // x = A^{-1} b with the last factorization.
  void solve(const Eigen::VectorXd& b, Eigen::VectorXd& x);

 private:
  // Position in store_ of entry (row, col), row >= col, of the internally
  // ordered matrix, for a row and column not both scalars.
  int slot(int row, int col) const;
  // Position of block row i in column j's list of blocks below the diagonal.
  int off_diagonal_index(int i, int j) const;

  int size_ = 0, num_scalars_ = 0, num_blocks_ = 0, tail_size_ = 0;
  std::vector<int> original_;  // internal index -> variable
  // Per scalar s: the internal indices its column reaches (ascending: whole
  // blocks, then tail entries) and where their values are; the blocks; per
  // pair of them (i <= j), where block (j, i) of the matrix starts.
  std::vector<int> scalar_start_, scalar_target_, segment_start_, segment_block_;
  std::vector<int> segment_pair_start_, segment_pair_slot_;
  // Per block column j: the blocks below the diagonal (ascending).
  std::vector<int> below_start_, below_;
  // Sections of store_.
  int scalar_entries_ = 0, diagonal_blocks_ = 0, off_diagonal_blocks_ = 0, border_ = 0, tail_ = 0;
  std::vector<int> value_slot_;  // input value p -> store_ position
  std::vector<double> store_;
  // The solve's vector; a column's W L^{-T} blocks; a dense factorization's row.
  std::vector<double> work_, update_, pivot_work_;
  int positive_ = 0, negative_ = 0;
};

}  // namespace tensegrity
