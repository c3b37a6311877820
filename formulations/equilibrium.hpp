#pragma once
// Nodal equilibrium f(x, sigma) = A(x) sigma + f_g over the free nodes.
//
// For element e joining nodes a and b with d = x_b - x_a, l = |d|, u = d / l, a
// force sigma_e (> 0 tension) acts on a as +sigma_e u and on b as -sigma_e u.
// A(x) is 3 n_free x m with at most six non-zeros per column (u and -u in the
// rows of the free ends). f_g stacks m_i g over free nodes (zero without
// gravity or without mass on free nodes, and then never assembled: has_gravity()
// is false and residual() adds nothing). Units: N.
//
// Sparsity patterns are built once in the constructor; set_positions and the
// derivative evaluations only write values, in the same order every call.
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <vector>

#include "formulations/free_nodes.hpp"
#include "model/structure.hpp"

namespace tensegrity {

class Equilibrium {
 public:
  explicit Equilibrium(const Structure& s);

  const FreeNodeMap& free_nodes() const { return map_; }
  int num_equations() const { return 3 * map_.num_free(); }
  int num_elements() const { return static_cast<int>(node_a_.size()); }

  // Sets the geometry (3 x n, fixed nodes at their scene positions) and
  // refreshes lengths, directions and the values of A. The constructor starts
  // at the structure's own positions.
  void set_positions(const Eigen::Matrix3Xd& positions);
  // Same, from the free coordinates q (3 n_free).
  void set_free_coordinates(const Eigen::VectorXd& q);
  // Same, and f = A sigma + f_g at q in the same call (as residual()
  // computes it, to the bit). A's values are written only when A()
  // is next called: Algorithm 1's line search evaluates many trial geometries
  // that need f alone. (So A(), although const, may write: one Equilibrium
  // must not be used from two threads at once; nothing shares one.)
  void set_free_coordinates_and_residual(const Eigen::VectorXd& q, const Eigen::VectorXd& sigma,
                                         Eigen::VectorXd& f);

  const Eigen::Matrix3Xd& positions() const { return x_; }
  const Eigen::VectorXd& lengths() const { return length_; }       // m
  const Eigen::Matrix3Xd& directions() const { return unit_; }     // u_e
  const Eigen::SparseMatrix<double>& A() const {                   // 3 n_free x m
    if (a_values_stale_) write_a_values();
    return A_;
  }
  const Eigen::VectorXd& gravity_load() const { return fg_; }      // 3 n_free
  bool has_gravity() const { return has_gravity_; }

  // f = A sigma + f_g (3 n_free).
  Eigen::VectorXd residual(const Eigen::VectorXd& sigma) const;
  void residual(const Eigen::VectorXd& sigma, Eigen::VectorXd& f) const;

  // J = df/dq at the current geometry (3 n_free x 3 n_free, symmetric,
  // 3x3 blocks on node adjacency plus every free node's diagonal block).
  // Pattern fixed; values rewritten. Element e adds K = sigma_e (I - u u^T) / l
  // as -K to blocks (a,a), (b,b) and +K to (a,b), (b,a).
  const Eigen::SparseMatrix<double>& jacobian_positions(const Eigen::VectorXd& sigma);
  // out = J v with J = df/dq above, element by element without assembling J
  // (J is symmetric, so this is also J^T v): element e adds K (v_b - v_a) to
  // the rows of a and subtracts it from those of b (v of a fixed end = 0).
  // Cheaper than refreshing J's values and multiplying, for a loop
  // (Algorithm 1's gradient steps) that needs two products per geometry.
  // It scales by sigma_e * (1 / l) (one division per element per geometry,
  // in the update), so its values may differ from J's by an ulp.
  // out must not alias v; it is resized only when its size is wrong.
  void jacobian_positions_product(const Eigen::VectorXd& sigma, const Eigen::VectorXd& v,
                                  Eigen::VectorXd& out) const;

  // Hessian of lambda^T f(q, sigma) with respect to z = (q, sigma), lower
  // triangle only, as triplets whose (row, col) order never changes:
  // hessian_structure() once, hessian_values() every call. The sigma-sigma
  // block is zero (f is linear in sigma) and absent. Element e contributes
  // sigma_e w.u with w = lambda_a - lambda_b (lambda of fixed ends = 0):
  //   d2/dx_b2 = d2/dx_a2 = -d2/dx_a dx_b = sigma_e H,
  //   H = -[w u^T + u w^T + (w.u)(I - 3 u u^T)] / l^2,
  //   d2/dsigma_e dx_b = -d2/dsigma_e dx_a = (I - u u^T) w / l.
  // Order: the 6 lower entries of every free node's diagonal block (slot
  // order), then one 3x3 block per adjacent free pair, then the sigma rows
  // (row 3 n_free + e). Uses the current geometry; lambda has 3 n_free entries.
  void hessian_structure(std::vector<int>& rows, std::vector<int>& cols) const;
  void hessian_values(const Eigen::VectorXd& sigma, const Eigen::VectorXd& lambda,
                      double* values) const;
  int hessian_nonzeros() const;
  // Position in the triplet list of the diagonal entry (k, k), 0 <= k < 3 n_free:
  // every free coordinate has one (for objective terms on q).
  int hessian_diagonal_index(int k) const { return h_diagonal_index_[k]; }

  // True when some element has zero length at the current geometry; its
  // direction and derivative terms are then set to zero instead of NaN.
  bool degenerate() const { return degenerate_; }

 private:
  void refresh();  // lengths, directions and A values from x_
  // Lengths, inverse lengths and directions from x_ (a zero-length element
  // has direction 0 and sets degenerate_).
  void update_elements();
  void write_a_values() const;

  FreeNodeMap map_;
  Eigen::Matrix3Xd x_;
  Eigen::VectorXd length_;
  Eigen::Matrix3Xd unit_;
  Eigen::VectorXd inverse_length_;  // 1 / l, 0 at zero length
  mutable Eigen::SparseMatrix<double> A_;
  mutable bool a_values_stale_ = false;
  Eigen::SparseMatrix<double> J_;
  Eigen::VectorXd fg_;
  bool has_gravity_ = false;
  bool degenerate_ = false;
  // Per element, the free slots of its ends (-1 for a fixed end).
  std::vector<int> slot_a_, slot_b_;
  std::vector<int> node_a_, node_b_;  // per element, its end nodes a and b
  // Per free slot k, entries incidence_start_[k] .. incidence_start_[k + 1] of
  // incidence_: 2 e for end a of element e, 2 e + 1 for end b.
  std::vector<int> incidence_start_, incidence_;
  // Per element, where the three u entries of end a / end b start in A_'s value
  // array (-1 for a fixed end).
  std::vector<int> a_value_index_;   // 2 per element
  // Per element, blocks (a,a), (a,b), (b,a), (b,b) of J_, three columns each:
  // where the column's three contiguous values start (-1 for a fixed end).
  std::vector<int> j_value_index_;   // 12 per element
  // Hessian triplets and, per element, where its diagonal blocks (a,a) and (b,b)
  // (6 lower-triangle entries each), its off-diagonal block (9 entries, row-major,
  // rows of the higher slot) and its sigma row (3 or 6 entries) start.
  std::vector<int> h_rows_, h_cols_;
  std::vector<int> h_element_index_;  // 5 per element
  std::vector<int> h_diagonal_index_; // per q coordinate
};

}  // namespace tensegrity
