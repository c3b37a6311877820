#include "formulations/equilibrium.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <map>
#include <utility>

namespace tensegrity {
namespace {

using Triplet = Eigen::Triplet<double>;

// Index of entry (row, col) in the value array of a compressed column-major
// matrix; the pattern is known to contain it.
int value_index(const Eigen::SparseMatrix<double>& M, int row, int col) {
  const int* inner = M.innerIndexPtr();
  const int* begin = inner + M.outerIndexPtr()[col];
  const int* end = inner + M.outerIndexPtr()[col + 1];
  return static_cast<int>(std::lower_bound(begin, end, row) - inner);
}

// Position of (r, c), r >= c, among the six lower entries of a 3x3 block
// stored row by row: (0,0) (1,0) (1,1) (2,0) (2,1) (2,2).
constexpr int lower_entry(int r, int c) { return r * (r + 1) / 2 + c; }

}  // namespace

Equilibrium::Equilibrium(const Structure& s)
    : map_(s), x_(s.positions) {
  const int m = s.num_elements();
  const int nf = map_.num_free();
  const int rows = 3 * nf;
  length_.resize(m);
  unit_.resize(3, m);

  inverse_length_.resize(m);
  slot_a_.resize(m);
  slot_b_.resize(m);
  node_a_.resize(m);
  node_b_.resize(m);
  for (int e = 0; e < m; ++e) {
    node_a_[e] = s.elements[e].a;
    node_b_[e] = s.elements[e].b;
    slot_a_[e] = map_.slot(node_a_[e]);
    slot_b_[e] = map_.slot(node_b_[e]);
  }

  // Per free node, its element ends in element order (so that the sums per
  // node add in the order an element-by-element scatter would).
  {
    incidence_start_.assign(nf + 1, 0);
    for (int e = 0; e < m; ++e)
      for (int end_slot : {slot_a_[e], slot_b_[e]})
        if (end_slot >= 0) ++incidence_start_[end_slot + 1];
    for (int k = 0; k < nf; ++k) incidence_start_[k + 1] += incidence_start_[k];
    incidence_.resize(incidence_start_[nf]);
    std::vector<int> fill(incidence_start_.begin(), incidence_start_.end() - 1);
    for (int e = 0; e < m; ++e) {
      if (slot_a_[e] >= 0) incidence_[fill[slot_a_[e]]++] = 2 * e;
      if (slot_b_[e] >= 0) incidence_[fill[slot_b_[e]]++] = 2 * e + 1;
    }
  }

  // Gravity only when it loads a free node; otherwise f_g stays identically zero.
  fg_ = Eigen::VectorXd::Zero(rows);
  if (s.has_gravity()) {
    const Eigen::VectorXd mass = s.lumped_mass();
    for (int k = 0; k < nf; ++k) {
      const double mk = mass[map_.free_nodes()[k]];
      if (mk > 0.0) has_gravity_ = true;
      fg_.segment<3>(3 * k) = mk * s.gravity;
    }
  }

  // A: column e holds u in the rows of a and -u in the rows of b.
  {
    std::vector<Triplet> t;
    t.reserve(6 * m);
    for (int e = 0; e < m; ++e)
      for (int end_slot : {slot_a_[e], slot_b_[e]})
        if (end_slot >= 0)
          for (int k = 0; k < 3; ++k) t.emplace_back(3 * end_slot + k, e, 1.0);
    A_.resize(rows, m);
    A_.setFromTriplets(t.begin(), t.end());
    A_.makeCompressed();
    a_value_index_.assign(2 * m, -1);
    for (int e = 0; e < m; ++e) {
      if (slot_a_[e] >= 0) a_value_index_[2 * e] = value_index(A_, 3 * slot_a_[e], e);
      if (slot_b_[e] >= 0) a_value_index_[2 * e + 1] = value_index(A_, 3 * slot_b_[e], e);
    }
  }

  // J: every free node's diagonal block, and both off-diagonal blocks of every
  // element with two free ends. Duplicates only merge in the pattern.
  {
    std::vector<Triplet> t;
    t.reserve(9 * (nf + 2 * m));
    auto add_block = [&](int r, int c) {
      for (int j = 0; j < 3; ++j)
        for (int i = 0; i < 3; ++i) t.emplace_back(3 * r + i, 3 * c + j, 0.0);
    };
    for (int k = 0; k < nf; ++k) add_block(k, k);
    for (int e = 0; e < m; ++e)
      if (slot_a_[e] >= 0 && slot_b_[e] >= 0) {
        add_block(slot_a_[e], slot_b_[e]);
        add_block(slot_b_[e], slot_a_[e]);
      }
    J_.resize(rows, rows);
    J_.setFromTriplets(t.begin(), t.end());
    J_.makeCompressed();
    j_value_index_.assign(12 * m, -1);
    for (int e = 0; e < m; ++e) {
      const int sa = slot_a_[e], sb = slot_b_[e];
      const int block_rows[4] = {sa, sa, sb, sb};
      const int block_cols[4] = {sa, sb, sa, sb};
      for (int blk = 0; blk < 4; ++blk) {
        if (block_rows[blk] < 0 || block_cols[blk] < 0) continue;
        for (int j = 0; j < 3; ++j)
          j_value_index_[12 * e + 3 * blk + j] =
              value_index(J_, 3 * block_rows[blk], 3 * block_cols[blk] + j);
      }
    }
  }

  // Hessian of lambda^T f: lower triangle, fixed order (see the header).
  {
    h_diagonal_index_.assign(rows, -1);
    for (int k = 0; k < nf; ++k)
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c <= r; ++c) {
          if (r == c) h_diagonal_index_[3 * k + r] = static_cast<int>(h_rows_.size());
          h_rows_.push_back(3 * k + r);
          h_cols_.push_back(3 * k + c);
        }
    h_element_index_.assign(5 * m, -1);
    std::map<std::pair<int, int>, int> off_block_of_pair;
    for (int e = 0; e < m; ++e) {
      const int sa = slot_a_[e], sb = slot_b_[e];
      if (sa >= 0) h_element_index_[5 * e + 0] = 6 * sa;
      if (sb >= 0) h_element_index_[5 * e + 1] = 6 * sb;
      if (sa < 0 || sb < 0) continue;
      const int hi = std::max(sa, sb), lo = std::min(sa, sb);
      const auto [it, inserted] =
          off_block_of_pair.emplace(std::make_pair(hi, lo), static_cast<int>(h_rows_.size()));
      h_element_index_[5 * e + 2] = it->second;
      if (!inserted) continue;
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) {
          h_rows_.push_back(3 * hi + r);
          h_cols_.push_back(3 * lo + c);
        }
    }
    for (int e = 0; e < m; ++e) {
      const int sa = slot_a_[e], sb = slot_b_[e];
      if (sa >= 0) {
        h_element_index_[5 * e + 3] = static_cast<int>(h_rows_.size());
        for (int k = 0; k < 3; ++k) {
          h_rows_.push_back(rows + e);
          h_cols_.push_back(3 * sa + k);
        }
      }
      if (sb >= 0) {
        h_element_index_[5 * e + 4] = static_cast<int>(h_rows_.size());
        for (int k = 0; k < 3; ++k) {
          h_rows_.push_back(rows + e);
          h_cols_.push_back(3 * sb + k);
        }
      }
    }
  }

  refresh();
}

