#include "kernels/node_block_ldlt.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace tensegrity {
namespace {

constexpr int kB = NodeBlockLdlt::kBlockSize;
constexpr int kBlockEntries = kB * kB;
using Matrix6 = Eigen::Matrix<double, kB, kB>;
using Vector6 = Eigen::Matrix<double, kB, 1>;
using BorderMatrix = Eigen::Matrix<double, Eigen::Dynamic, kB>;

// In-place LDL^T without pivoting of the dense symmetric matrix whose lower
// triangle `a` holds (column-major, leading dimension n): L's strict lower
// triangle and D on the diagonal. Counts the signs of D; false on a zero or
// non-finite pivot. `scaled`: n doubles of workspace.
bool factor_dense(double* a, int n, double* scaled, int& positive, int& negative) {
  for (int k = 0; k < n; ++k) {
    for (int m = 0; m < k; ++m) scaled[m] = a[m * n + k] * a[m * n + m];  // L(k, m) d_m
    double d = a[k * n + k];
    for (int m = 0; m < k; ++m) d -= a[m * n + k] * scaled[m];
    if (!std::isfinite(d) || d == 0.0) return false;
    (d > 0.0 ? positive : negative) += 1;
    a[k * n + k] = d;
    for (int r = k + 1; r < n; ++r) {
      double value = a[k * n + r];
      for (int m = 0; m < k; ++m) value -= a[m * n + r] * scaled[m];
      a[k * n + r] = value / d;
    }
  }
  return true;
}

// Unit lower triangular solves with the strict lower triangle of `l` (n x n,
// column-major): y <- L^{-1} y and y <- L^{-T} y.
// Each entry is accumulated in a register (its terms in ascending order),
// not written back after every term.
inline void forward_unit(const double* l, int n, double* y) {
  for (int r = 1; r < n; ++r) {
    double value = y[r];
    for (int c = 0; c < r; ++c) value -= l[c * n + r] * y[c];
    y[r] = value;
  }
}
inline void backward_unit(const double* l, int n, double* y) {
  for (int c = n - 1; c >= 0; --c) {
    double value = y[c];
    for (int r = c + 1; r < n; ++r) value -= l[c * n + r] * y[r];
    y[c] = value;
  }
}

// W <- W L^{-T} for the rows of W (rows x kB, column-major) and L the unit
// lower triangle of a factored diagonal block.
void solve_right_transposed(const double* l, double* w, int rows) {
  for (int c = 0; c < kB; ++c)
    for (int m = 0; m < c; ++m) {
      const double factor = l[m * kB + c];
      for (int r = 0; r < rows; ++r) w[c * rows + r] -= w[m * rows + r] * factor;
    }
}

// C <- C - L U^T for 6 x 6 column-major blocks, as updates of contiguous
// columns, which the compiler vectorizes; each entry takes its terms in
// ascending order.
void subtract_product_transposed(double* __restrict c, const double* __restrict l, const double* __restrict u) {
  for (int col = 0; col < kB; ++col)
    for (int m = 0; m < kB; ++m) {
      const double factor = u[m * kB + col];
      for (int r = 0; r < kB; ++r) c[col * kB + r] -= l[m * kB + r] * factor;
    }
}

// The same for a border of `rows` rows: T <- T - B U^T (T, B rows x 6).
void subtract_border_product(double* __restrict t, const double* __restrict b, const double* __restrict u, int rows) {
  for (int col = 0; col < kB; ++col)
    for (int m = 0; m < kB; ++m) {
      const double factor = u[m * kB + col];
      for (int r = 0; r < rows; ++r) t[col * rows + r] -= b[m * rows + r] * factor;
    }
}

}  // namespace

