#include "kernels/block_cholesky.hpp"

#include <algorithm>
#include <cmath>

namespace tensegrity {

void BlockCholesky::analyze(const std::vector<std::vector<int>>& lower) {
  const int nb = static_cast<int>(lower.size());
  // Symbolic factorization: the rows of L's column k are N's rows below k
  // plus those of every child in the elimination tree (parent = first row).
  std::vector<std::vector<int>> rows(nb), children(nb);
  std::vector<int> mark(nb, -1);
  for (int k = 0; k < nb; ++k) {
    auto& list = rows[k];
    auto add = [&](int r) {
      if (r > k && mark[r] != k) {
        mark[r] = k;
        list.push_back(r);
      }
    };
    for (int r : lower[k]) add(r);
    for (int c : children[k])
      for (int r : rows[c]) add(r);
    std::sort(list.begin(), list.end());
    if (!list.empty()) children[list.front()].push_back(k);
  }
  column_begin_.assign(nb + 1, 0);
  row_.clear();
  for (int k = 0; k < nb; ++k) {
    column_begin_[k] = static_cast<int>(row_.size());
    row_.push_back(k);
    row_.insert(row_.end(), rows[k].begin(), rows[k].end());
  }
  column_begin_[nb] = static_cast<int>(row_.size());
  values_.assign(row_.size(), Eigen::Matrix3d::Zero());
  inverse_diagonal_.assign(nb, Eigen::Matrix3d::Identity());
  cursor_.assign(nb, 0);
  head_.assign(nb, -1);
  next_.assign(nb, -1);

  // The update plan: factorize()'s traversal, recording the slot each
  // update writes to (saves two dependent lookups per 3x3 update).
  update_target_.clear();
  std::vector<int> position(nb, 0);
  for (int k = 0; k < nb; ++k) {
    const int begin = column_begin_[k], end = column_begin_[k + 1];
    for (int p = begin; p < end; ++p) position[row_[p]] = p;
    for (int j = head_[k]; j != -1;) {
      const int next_j = next_[j];
      const int pj = cursor_[j], end_j = column_begin_[j + 1];
      for (int p = pj; p < end_j; ++p) update_target_.push_back(position[row_[p]]);
      wait_at_next_row(j, pj + 1);
      j = next_j;
    }
    wait_at_next_row(k, begin + 1);
  }
}

void BlockCholesky::wait_at_next_row(int j, int slot) {
  // Column j's next update goes to the column of its block row at `slot`.
  if (slot >= column_begin_[j + 1]) return;
  cursor_[j] = slot;
  const int r = row_[slot];
  next_[j] = head_[r];
  head_[r] = j;
}

int BlockCholesky::slot(int r, int c) const {
  const int begin = column_begin_[c], end = column_begin_[c + 1];
  if (r == c) return begin;
  const auto it = std::lower_bound(row_.begin() + begin + 1, row_.begin() + end, r);
  return it != row_.begin() + end && *it == r ? static_cast<int>(it - row_.begin()) : -1;
}

std::vector<int> BlockCholesky::slots(const std::vector<std::pair<int, int>>& blocks) const {
  const int nb = num_blocks();
  // Requests bucketed by column, then each column's rows mapped once.
  std::vector<int> bucket_begin(nb + 1, 0), order(blocks.size()), result(blocks.size(), -1), position(nb, -1);
  for (const auto& [r, c] : blocks) ++bucket_begin[c + 1];
  for (int c = 0; c < nb; ++c) bucket_begin[c + 1] += bucket_begin[c];
  std::vector<int> fill(bucket_begin.begin(), bucket_begin.end() - 1);
  for (std::size_t i = 0; i < blocks.size(); ++i) order[fill[blocks[i].second]++] = static_cast<int>(i);
  for (int c = 0; c < nb; ++c) {
    if (bucket_begin[c] == bucket_begin[c + 1]) continue;
    for (int p = column_begin_[c]; p < column_begin_[c + 1]; ++p) position[row_[p]] = p;
    for (int k = bucket_begin[c]; k < bucket_begin[c + 1]; ++k) result[order[k]] = position[blocks[order[k]].first];
    for (int p = column_begin_[c]; p < column_begin_[c + 1]; ++p) position[row_[p]] = -1;
  }
  return result;
}

void BlockCholesky::set_zero() {
  for (auto& v : values_) v.setZero();
}

bool BlockCholesky::factorize() {
  const int nb = num_blocks();
  std::fill(head_.begin(), head_.end(), -1);
  const int* target = update_target_.data();
  for (int k = 0; k < nb; ++k) {
    const int begin = column_begin_[k], end = column_begin_[k + 1];
    // Left-looking: every earlier column j with a block in row k updates
    // column k by its rows >= k; where each update lands was worked out by
    // analyze(), in this same order.
    for (int j = head_[k]; j != -1;) {
      const int next_j = next_[j];
      const int pj = cursor_[j], end_j = column_begin_[j + 1];
      const Eigen::Matrix3d lkj_t = values_[pj].transpose();
      for (int p = pj; p < end_j; ++p) values_[*target++].noalias() -= values_[p] * lkj_t;
      wait_at_next_row(j, pj + 1);
      j = next_j;
    }
    // 3x3 Cholesky of the pivot block (lower triangle of the symmetric block).
    const Eigen::Matrix3d& w = values_[begin];
    Eigen::Matrix3d l = Eigen::Matrix3d::Zero();
    const double d0 = w(0, 0);
    if (!(d0 > 0.0)) return false;
    l(0, 0) = std::sqrt(d0);
    l(1, 0) = w(1, 0) / l(0, 0);
    l(2, 0) = w(2, 0) / l(0, 0);
    const double d1 = w(1, 1) - l(1, 0) * l(1, 0);
    if (!(d1 > 0.0)) return false;
    l(1, 1) = std::sqrt(d1);
    l(2, 1) = (w(2, 1) - l(2, 0) * l(1, 0)) / l(1, 1);
    const double d2 = w(2, 2) - l(2, 0) * l(2, 0) - l(2, 1) * l(2, 1);
    if (!(d2 > 0.0)) return false;
    l(2, 2) = std::sqrt(d2);
    Eigen::Matrix3d inv = Eigen::Matrix3d::Zero();
    inv(0, 0) = 1.0 / l(0, 0);
    inv(1, 1) = 1.0 / l(1, 1);
    inv(2, 2) = 1.0 / l(2, 2);
    inv(1, 0) = -l(1, 0) * inv(0, 0) * inv(1, 1);
    inv(2, 1) = -l(2, 1) * inv(1, 1) * inv(2, 2);
    inv(2, 0) = -(l(2, 0) * inv(0, 0) + l(2, 1) * inv(1, 0)) * inv(2, 2);
    values_[begin] = l;
    inverse_diagonal_[k] = inv;
    const Eigen::Matrix3d inv_t = inv.transpose();
    for (int p = begin + 1; p < end; ++p) values_[p] = values_[p] * inv_t;
    wait_at_next_row(k, begin + 1);
  }
  return true;
}

void BlockCholesky::solve(Eigen::VectorXd& x) const {
  const int nb = num_blocks();
  for (int k = 0; k < nb; ++k) {
    const Eigen::Vector3d xk = inverse_diagonal_[k] * x.segment<3>(3 * k);
    x.segment<3>(3 * k) = xk;
    for (int p = column_begin_[k] + 1; p < column_begin_[k + 1]; ++p) x.segment<3>(3 * row_[p]) -= values_[p] * xk;
  }
  for (int k = nb - 1; k >= 0; --k) {
    Eigen::Vector3d xk = x.segment<3>(3 * k);
    for (int p = column_begin_[k] + 1; p < column_begin_[k + 1]; ++p)
      xk -= values_[p].transpose() * x.segment<3>(3 * row_[p]);
    x.segment<3>(3 * k) = inverse_diagonal_[k].transpose() * xk;
  }
}

}  // namespace tensegrity
