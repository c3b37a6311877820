#include "kernels/pattern_ldlt.hpp"

#include <algorithm>

namespace tensegrity {

void PatternLdlt::analyze(const Eigen::SparseMatrix<double>& lower) {
  Base::analyzePattern(lower);
  analyze_ordered(lower);
}

void PatternLdlt::analyze(const Eigen::SparseMatrix<double>& lower, const Eigen::VectorXi& order) {
  const int n = static_cast<int>(lower.cols());
  // Eigen's convention: m_Pinv lists the variables in elimination order and
  // m_P = m_Pinv^{-1} maps a variable to its position.
  m_Pinv.indices() = order;
  m_P = m_Pinv.inverse();
  Eigen::SparseMatrix<double> ordered(n, n);
  ordered.selfadjointView<Eigen::Upper>() = lower.selfadjointView<Eigen::Lower>().twistedBy(m_P);
  analyzePattern_preordered(ordered, true);
  analyze_ordered(lower);
}

void PatternLdlt::analyze_ordered(const Eigen::SparseMatrix<double>& lower) {
  const int n = static_cast<int>(lower.cols());

  // The ordered upper triangle that Eigen's factorize() builds, with every
  // value replaced by its position in `lower`: the permutation as a table.
  Eigen::SparseMatrix<double> coded = lower;
  coded.makeCompressed();
  for (int p = 0; p < static_cast<int>(coded.nonZeros()); ++p) coded.valuePtr()[p] = p;
  Eigen::SparseMatrix<double> ordered(n, n);
  ordered.selfadjointView<Eigen::Upper>() = coded.selfadjointView<Eigen::Lower>().twistedBy(m_P);
  column_start_.assign(n + 1, 0);
  entry_row_.clear();
  entry_source_.clear();
  for (int k = 0; k < n; ++k) {
    for (Eigen::SparseMatrix<double>::InnerIterator it(ordered, k); it; ++it) {
      if (it.index() > k) continue;  // as Eigen's factorization: the upper triangle only
      entry_row_.push_back(static_cast<int>(it.index()));
      entry_source_.push_back(static_cast<int>(it.value()));
    }
    column_start_[k + 1] = static_cast<int>(entry_row_.size());
  }

  // Each row's pattern of L by the elimination-tree walk of Eigen's
  // factorize_preordered, in the same order, and L's row indices (which
  // depend on the pattern alone).
  std::vector<int> tags(n), stack(n), count(n, 0);
  const int* Lp = m_matrix.outerIndexPtr();
  int* Li = m_matrix.innerIndexPtr();
  pattern_start_.assign(n + 1, 0);
  pattern_column_.clear();
  pattern_store_.clear();
  for (int k = 0; k < n; ++k) {
    int top = n;
    tags[k] = k;
    for (int e = column_start_[k]; e < column_start_[k + 1]; ++e) {
      int i = entry_row_[e];
      int len = 0;
      for (; tags[i] != k; i = m_parent[i]) {
        stack[len++] = i;
        tags[i] = k;
      }
      while (len > 0) stack[--top] = stack[--len];
    }
    for (; top < n; ++top) {
      const int i = stack[top];
      const int p = Lp[i] + count[i]++;
      Li[p] = k;
      pattern_column_.push_back(i);
      pattern_store_.push_back(p);
    }
    pattern_start_[k + 1] = static_cast<int>(pattern_column_.size());
  }
  for (int k = 0; k < n; ++k) m_nonZerosPerCol[k] = count[k];
  y_.assign(n, 0.0);
  m_diag.resize(n);
  m_factorizationIsOk = false;
}

bool PatternLdlt::factorize_values(const double* values) {
  const int n = static_cast<int>(y_.size());
  const int* Lp = m_matrix.outerIndexPtr();
  const int* Li = m_matrix.innerIndexPtr();
  double* Lx = m_matrix.valuePtr();
  double* diag = m_diag.data();
  double* y = y_.data();
  bool ok = true;
  for (int k = 0; k < n; ++k) {
    y[k] = 0.0;
    for (int e = column_start_[k]; e < column_start_[k + 1]; ++e) y[entry_row_[e]] += values[entry_source_[e]];
    double d = y[k] * m_shiftScale + m_shiftOffset;
    y[k] = 0.0;
    for (int t = pattern_start_[k]; t < pattern_start_[k + 1]; ++t) {
      const int i = pattern_column_[t];
      const double yi = y[i];
      y[i] = 0.0;
      const double l_ki = yi / diag[i];
      const int end = pattern_store_[t];
      for (int p = Lp[i]; p < end; ++p) y[Li[p]] -= Lx[p] * yi;
      d -= l_ki * yi;
      Lx[end] = l_ki;
    }
    diag[k] = d;
    if (d == 0.0) {
      ok = false;
      std::fill(y_.begin(), y_.end(), 0.0);
      break;
    }
  }
  m_info = ok ? Eigen::Success : Eigen::NumericalIssue;
  m_factorizationIsOk = true;
  return ok;
}

}  // namespace tensegrity