void NodeBlockLdlt::analyze(const Eigen::SparseMatrix<double>& lower, const std::vector<int>& scalars,
                            const std::vector<Block>& blocks, const std::vector<int>& tail) {
  if (!lower.isCompressed() || lower.rows() != lower.cols())
    throw std::invalid_argument("NodeBlockLdlt: the matrix must be square and compressed");
  size_ = static_cast<int>(lower.cols());
  num_scalars_ = static_cast<int>(scalars.size());
  num_blocks_ = static_cast<int>(blocks.size());
  tail_size_ = static_cast<int>(tail.size());
  const int ns = num_scalars_, nb = num_blocks_, nt = tail_size_;
  const int block_begin = ns, tail_begin = ns + kB * nb;

  // Internal order: scalars, the blocks' variables, the tail.
  original_.clear();
  original_.insert(original_.end(), scalars.begin(), scalars.end());
  for (const Block& block : blocks) original_.insert(original_.end(), block.begin(), block.end());
  original_.insert(original_.end(), tail.begin(), tail.end());
  if (static_cast<int>(original_.size()) != size_)
    throw std::invalid_argument("NodeBlockLdlt: the groups hold " + std::to_string(original_.size()) +
                                " variables, the matrix " + std::to_string(size_));
  std::vector<int> internal(size_, -1);
  for (int i = 0; i < size_; ++i) {
    const int v = original_[i];
    if (v < 0 || v >= size_ || internal[v] >= 0)
      throw std::invalid_argument("NodeBlockLdlt: variable " + std::to_string(v) + " out of range or in two groups");
    internal[v] = i;
  }
  auto block_of = [&](int i) { return (i - block_begin) / kB; };

  // Each scalar's targets, and the block graph (lower: adjacency[j] holds i > j).
  std::vector<std::vector<int>> targets(ns), adjacency(nb);
  for (int c = 0; c < size_; ++c)
    for (Eigen::SparseMatrix<double>::InnerIterator it(lower, c); it; ++it) {
      int row = internal[it.row()], col = internal[c];
      if (row < col) std::swap(row, col);
      if (col < ns) {
        if (row < ns && row != col)
          throw std::invalid_argument("NodeBlockLdlt: scalars " + std::to_string(original_[row]) + " and " +
                                      std::to_string(original_[col]) + " are coupled");
        if (row >= ns) targets[col].push_back(row);
      } else if (row < tail_begin && block_of(row) != block_of(col)) {
        adjacency[block_of(col)].push_back(block_of(row));
      }
    }
  for (auto& list : targets) {
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
    // Eliminating a scalar couples every block it touches.
    std::vector<int> touched;
    for (int i : list)
      if (i < tail_begin && (touched.empty() || touched.back() != block_of(i))) touched.push_back(block_of(i));
    for (std::size_t a = 0; a < touched.size(); ++a)
      for (std::size_t b = a + 1; b < touched.size(); ++b) adjacency[touched[a]].push_back(touched[b]);
  }

  // Symbolic block factorization: column j's blocks below the diagonal are its
  // own neighbours after it and those of its children in the elimination tree.
  std::vector<std::vector<int>> children(nb);
  std::vector<int> mark(nb, -1), list;
  below_start_.assign(nb + 1, 0);
  below_.clear();
  for (int j = 0; j < nb; ++j) {
    list.clear();
    mark[j] = j;
    auto add = [&](int i) {
      if (mark[i] != j) mark[i] = j, list.push_back(i);
    };
    for (int i : adjacency[j]) add(i);
    for (int child : children[j])
      for (int p = below_start_[child]; p < below_start_[child + 1]; ++p) add(below_[p]);
    std::sort(list.begin(), list.end());
    below_.insert(below_.end(), list.begin(), list.end());
    below_start_[j + 1] = static_cast<int>(below_.size());
    if (!list.empty()) children[list.front()].push_back(j);
  }

  // Each scalar's column as whole blocks (a segment of kB entries per block
  // it touches, zeros where it has none), then its tail entries: contiguous
  // updates in place of one indirection per entry.
  scalar_start_.assign(ns + 1, 0);
  segment_start_.assign(ns + 1, 0);
  scalar_target_.clear();
  segment_block_.clear();
  for (int s = 0; s < ns; ++s) {
    for (int i : targets[s]) {
      if (i >= tail_begin) continue;
      const int block = block_of(i);
      if (segment_block_.size() > static_cast<std::size_t>(segment_start_[s]) && segment_block_.back() == block) continue;
      segment_block_.push_back(block);
      for (int o = 0; o < kB; ++o) scalar_target_.push_back(block_begin + kB * block + o);
    }
    segment_start_[s + 1] = static_cast<int>(segment_block_.size());
    for (int i : targets[s])
      if (i >= tail_begin) scalar_target_.push_back(i);
    scalar_start_[s + 1] = static_cast<int>(scalar_target_.size());
  }
  scalar_entries_ = ns;
  diagonal_blocks_ = scalar_entries_ + static_cast<int>(scalar_target_.size());
  off_diagonal_blocks_ = diagonal_blocks_ + kBlockEntries * nb;
  border_ = off_diagonal_blocks_ + kBlockEntries * static_cast<int>(below_.size());
  tail_ = border_ + nb * nt * kB;
  store_.assign(static_cast<std::size_t>(tail_ + nt * nt), 0.0);

  value_slot_.clear();
  value_slot_.reserve(static_cast<std::size_t>(lower.nonZeros()));
  for (int c = 0; c < size_; ++c)
    for (Eigen::SparseMatrix<double>::InnerIterator it(lower, c); it; ++it) {
      int row = internal[it.row()], col = internal[c];
      if (row < col) std::swap(row, col);
      value_slot_.push_back(row < ns ? row : slot(row, col));
    }
  // Per scalar and pair of its segments (i <= j): where block (j, i) starts.
  segment_pair_start_.assign(ns + 1, 0);
  segment_pair_slot_.clear();
  for (int s = 0; s < ns; ++s) {
    for (int j = segment_start_[s]; j < segment_start_[s + 1]; ++j)
      for (int i = segment_start_[s]; i <= j; ++i)
        segment_pair_slot_.push_back(slot(block_begin + kB * segment_block_[j], block_begin + kB * segment_block_[i]));
    segment_pair_start_[s + 1] = static_cast<int>(segment_pair_slot_.size());
  }
  int longest = 0;
  for (int j = 0; j < nb; ++j) longest = std::max(longest, below_start_[j + 1] - below_start_[j]);
  update_.assign(static_cast<std::size_t>(kBlockEntries * longest + nt * kB), 0.0);
  work_.assign(size_, 0.0);
  pivot_work_.assign(std::max(kB, nt), 0.0);
  positive_ = negative_ = 0;
}

