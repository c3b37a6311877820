#pragma once
// The elastic energy of a built tensegrity (paper, Eq. 1): what the simulator,
// the static relax and the stability analysis minimise or differentiate.
//
//   E(x) = sum_cables  L_e W_e(eps_e)                         eps_e = l_e / L_e - 1
//        + sum_struts  EA_e / (2 L_e) (l_e - L_e)^2
//        - sum_i m_i g . x_i                                   (gravity potential)
//        + sum_drags  k_d / 2 |x_i - t_d|^2                    (user drag springs)
//
// in J, with W_e(eps) = int_0^eps f_e(s) ds and the cable force (N)
//
//   f(eps) = 0                        when eps <= 0 (slack: l <= L),
//          = max(0, g(eps))           otherwise,
//
// g the material's force-strain polynomial F (model/material.hpp) on its
// measured strain range, continued linearly (value and slope of F at the end
// of the range) outside it, so that large drags stay finite instead of
// throwing. A fitted curve with F(0) < 0 (fits of real cords can have one)
// carries nothing until g crosses zero; one with F(0) > 0 jumps by F(0) at
// eps = 0. The element force sigma_e = dE/dl_e is positive in tension
// (docs/FORMATS.md).
//
// Struts are stiff linear springs rather than constraints, so one sparse
// Newton system serves every purpose. Default stiffness (make_elastic_model):
// one EA for all struts, EA = max |designed strut force| / 1e-6, so a strut's
// elastic strain stays near 1e-6 under the designed forces (aluminium tubes are
// effectively rigid); its rest length is l / (1 + sigma / EA), so the designed
// geometry is exactly an equilibrium of the model (the fabricated strut is cut
// to its geometric length; the 1e-6 is the model's, not the tube's).
//
// Derivatives, per element with u = (x_b - x_a) / l:
//   dE/dx_b = -dE/dx_a = sigma u,
//   d2E/dx_b2 = K_e = k_e u u^T + (sigma / l)(I - u u^T),  k_e = d sigma / d l.
// HessianMode::Definite drops the geometric term (sigma / l)(I - u u^T) of
// compressed elements (sigma < 0), so every K_e is positive semidefinite and a
// Newton step on E plus a positive mass term is always a descent direction.
// Only free (non-fixed) nodes are unknowns; the sparse pattern over their
// coordinates (both triangles) is built once, together with the value slot of
// every element entry, so assembly writes values and never allocates.
#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <array>
#include <span>
#include <string>
#include <vector>

#include "formulations/free_nodes.hpp"
#include "model/design.hpp"
#include "model/material.hpp"
#include "model/structure.hpp"

namespace tensegrity {

// The force-strain curve of one cable kind as the energy uses it (see top).
class CableCurve {
 public:
  CableCurve() = default;
  explicit CableCurve(const CableMaterial& material);
  // A linear cord: f = ea * eps for eps > 0 (ea in N).
  static CableCurve linear(double ea);

  double force(double eps) const;         // f(eps), N
  double slope(double eps) const;         // df/deps, N (0 where slack)
  double energy_density(double eps) const;  // W(eps) = int_0^eps f, N (energy per rest length)
  double slack_strain() const { return slack_strain_; }  // f = 0 at and below this strain
  bool in_measured_range(double eps) const { return eps >= strain_min_ && eps <= strain_max_; }