void Equilibrium::set_positions(const Eigen::Matrix3Xd& positions) {
  assert(positions.cols() == x_.cols());
  x_ = positions;  // same shape: no allocation
  refresh();
}

void Equilibrium::set_free_coordinates(const Eigen::VectorXd& q) {
  map_.scatter(q, x_);
  refresh();
}

void Equilibrium::set_free_coordinates_and_residual(const Eigen::VectorXd& q, const Eigen::VectorXd& sigma,
                                                    Eigen::VectorXd& f) {
  map_.scatter(q, x_);
  update_elements();
  residual(sigma, f);
  a_values_stale_ = true;
}

void Equilibrium::update_elements() {
  degenerate_ = false;
  for (int e = 0; e < num_elements(); ++e) {
    const Eigen::Vector3d d = x_.col(node_b_[e]) - x_.col(node_a_[e]);
    const double l = d.norm();
    length_[e] = l;
    if (l > 0.0) {
      inverse_length_[e] = 1.0 / l;
      unit_.col(e) = d / l;
    } else {  // zero or NaN length: no direction
      degenerate_ = true;
      inverse_length_[e] = 0.0;
      unit_.col(e).setZero();
    }
  }
}

void Equilibrium::write_a_values() const {
  double* a_values = A_.valuePtr();
  for (int e = 0; e < num_elements(); ++e) {
    const int ia = a_value_index_[2 * e], ib = a_value_index_[2 * e + 1];
    for (int k = 0; k < 3; ++k) {
      if (ia >= 0) a_values[ia + k] = unit_(k, e);
      if (ib >= 0) a_values[ib + k] = -unit_(k, e);
    }
  }
  a_values_stale_ = false;
}

void Equilibrium::refresh() {
  update_elements();
  write_a_values();
}

Eigen::VectorXd Equilibrium::residual(const Eigen::VectorXd& sigma) const {
  Eigen::VectorXd f;
  residual(sigma, f);
  return f;
}