int NodeBlockLdlt::off_diagonal_index(int i, int j) const {
  const auto first = below_.begin() + below_start_[j], last = below_.begin() + below_start_[j + 1];
  const auto found = std::lower_bound(first, last, i);
  return static_cast<int>(found - below_.begin());
}

int NodeBlockLdlt::slot(int row, int col) const {
  const int ns = num_scalars_, nt = tail_size_, tail_begin = ns + kB * num_blocks_;
  if (col < ns) {
    const auto first = scalar_target_.begin() + scalar_start_[col];
    const auto last = scalar_target_.begin() + scalar_start_[col + 1];
    return scalar_entries_ + static_cast<int>(std::lower_bound(first, last, row) - scalar_target_.begin());
  }
  if (col >= tail_begin) return tail_ + (col - tail_begin) * nt + (row - tail_begin);
  const int bj = (col - ns) / kB, oj = (col - ns) % kB;
  if (row >= tail_begin) return border_ + bj * nt * kB + oj * nt + (row - tail_begin);
  const int bi = (row - ns) / kB, oi = (row - ns) % kB;
  if (bi == bj) return diagonal_blocks_ + kBlockEntries * bj + oj * kB + oi;
  return off_diagonal_blocks_ + kBlockEntries * off_diagonal_index(bi, bj) + oj * kB + oi;
}

