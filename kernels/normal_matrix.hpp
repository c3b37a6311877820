#pragma once
// The normal matrix of the joint Gauss-Newton steps in z = (q, sigma):
//
//   N = wq J J^T + sum_e w_e b_e b_e^T + lambda I,    b_e = [a_e; w_n c_e],
//
// where J = df/dq (3 n_free square, Equilibrium::jacobian_positions), a_e is
// column e of A (Equilibrium::A) and the optional last row holds the force
// normalisation c^T sigma = t with weight w_n (ForceScale). N has the size of
// the equations (3 n_free, + 1 with the normalisation) and the node-adjacency
// pattern, whatever the number of elements. The stress QP's node space
// (StressQpOptions::node_space) is the same matrix with J = I in 3x3 blocks,
// w_e = 1/D_e and the normalisation's diagonal shifted by 1.
//
// The pattern is built once per topology at the level of 3x3 node blocks
// (J J^T couples nodes two elements apart), ordered by AMD on the node graph,
// and analysed symbolically once; every assembly writes values in place
// through precomputed block plans (upper triangle, permuted numbering) and
// only refactorizes numerically (BlockCholesky). The patterns of J and A must
// not change.
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <array>
#include <vector>

#include "kernels/block_cholesky.hpp"

namespace tensegrity {

class NormalMatrix {
 public:
  using SparseMatrix = Eigen::SparseMatrix<double>;
  // normalisation_row: c (m entries) or nullptr when there is no normalisation.
  NormalMatrix(const SparseMatrix& J, const SparseMatrix& A, const Eigen::VectorXd* normalisation_row);

  int size() const { return size_; }

  // Assembles with weight wq on every J column, ws[e] on force column e and
  // the normalisation entry norm_weight, adds lambda_relative times the mean
  // diagonal, and norm_shift to the normalisation's diagonal entry (which J
  // does not reach), and factorizes. Returns false when the factorization
  // fails or N is not positive definite. Does not allocate.
  bool assemble_and_factorize(const SparseMatrix& J, double wq, const SparseMatrix& A, const Eigen::VectorXd& ws,
                              double norm_weight, double lambda_relative, double norm_shift = 0.0);

  // y = N^{-1} rhs, both in the original numbering. Does not allocate.
  void solve(const Eigen::VectorXd& rhs, Eigen::VectorXd& y);

 private:
  struct JBlock {
    int node;                   // row block a of J_ab (b: the column block it is listed under)
    std::array<int, 3> offset;  // start of rows 3a..3a+2 in J's value array, per column of b
  };
  struct JjEntry {              // N block (a1, a2) += J_a1b J_a2b^T
    int first, second;          // indices into j_blocks_
    int target;                 // slot in the factor's storage
  };
  struct AColumn {              // one element: its free ends' blocks of A (larger new index first)
    int count = 0;
    std::array<int, 2> node{}, value_offset{}, diagonal{}, norm{};
    int off_diagonal = -1;
    bool normalised = false;
  };

  int nodes_, size_;
  bool has_norm_;
  std::vector<JBlock> j_blocks_;
  std::vector<int> j_column_begin_;
  std::vector<JjEntry> jj_plan_;
  std::vector<AColumn> a_column_;
  std::vector<int> new_node_, diagonal_slot_;
  int norm_diagonal_ = -1;
  BlockCholesky factor_;
  Eigen::VectorXd x_;
};

}  // namespace tensegrity