void Equilibrium::residual(const Eigen::VectorXd& sigma, Eigen::VectorXd& f) const {
  // A sum per node over its element ends (in element order, so the bits are
  // those of an element-by-element scatter): scattering into f chains every
  // update of a node on the previous one's store.
  const int nf = map_.num_free();
  f.resize(3 * nf);
  for (int k = 0; k < nf; ++k) {
    Eigen::Vector3d sum = has_gravity_ ? Eigen::Vector3d(fg_.segment<3>(3 * k)) : Eigen::Vector3d::Zero();
    for (int j = incidence_start_[k]; j < incidence_start_[k + 1]; ++j) {
      const int e = incidence_[j] >> 1;  // 2 e: end a (+ sigma u), 2 e + 1: end b (- sigma u)
      const Eigen::Vector3d force = sigma[e] * unit_.col(e);
      if (incidence_[j] & 1)
        sum -= force;
      else
        sum += force;
    }
    f.segment<3>(3 * k) = sum;
  }
}

const Eigen::SparseMatrix<double>& Equilibrium::jacobian_positions(const Eigen::VectorXd& sigma) {
  double* values = J_.valuePtr();
  std::fill(values, values + J_.nonZeros(), 0.0);
  // d f_a / d x_b = sigma du/dd = K; the other blocks follow from d = x_b - x_a.
  const double block_sign[4] = {-1.0, 1.0, 1.0, -1.0};
  for (int e = 0; e < num_elements(); ++e) {
    const double l = length_[e];
    if (!(l > 0.0)) continue;
    const Eigen::Vector3d u = unit_.col(e);
    const Eigen::Matrix3d K = (sigma[e] / l) * (Eigen::Matrix3d::Identity() - u * u.transpose());
    for (int blk = 0; blk < 4; ++blk) {
      const int* start = &j_value_index_[12 * e + 3 * blk];
      if (start[0] < 0) continue;
      for (int j = 0; j < 3; ++j)
        for (int i = 0; i < 3; ++i) values[start[j] + i] += block_sign[blk] * K(i, j);
    }
  }
  return J_;
}

void Equilibrium::jacobian_positions_product(const Eigen::VectorXd& sigma, const Eigen::VectorXd& v,
                                             Eigen::VectorXd& out) const {
  assert(&out != &v);
  out.setZero(num_equations());
  for (int e = 0; e < num_elements(); ++e) {
    const double inverse = inverse_length_[e];
    if (!(inverse > 0.0)) continue;
    const int sa = slot_a_[e], sb = slot_b_[e];
    Eigen::Vector3d w = Eigen::Vector3d::Zero();
    if (sb >= 0) w = v.segment<3>(3 * sb);
    if (sa >= 0) w -= v.segment<3>(3 * sa);
    const Eigen::Vector3d u = unit_.col(e);
    const Eigen::Vector3d k = (sigma[e] * inverse) * (w - u.dot(w) * u);  // K w
    if (sa >= 0) out.segment<3>(3 * sa) += k;
    if (sb >= 0) out.segment<3>(3 * sb) -= k;
  }
}

void Equilibrium::hessian_structure(std::vector<int>& rows, std::vector<int>& cols) const {
  rows = h_rows_;
  cols = h_cols_;
}

int Equilibrium::hessian_nonzeros() const { return static_cast<int>(h_rows_.size()); }

void Equilibrium::hessian_values(const Eigen::VectorXd& sigma, const Eigen::VectorXd& lambda,
                                 double* values) const {
  std::fill(values, values + hessian_nonzeros(), 0.0);
  for (int e = 0; e < num_elements(); ++e) {
    const double l = length_[e];
    if (!(l > 0.0)) continue;
    const int sa = slot_a_[e], sb = slot_b_[e];
    Eigen::Vector3d w = Eigen::Vector3d::Zero();
    if (sa >= 0) w += lambda.segment<3>(3 * sa);
    if (sb >= 0) w -= lambda.segment<3>(3 * sb);
    const Eigen::Vector3d u = unit_.col(e);
    const double wu = w.dot(u);
    const Eigen::Matrix3d uut = u * u.transpose();
    // sigma_e times the Hessian of w.u(d) with respect to d.
    const Eigen::Matrix3d H =
        (-sigma[e] / (l * l)) *
        (w * u.transpose() + u * w.transpose() + wu * (Eigen::Matrix3d::Identity() - 3.0 * uut));
    const int* index = &h_element_index_[5 * e];
    for (int end = 0; end < 2; ++end) {
      if (index[end] < 0) continue;
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c <= r; ++c) values[index[end] + lower_entry(r, c)] += H(r, c);
    }
    if (index[2] >= 0)
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) values[index[2] + 3 * r + c] -= H(r, c);
    const Eigen::Vector3d Pw = (w - wu * u) / l;
    for (int k = 0; k < 3; ++k) {
      if (index[3] >= 0) values[index[3] + k] -= Pw[k];
      if (index[4] >= 0) values[index[4] + k] += Pw[k];
    }
  }
}

}  // namespace tensegrity
