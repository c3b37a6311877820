#include "kernels/normal_matrix.hpp"

#include <Eigen/OrderingMethods>
#include <algorithm>
#include <stdexcept>

namespace tensegrity {
namespace {

// Where the three rows of node block `node` start in column `col`, or -1.
int block_start(const Eigen::SparseMatrix<double>& M, int col, int node) {
  const int* inner = M.innerIndexPtr();
  const int* begin = inner + M.outerIndexPtr()[col];
  const int* end = inner + M.outerIndexPtr()[col + 1];
  const int* it = std::lower_bound(begin, end, 3 * node);
  if (it == end || *it != 3 * node) return -1;
  if (end - it < 3 || it[1] != 3 * node + 1 || it[2] != 3 * node + 2)
    throw std::logic_error("NormalMatrix: a node block of the Jacobian or of A is not dense");
  return static_cast<int>(it - inner);
}

}  // namespace

NormalMatrix::NormalMatrix(const SparseMatrix& J, const SparseMatrix& A, const Eigen::VectorXd* normalisation_row)
    : nodes_(static_cast<int>(J.rows()) / 3),
      size_(3 * nodes_ + (normalisation_row ? 1 : 0)),
      has_norm_(normalisation_row != nullptr) {
  if (J.rows() != 3 * nodes_ || J.cols() != J.rows() || A.rows() != J.rows())
    throw std::logic_error("NormalMatrix: J must be square with 3 rows per free node, A must match");
  const int m = static_cast<int>(A.cols());

  // Node blocks of J, column block by column block: J_ab is read from the
  // three columns of b at the rows of a.
  j_column_begin_.assign(nodes_ + 1, 0);
  for (int b = 0; b < nodes_; ++b) {
    const int col = 3 * b;
    const int* inner = J.innerIndexPtr();
    for (int p = J.outerIndexPtr()[col]; p < J.outerIndexPtr()[col + 1]; p += 3) {
      const int a = inner[p] / 3;
      JBlock blk;
      blk.node = a;
      for (int j = 0; j < 3; ++j) {
        blk.offset[j] = block_start(J, col + j, a);
        if (blk.offset[j] < 0) throw std::logic_error("NormalMatrix: J's columns of one node differ in pattern");
      }
      j_blocks_.push_back(blk);
    }
    j_column_begin_[b + 1] = static_cast<int>(j_blocks_.size());
  }

  // Node graph of N: a ~ c when both meet some column block b of J (J J^T),
  // or are the free ends of one element (A W A^T; with J = df/dq those are
  // J-adjacent already, but not with a block-diagonal J). J's block pattern
  // is symmetric, so the neighbours of a are the rows of the columns b of a.
  std::vector<std::vector<int>> neighbours(nodes_);
  for (int a = 0; a < nodes_; ++a)
    for (int k1 = j_column_begin_[a]; k1 < j_column_begin_[a + 1]; ++k1) {
      const int b = j_blocks_[k1].node;
      for (int k2 = j_column_begin_[b]; k2 < j_column_begin_[b + 1]; ++k2) neighbours[a].push_back(j_blocks_[k2].node);
    }
  for (int e = 0; e < m; ++e) {
    const int begin = A.outerIndexPtr()[e], end = A.outerIndexPtr()[e + 1];
    if (end - begin != 6) continue;  // fewer than two free ends
    const int a = A.innerIndexPtr()[begin] / 3, c = A.innerIndexPtr()[begin + 3] / 3;
    neighbours[a].push_back(c);
    neighbours[c].push_back(a);
  }
  std::vector<int> adjacent_begin(nodes_ + 1, 0), adjacent;
  for (int a = 0; a < nodes_; ++a) {
    std::vector<int>& list = neighbours[a];
    std::sort(list.begin(), list.end());
    list.erase(std::unique(list.begin(), list.end()), list.end());
    adjacent.insert(adjacent.end(), list.begin(), list.end());
    adjacent_begin[a + 1] = static_cast<int>(adjacent.size());
  }

  // Fill-reducing ordering of the node graph (3x3 blocks eliminate together);
  // the normalisation unknown, coupled to every cable end, goes last.
  new_node_.resize(nodes_);
  {
    SparseMatrix graph(nodes_, nodes_);
    graph.resizeNonZeros(static_cast<int>(adjacent.size()));
    std::copy(adjacent_begin.begin(), adjacent_begin.end(), graph.outerIndexPtr());
    std::copy(adjacent.begin(), adjacent.end(), graph.innerIndexPtr());
    std::fill(graph.valuePtr(), graph.valuePtr() + adjacent.size(), 1.0);
    Eigen::AMDOrdering<int> amd;
    Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> inverse;
    amd(graph, inverse);
    if (inverse.size() == nodes_) {
      for (int a = 0; a < nodes_; ++a) new_node_[inverse.indices()[a]] = a;
    } else {
      for (int a = 0; a < nodes_; ++a) new_node_[a] = a;
    }
  }

  // Lower block pattern in the new numbering; the normalisation unknown is
  // block `nodes_` (its two padding entries get a unit diagonal).
  const int blocks = nodes_ + (has_norm_ ? 1 : 0);
  std::vector<std::vector<int>> lower(blocks);
  for (int a = 0; a < nodes_; ++a)
    for (int p = adjacent_begin[a]; p < adjacent_begin[a + 1]; ++p) {
      const int c = adjacent[p];
      if (new_node_[a] >= new_node_[c]) lower[new_node_[c]].push_back(new_node_[a]);
    }
  std::vector<char> touches_norm(nodes_, 0);
  if (has_norm_) {
    for (int e = 0; e < m; ++e)
      if ((*normalisation_row)[e] != 0.0)
        for (int p = A.outerIndexPtr()[e]; p < A.outerIndexPtr()[e + 1]; p += 3)
          touches_norm[A.innerIndexPtr()[p] / 3] = 1;
    for (int a = 0; a < nodes_; ++a)
      if (touches_norm[a]) lower[new_node_[a]].push_back(nodes_);
    lower[nodes_].push_back(nodes_);
  }
  factor_.analyze(lower);

  // Storage of N's blocks: every (a, c) in old numbers is stored as the
  // lower-triangle block (max, min) of the new numbers; the slots of all
  // blocks the plans touch are resolved in one pass.
  std::vector<std::pair<int, int>> requests;
  auto request = [&](int a, int c) {
    const int r = std::max(new_node_[a], new_node_[c]), col = std::min(new_node_[a], new_node_[c]);
    requests.emplace_back(r, col);
    return static_cast<int>(requests.size()) - 1;
  };
  // J J^T plan: every ordered pair (k1, k2) of blocks in one column block b
  // of J with new(a1) >= new(a2) adds J_a1b J_a2b^T to the stored block.
  for (int b = 0; b < nodes_; ++b)
    for (int k1 = j_column_begin_[b]; k1 < j_column_begin_[b + 1]; ++k1)
      for (int k2 = j_column_begin_[b]; k2 < j_column_begin_[b + 1]; ++k2) {
        const int a1 = j_blocks_[k1].node, a2 = j_blocks_[k2].node;
        if (new_node_[a1] >= new_node_[a2]) jj_plan_.push_back({k1, k2, request(a1, a2)});
      }
  // A W A^T plan: per element its (one or two) node blocks, the first with
  // the larger new index, so that block (end 0, end 1) is in the lower triangle.
  a_column_.resize(m);
  for (int e = 0; e < m; ++e) {
    AColumn& col = a_column_[e];
    for (int p = A.outerIndexPtr()[e]; p < A.outerIndexPtr()[e + 1]; p += 3) {
      if (col.count == 2) throw std::logic_error("NormalMatrix: a column of A touches more than two nodes");
      col.node[col.count] = A.innerIndexPtr()[p] / 3;
      col.value_offset[col.count] = p;
      ++col.count;
    }
    if (col.count == 2 && new_node_[col.node[0]] < new_node_[col.node[1]]) {
      std::swap(col.node[0], col.node[1]);
      std::swap(col.value_offset[0], col.value_offset[1]);
    }
    for (int k = 0; k < col.count; ++k) {
      col.diagonal[k] = factor_.slot(new_node_[col.node[k]], new_node_[col.node[k]]);
      col.norm[k] = -1;
      if (has_norm_ && touches_norm[col.node[k]]) {
        requests.emplace_back(nodes_, new_node_[col.node[k]]);
        col.norm[k] = static_cast<int>(requests.size()) - 1;
      }
    }
    if (col.count == 2) col.off_diagonal = request(col.node[0], col.node[1]);
    col.normalised = has_norm_ && (*normalisation_row)[e] != 0.0;
  }
  const std::vector<int> slots = factor_.slots(requests);
  for (JjEntry& p : jj_plan_) p.target = slots[p.target];
  for (AColumn& col : a_column_) {
    for (int k = 0; k < col.count; ++k)
      if (col.norm[k] >= 0) col.norm[k] = slots[col.norm[k]];
    if (col.count == 2) col.off_diagonal = slots[col.off_diagonal];
  }
  norm_diagonal_ = has_norm_ ? factor_.slot(nodes_, nodes_) : -1;
  diagonal_slot_.resize(nodes_);
  for (int s = 0; s < nodes_; ++s) diagonal_slot_[s] = factor_.slot(s, s);
  x_.resize(3 * blocks);
}

bool NormalMatrix::assemble_and_factorize(const SparseMatrix& J, double wq, const SparseMatrix& A,
                                          const Eigen::VectorXd& ws, double norm_weight, double lambda_relative,
                                          double norm_shift) {
  factor_.set_zero();
  const double* jv = J.valuePtr();
  for (const JjEntry& p : jj_plan_) {
    const JBlock& b1 = j_blocks_[p.first];
    const JBlock& b2 = j_blocks_[p.second];
    // (J_a1b J_a2b^T)(i, j) = sum_k J_a1b(i, k) J_a2b(j, k); column k of a
    // block of J is three contiguous values.
    Eigen::Matrix3d m1, m2;
    for (int k = 0; k < 3; ++k) {
      m1.col(k) = Eigen::Map<const Eigen::Vector3d>(jv + b1.offset[k]);
      m2.col(k) = Eigen::Map<const Eigen::Vector3d>(jv + b2.offset[k]);
    }
    factor_.block(p.target).noalias() += wq * m1 * m2.transpose();
  }
  const double* av = A.valuePtr();
  double norm_diagonal = 0.0;
  for (int e = 0; e < static_cast<int>(a_column_.size()); ++e) {
    const double w = ws[e];
    if (w == 0.0) continue;
    const AColumn& col = a_column_[e];
    for (int k = 0; k < col.count; ++k) {
      const Eigen::Map<const Eigen::Vector3d> v(av + col.value_offset[k]);
      factor_.block(col.diagonal[k]).noalias() += w * v * v.transpose();
      if (col.normalised) factor_.block(col.norm[k]).row(0) += (w * norm_weight) * v.transpose();
    }
    if (col.count == 2) {
      const Eigen::Map<const Eigen::Vector3d> v0(av + col.value_offset[0]), v1(av + col.value_offset[1]);
      factor_.block(col.off_diagonal).noalias() += w * v0 * v1.transpose();
    }
    if (col.normalised) norm_diagonal += w * norm_weight * norm_weight;
  }
  double trace = norm_diagonal;
  for (int slot : diagonal_slot_) trace += factor_.block(slot).trace();
  const double lambda = lambda_relative * (trace > 0.0 ? trace / size_ : 1.0);
  for (int slot : diagonal_slot_) factor_.block(slot).diagonal().array() += lambda;
  if (has_norm_) factor_.block(norm_diagonal_).diagonal() << norm_diagonal + lambda + norm_shift, 1.0, 1.0;
  return factor_.factorize();
}

void NormalMatrix::solve(const Eigen::VectorXd& rhs, Eigen::VectorXd& y) {
  x_.setZero();
  for (int a = 0; a < nodes_; ++a) x_.segment<3>(3 * new_node_[a]) = rhs.segment<3>(3 * a);
  if (has_norm_) x_[3 * nodes_] = rhs[size_ - 1];
  factor_.solve(x_);
  for (int a = 0; a < nodes_; ++a) y.segment<3>(3 * a) = x_.segment<3>(3 * new_node_[a]);
  if (has_norm_) y[size_ - 1] = x_[3 * nodes_];
}

}  // namespace tensegrity
