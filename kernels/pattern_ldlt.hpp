#pragma once
// Sparse LDL^T of a symmetric matrix whose sparsity pattern never changes, for
// many numeric factorizations of new values (the stress QP refactorizes its
// matrix K at every geometry and every change of its held set).
//
// It is Eigen's SimplicialLDLT (AMD ordering, lower triangle given; Tim
// Davis's up-looking LDL algorithm) with the per-factorization symbolic work
// done once: the permutation of the values into the ordered matrix becomes a
// table of value positions, and each row's pattern of L (the elimination-tree
// walk, in the order Eigen's factorization discovers it) becomes a list. The
// numeric loop performs the same floating-point operations in the same order
// as Eigen's factorize(), so L and D are equal to Eigen's bit for bit (a test
// holds it to that); solve() is Eigen's own.
#include <Eigen/OrderingMethods>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <vector>

namespace tensegrity {

class PatternLdlt : public Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::AMDOrdering<int>> {
 public:
  using Base = Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::AMDOrdering<int>>;

  // Orders and analyses `lower` (its lower triangle, compressed); the values
  // are ignored. Every later factorization must pass values in this pattern.
  void analyze(const Eigen::SparseMatrix<double>& lower);
  // The same with the caller's elimination order (order[k]: the variable
  // eliminated k-th) in place of AMD's, for callers that know the structure.
  void analyze(const Eigen::SparseMatrix<double>& lower, const Eigen::VectorXi& order);

  // Factorizes the matrix whose lower-triangle values, in the analysed
  // pattern's storage order, are `values`. False when a pivot is zero (then
  // info() is NumericalIssue), as Eigen's factorize().
  bool factorize_values(const double* values);

 private:
  // Everything after the ordering: the tables below from m_P.
  void analyze_ordered(const Eigen::SparseMatrix<double>& lower);
  // Per column k of the ordered upper triangle: the entries in Eigen's storage
  // order, as the row and the position of the value in the caller's array.
  std::vector<int> column_start_, entry_row_, entry_source_;
  // Per row k of L: its nonzero columns i in the order of the up-looking
  // factorization, and where L(k, i) is stored (the end of column i's entries so far).
  std::vector<int> pattern_start_, pattern_column_, pattern_store_;
  std::vector<double> y_;  // dense work row, all zero between factorizations
};

}  // namespace tensegrity