 private:
  double g(double eps) const;
  double g_slope(double eps) const;
  double g_integral(double eps) const;  // an antiderivative of g, continuous
  std::array<double, 6> c_{};
  double strain_min_ = 0.0, strain_max_ = 0.0;
  double f_min_ = 0.0, f_max_ = 0.0, slope_min_ = 0.0, slope_max_ = 0.0;
  double slack_strain_ = 0.0, integral_at_slack_ = 0.0;
};

struct DragSpring {
  int node = 0;
  Eigen::Vector3d target = Eigen::Vector3d::Zero();  // m
  double stiffness = 0.0;                            // N/m
};

enum class HessianMode { Exact, Definite };

// Everything the energy needs, per element.
struct ElasticModel {
  Structure structure;                 // topology, fixed flags, masses, gravity
  Eigen::Matrix3Xd reference;          // the designed positions (3 x n, m)
  Eigen::VectorXd rest_lengths;        // m per element (struts: pre-compressed, see top)
  Eigen::VectorXd strut_ea;            // N per element (0 for cables)
  std::vector<CableCurve> curves;      // distinct cable curves
  std::vector<int> curve_of;           // per element, index into curves, -1 for struts
  Eigen::VectorXd designed_forces;     // N per element, for scales and reports
  double length_scale = 1.0;           // m: the bounding-box diagonal of the reference
  double force_scale = 1.0;            // N: max(total weight, max |designed force|)
};

struct ElasticModelOptions {
  double strut_design_strain = 1e-6;   // strut strain under the largest designed strut force
};

// From a design file: cable rest lengths and materials as designed.
ElasticModel make_elastic_model(const Design& design, const ElasticModelOptions& options = {});
// Without materials (blocks, plain solutions): every cable a linear cord that
// carries its given force at strain `cable_strain`: L = l / (1 + eps),
// EA = sigma / eps. Struts as above.
ElasticModel make_linear_elastic_model(const Structure& s, const Eigen::Matrix3Xd& positions,
                                       const Eigen::VectorXd& forces, double cable_strain = 0.1,
                                       const ElasticModelOptions& options = {});

class ElasticEnergy {
 public:
  // `gravity` overrides the structure's (pass the structure's own to keep it).
  ElasticEnergy(const ElasticModel& model, const Eigen::Vector3d& gravity);
  explicit ElasticEnergy(const ElasticModel& model) : ElasticEnergy(model, model.structure.gravity) {}

  const ElasticModel& model() const { return model_; }
  const FreeNodeMap& free_map() const { return map_; }
  int num_dofs() const { return 3 * map_.num_free(); }
  const Eigen::Vector3d& gravity() const { return gravity_; }
  const Eigen::VectorXd& lumped_mass() const { return mass_; }  // kg per node

  // E(x) (J); x holds every node, fixed ones at their positions.
  double energy(const Eigen::Matrix3Xd& x, std::span<const DragSpring> drags = {}) const;
  // E(x) and its gradient over the free coordinates (3 n_free, N).
  double energy_gradient(const Eigen::Matrix3Xd& x, Eigen::VectorXd& gradient,
                         std::span<const DragSpring> drags = {}) const;
  // Writes the Hessian values into H, which must have pattern() (copy it once).
  void hessian(const Eigen::Matrix3Xd& x, HessianMode mode, Eigen::SparseMatrix<double>& H,
               std::span<const DragSpring> drags = {}) const;
  // The symmetric pattern (both triangles, every free diagonal present), zero values.
  const Eigen::SparseMatrix<double>& pattern() const { return pattern_; }
  // Index into H.valuePtr() of the diagonal entry of free coordinate k.
  int diagonal_slot(int k) const { return diagonal_slot_[k]; }

  // Curved line-search path for stiff struts: moves the ends of every strut of
  // `x` along its axis so that its length equals its length in `before` plus
  // the first-order change of the step x - before (fixed ends stay). A Newton
  // step that rotates a strut lengthens it at second order, which the far
  // stiffer strut energy punishes so hard that a straight line search would
  // crawl; restoring the lengths first lets large rotations through.
  void restore_strut_lengths(const Eigen::Matrix3Xd& before, Eigen::Matrix3Xd& x) const;

  // Axial forces sigma_e (N, tension > 0) at x.
  Eigen::VectorXd element_forces(const Eigen::Matrix3Xd& x) const;
  // Cables whose strain at x lies outside their measured range (not slack).
  int cables_outside_measured_range(const Eigen::Matrix3Xd& x) const;

 private:
  // psi(l), psi'(l) = sigma, psi''(l) of element e at length l.
  void element_terms(int e, double l, double* psi, double* sigma, double* stiffness) const;

  ElasticModel model_;
  FreeNodeMap map_;
  Eigen::Vector3d gravity_;
  Eigen::VectorXd mass_;
  Eigen::SparseMatrix<double> pattern_;
  // A 3x3 block (rows of one node, columns of another) is three runs of three
  // consecutive values, one per column: its three start slots.
  using BlockSlots = std::array<int, 3>;
  std::vector<std::array<BlockSlots, 4>> element_blocks_;  // per element: aa, bb, ab, ba ({-1..}: fixed)
  std::vector<BlockSlots> node_blocks_;                    // per node: its diagonal block
  std::vector<int> diagonal_slot_;
};

}  // namespace tensegrity