bool NodeBlockLdlt::factorize(const double* values) {
  const int ns = num_scalars_, nb = num_blocks_, nt = tail_size_;
  std::fill(store_.begin(), store_.end(), 0.0);
  for (std::size_t p = 0; p < value_slot_.size(); ++p) store_[value_slot_[p]] += values[p];
  double* store = store_.data();
  int positive = 0, negative = 0;

  // The scalars: one rank-one update each, entry (r, c) less c_r / d * c_c,
  // then their column becomes L's.
  const int tail_begin = ns + kB * nb;
  for (int s = 0; s < ns; ++s) {
    const double d = store[s];
    if (!std::isfinite(d) || d == 0.0) return false;
    (d > 0.0 ? positive : negative) += 1;
    double* column = store + scalar_entries_ + scalar_start_[s];
    const int segments = segment_start_[s + 1] - segment_start_[s];
    const int* pair = segment_pair_slot_.data() + segment_pair_start_[s];
    for (int j = 0; j < segments; ++j) {
      double scaled[kB];
      for (int r = 0; r < kB; ++r) scaled[r] = column[kB * j + r] / d;
      for (int i = 0; i <= j; ++i) {
        double* block = store + *pair++;
        const double* c_i = column + kB * i;
        for (int c = 0; c < kB; ++c)
          for (int r = 0; r < kB; ++r) block[c * kB + r] -= scaled[r] * c_i[c];
      }
    }
    const int entries = scalar_start_[s + 1] - scalar_start_[s];
    for (int t = kB * segments; t < entries; ++t) {
      const int row = scalar_target_[scalar_start_[s] + t] - tail_begin;
      const double scaled = column[t] / d;
      for (int i = 0; i < segments; ++i) {
        double* border_i = store + border_ + segment_block_[segment_start_[s] + i] * nt * kB;
        for (int c = 0; c < kB; ++c) border_i[c * nt + row] -= scaled * column[kB * i + c];
      }
      for (int u = kB * segments; u <= t; ++u)
        store[tail_ + (scalar_target_[scalar_start_[s] + u] - tail_begin) * nt + row] -= scaled * column[u];
    }
    for (int k = 0; k < entries; ++k) column[k] /= d;
  }

  // The blocks, right-looking: factor the diagonal block, turn the blocks
  // below it into L's (keeping W L^{-T} for the update), update the rest.
  double* update = update_.data();
  for (int j = 0; j < nb; ++j) {
    double* diagonal = store + diagonal_blocks_ + kBlockEntries * j;
    if (!factor_dense(diagonal, kB, pivot_work_.data(), positive, negative)) return false;
    Vector6 inverse_d;
    for (int k = 0; k < kB; ++k) inverse_d[k] = 1.0 / diagonal[k * kB + k];
    const int first = below_start_[j], count = below_start_[j + 1] - first;
    double* border_j = store + border_ + j * nt * kB;
    double* border_update = update + kBlockEntries * count;
    for (int t = 0; t < count; ++t) {
      double* w = store + off_diagonal_blocks_ + kBlockEntries * (first + t);
      solve_right_transposed(diagonal, w, kB);
      Eigen::Map<Matrix6>(update + kBlockEntries * t) = Eigen::Map<Matrix6>(w);
      Eigen::Map<Matrix6>(w) *= inverse_d.asDiagonal();
    }
    if (nt > 0) {
      solve_right_transposed(diagonal, border_j, nt);
      Eigen::Map<BorderMatrix>(border_update, nt, kB) = Eigen::Map<BorderMatrix>(border_j, nt, kB);
      Eigen::Map<BorderMatrix>(border_j, nt, kB) *= inverse_d.asDiagonal();
    }
    for (int kk = 0; kk < count; ++kk) {
      const int k = below_[first + kk];
      const double* u_k = update + kBlockEntries * kk;
      const double* column_l = store + off_diagonal_blocks_ + kBlockEntries * first;
      subtract_product_transposed(store + diagonal_blocks_ + kBlockEntries * k, column_l + kBlockEntries * kk, u_k);
      // Blocks (i, k), i below k in column j, are in column k's list (a superset).
      int w = below_start_[k];
      for (int ii = kk + 1; ii < count; ++ii) {
        const int i = below_[first + ii];
        while (below_[w] != i) ++w;
        subtract_product_transposed(store + off_diagonal_blocks_ + kBlockEntries * w, column_l + kBlockEntries * ii, u_k);
      }
      if (nt > 0) subtract_border_product(store + border_ + k * nt * kB, border_j, u_k, nt);
    }
    for (int c = 0; c < nt; ++c)
      for (int m = 0; m < kB; ++m) {
        const double factor = border_update[m * nt + c];
        for (int r = 0; r < nt; ++r) store[tail_ + c * nt + r] -= border_j[m * nt + r] * factor;
      }
  }
  if (nt > 0 && !factor_dense(store + tail_, nt, pivot_work_.data(), positive, negative)) return false;
  positive_ = positive;
  negative_ = negative;
  return true;
}

