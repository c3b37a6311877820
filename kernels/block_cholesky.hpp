#pragma once
// Sparse Cholesky factorization N = L L^T of a symmetric positive definite
// matrix made of 3x3 blocks (one block row/column per free node), in place.
//
// Why our own: the joint Gauss-Newton steps factorize the same small
// node-block pattern many times per solve. A general sparse factorization
// (Eigen's SimplicialLDLT entry by entry, CHOLMOD's supernodes) pays index
// arithmetic or set-up per entry; on fixed-size 3x3 blocks one index lookup
// serves 27 multiply-adds.
//
// Usage: analyze() once per pattern (elimination tree and the block pattern
// of L, fill included); then per factorization write N's lower-triangle
// blocks (diagonal blocks in full) into block(slot(r, c)) after
// set_zero(), call factorize(), and solve() any number of right-hand sides.
// The block order is the caller's (a fill-reducing order is its business).
#include <Eigen/Core>
#include <utility>
#include <vector>

namespace tensegrity {

class BlockCholesky {
 public:
  // lower[c]: the block rows r >= c of N's column c (c itself included).
  void analyze(const std::vector<std::vector<int>>& lower);

  int num_blocks() const { return static_cast<int>(column_begin_.size()) - 1; }
  // Storage index of block (r, c), r >= c, of the pattern of L (N's pattern
  // is part of it); -1 when absent.
  int slot(int r, int c) const;
  // The same for many blocks at once, in time linear in their number and the
  // pattern's size: slots[i] = slot(blocks[i].first, blocks[i].second).
  std::vector<int> slots(const std::vector<std::pair<int, int>>& blocks) const;
  Eigen::Matrix3d& block(int slot) { return values_[slot]; }
  void set_zero();

  // In place; false when a pivot block is not positive definite (the
  // factor is then unusable until the next successful factorize()).
  bool factorize();
  // x = N^{-1} x (3 num_blocks entries).
  void solve(Eigen::VectorXd& x) const;

 private:
  // Left-looking bookkeeping: queue column j (cursor at `slot`) on the list of
  // the column its block row at `slot` names; nothing when j has no more rows.
  void wait_at_next_row(int j, int slot);

  std::vector<int> column_begin_;   // per block column, its first slot (the diagonal)
  std::vector<int> row_;            // per slot, its block row
  std::vector<Eigen::Matrix3d> values_;
  std::vector<Eigen::Matrix3d> inverse_diagonal_;  // L_kk^{-1}
  // Factorization workspace (sized once).
  std::vector<int> cursor_, head_, next_;
  std::vector<int> update_target_;  // per 3x3 update, in factorize()'s order: the slot it writes
};

}  // namespace tensegrity