Eigen::VectorXd NodeBlockLdlt::pivots() const {
  const int ns = num_scalars_, nb = num_blocks_, nt = tail_size_;
  Eigen::VectorXd d(size_);
  for (int s = 0; s < ns; ++s) d[s] = store_[s];
  for (int j = 0; j < nb; ++j)
    for (int k = 0; k < kB; ++k) d[ns + kB * j + k] = store_[diagonal_blocks_ + kBlockEntries * j + k * kB + k];
  for (int t = 0; t < nt; ++t) d[ns + kB * nb + t] = store_[tail_ + t * nt + t];
  return d;
}

void NodeBlockLdlt::solve(const Eigen::VectorXd& b, Eigen::VectorXd& x) {
  const int ns = num_scalars_, nb = num_blocks_, nt = tail_size_;
  const int tail_begin = ns + kB * nb;
  const double* store = store_.data();
  double* w = work_.data();
  for (int i = 0; i < size_; ++i) w[i] = b[original_[i]];
  const Eigen::Map<Eigen::VectorXd> w_tail(w + tail_begin, nt);

  // L y = b.
  for (int s = 0; s < ns; ++s) {
    const double w_s = w[s];
    const double* l = store + scalar_entries_ + scalar_start_[s];
    int k = 0;
    for (int g = segment_start_[s]; g < segment_start_[s + 1]; ++g, k += kB) {
      double* w_block = w + ns + kB * segment_block_[g];
      for (int r = 0; r < kB; ++r) w_block[r] -= l[k + r] * w_s;
    }
    for (; k < scalar_start_[s + 1] - scalar_start_[s]; ++k) w[scalar_target_[scalar_start_[s] + k]] -= l[k] * w_s;
  }
  for (int j = 0; j < nb; ++j) {
    double* y = w + ns + kB * j;
    forward_unit(store + diagonal_blocks_ + kBlockEntries * j, kB, y);
    const Eigen::Map<const Vector6> y_j(y);
    for (int p = below_start_[j]; p < below_start_[j + 1]; ++p)
      Eigen::Map<Vector6>(w + ns + kB * below_[p]).noalias() -=
          Eigen::Map<const Matrix6>(store + off_diagonal_blocks_ + kBlockEntries * p) * y_j;
    if (nt > 0)
      Eigen::Map<Eigen::VectorXd>(w + tail_begin, nt).noalias() -=
          Eigen::Map<const BorderMatrix>(store + border_ + j * nt * kB, nt, kB) * y_j;
  }
  forward_unit(store + tail_, nt, w + tail_begin);

  // D z = y.
  for (int s = 0; s < ns; ++s) w[s] /= store[s];
  for (int j = 0; j < nb; ++j)
    for (int k = 0; k < kB; ++k) w[ns + kB * j + k] /= store[diagonal_blocks_ + kBlockEntries * j + k * kB + k];
  for (int t = 0; t < nt; ++t) w[tail_begin + t] /= store[tail_ + t * nt + t];

  // L^T x = z.
  backward_unit(store + tail_, nt, w + tail_begin);
  for (int j = nb - 1; j >= 0; --j) {
    Eigen::Map<Vector6> z(w + ns + kB * j);
    for (int p = below_start_[j]; p < below_start_[j + 1]; ++p)
      z.noalias() -= Eigen::Map<const Matrix6>(store + off_diagonal_blocks_ + kBlockEntries * p).transpose() *
                     Eigen::Map<const Vector6>(w + ns + kB * below_[p]);
    if (nt > 0)
      z.noalias() -= Eigen::Map<const BorderMatrix>(store + border_ + j * nt * kB, nt, kB).transpose() * w_tail;
    backward_unit(store + diagonal_blocks_ + kBlockEntries * j, kB, z.data());
  }
  for (int s = 0; s < ns; ++s) {
    double value = w[s];
    const double* l = store + scalar_entries_ + scalar_start_[s];
    int k = 0;
    for (int g = segment_start_[s]; g < segment_start_[s + 1]; ++g, k += kB) {
      const double* w_block = w + ns + kB * segment_block_[g];
      for (int r = 0; r < kB; ++r) value -= l[k + r] * w_block[r];
    }
    for (; k < scalar_start_[s + 1] - scalar_start_[s]; ++k) value -= l[k] * w[scalar_target_[scalar_start_[s] + k]];
    w[s] = value;
  }
  x.resize(size_);
  for (int i = 0; i < size_; ++i) x[original_[i]] = w[i];
}

}  // namespace tensegrity
