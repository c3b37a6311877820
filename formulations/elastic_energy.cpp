#include "formulations/elastic_energy.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>

#include "model/errors.hpp"

namespace tensegrity {

namespace {

// Smallest slope (N) of a curve's linear continuation: keeps a borderline
// curve's continuation from turning flat.
constexpr double kMinimumContinuationSlope = 1e-12;
// Bisection for the slack strain: enough halvings to reach the relative
// resolution below from any bracket a double can hold.
constexpr int kMaxBisections = 200;
constexpr double kBisectionResolution = 1e-16;
// Floors of the model's scales (N, m), so that a massless, force-free or
// single-point reference still gives finite relative measures.
constexpr double kSmallestScale = 1e-12;

}  // namespace

// ---- CableCurve -------------------------------------------------------------

CableCurve::CableCurve(const CableMaterial& material) {
  c_ = material.coefficients;
  strain_min_ = material.strain_min;
  strain_max_ = material.strain_max;
  f_min_ = material.force_unchecked(strain_min_);
  f_max_ = material.force_unchecked(strain_max_);
  // A validated material has F' > 0 on its range; the floor only keeps a
  // borderline curve's continuation from turning flat.
  slope_min_ = std::max(material.slope_unchecked(strain_min_), kMinimumContinuationSlope);
  slope_max_ = std::max(material.slope_unchecked(strain_max_), kMinimumContinuationSlope);
  if (g(0.0) >= 0.0) {
    slack_strain_ = 0.0;
  } else {
    // g is increasing: bisect its root on (0, hi].
    double lo = 0.0, hi = std::max(strain_max_, 1e-6);
    if (g(hi) <= 0.0) hi = strain_max_ + 1.01 * (-f_max_) / slope_max_ + 1e-9;
    for (int it = 0; it < kMaxBisections && hi - lo > kBisectionResolution * std::max(1.0, hi); ++it) {
      const double mid = 0.5 * (lo + hi);
      (g(mid) <= 0.0 ? lo : hi) = mid;
    }
    slack_strain_ = hi;
  }
  integral_at_slack_ = g_integral(slack_strain_);
}

CableCurve CableCurve::linear(double ea) {
  CableMaterial m;
  m.name = "linear";
  m.coefficients = {0.0, ea, 0.0, 0.0, 0.0, 0.0};
  m.strain_min = -1.0;
  m.strain_max = 1e6;
  return CableCurve(m);
}

double CableCurve::g(double eps) const {
  if (eps < strain_min_) return f_min_ + slope_min_ * (eps - strain_min_);
  if (eps > strain_max_) return f_max_ + slope_max_ * (eps - strain_max_);
  double v = 0.0;
  for (int k = 5; k >= 0; --k) v = v * eps + c_[k];
  return v;
}

double CableCurve::g_slope(double eps) const {
  if (eps < strain_min_) return slope_min_;
  if (eps > strain_max_) return slope_max_;
  double v = 0.0;
  for (int k = 5; k >= 1; --k) v = v * eps + k * c_[k];
  return v;
}

double CableCurve::g_integral(double eps) const {
  auto poly_integral = [this](double t) {
    double v = 0.0;
    for (int k = 5; k >= 0; --k) v = v * t + c_[k] / (k + 1);
    return v * t;
  };
  if (eps < strain_min_) {
    const double d = eps - strain_min_;
    return poly_integral(strain_min_) + f_min_ * d + 0.5 * slope_min_ * d * d;
  }
  if (eps > strain_max_) {
    const double d = eps - strain_max_;
    return poly_integral(strain_max_) + f_max_ * d + 0.5 * slope_max_ * d * d;
  }
  return poly_integral(eps);
}

double CableCurve::force(double eps) const {
  if (eps <= 0.0 || eps <= slack_strain_) return 0.0;
  return g(eps);
}

double CableCurve::slope(double eps) const {
  if (eps <= 0.0 || eps <= slack_strain_) return 0.0;
  return g_slope(eps);
}

double CableCurve::energy_density(double eps) const {
  if (eps <= 0.0 || eps <= slack_strain_) return 0.0;
  return g_integral(eps) - integral_at_slack_;
}

// ---- models -----------------------------------------------------------------

namespace {

double element_length(const Structure& s, const Eigen::Matrix3Xd& x, int e) {
  return (x.col(s.elements[e].b) - x.col(s.elements[e].a)).norm();
}

void finish_model(ElasticModel& model, const ElasticModelOptions& options) {
  const Structure& s = model.structure;
  const int m = s.num_elements();
  double strut_force = 0.0, max_force = 0.0;
  for (int e = 0; e < m; ++e) {
    max_force = std::max(max_force, std::abs(model.designed_forces[e]));
    if (s.elements[e].kind == ElementKind::Strut) strut_force = std::max(strut_force, -model.designed_forces[e]);
  }
  const Eigen::VectorXd mass = s.lumped_mass();
  double weight = 0.0;
  for (int i = 0; i < s.num_nodes(); ++i)
    if (!s.fixed[i]) weight += mass[i] * s.gravity.norm();
  model.force_scale = std::max({weight, max_force, kSmallestScale});
  if (!(strut_force > 0.0)) strut_force = model.force_scale;
  const double ea = strut_force / options.strut_design_strain;
  model.strut_ea = Eigen::VectorXd::Zero(m);
  for (int e = 0; e < m; ++e) {
    if (s.elements[e].kind != ElementKind::Strut) continue;
    model.strut_ea[e] = ea;
    // Pre-compressed so that the designed force holds at the designed length.
    model.rest_lengths[e] = element_length(s, model.reference, e) / (1.0 + model.designed_forces[e] / ea);
  }
  if (s.num_nodes() > 0) {
    const Eigen::Vector3d lo = model.reference.rowwise().minCoeff(), hi = model.reference.rowwise().maxCoeff();
    model.length_scale = std::max((hi - lo).norm(), kSmallestScale);
  }
}

}  // namespace

ElasticModel make_elastic_model(const Design& design, const ElasticModelOptions& options) {
  ElasticModel model;
  model.structure = design.structure;
  model.reference = design.solution.positions.cols() == design.structure.num_nodes()
                        ? design.solution.positions
                        : design.structure.positions;
  model.structure.positions = model.reference;
  const int m = model.structure.num_elements();
  if (!design.solution.rest_lengths || design.solution.rest_lengths->size() != m)
    throw InputError(design.structure.name, "rest_lengths", "the design has no rest length per element");
  model.rest_lengths = *design.solution.rest_lengths;
  model.designed_forces = design.solution.forces;
  model.curve_of.assign(m, -1);
  std::map<std::string, int> index;
  for (int e = 0; e < m; ++e) {
    if (model.structure.elements[e].kind != ElementKind::Cable) continue;
    const std::string& name = e < static_cast<int>(design.cable_material.size()) ? design.cable_material[e] : "";
    const auto mat = design.materials.find(name);
    if (mat == design.materials.end())
      throw InputError(design.structure.name, "elements[" + std::to_string(e) + "].material",
                       "cable has no material the design defines");
    auto it = index.find(name);
    if (it == index.end()) {
      it = index.emplace(name, static_cast<int>(model.curves.size())).first;
      model.curves.emplace_back(mat->second);
    }
    model.curve_of[e] = it->second;
  }
  finish_model(model, options);
  return model;
}

ElasticModel make_linear_elastic_model(const Structure& s, const Eigen::Matrix3Xd& positions,
                                       const Eigen::VectorXd& forces, double cable_strain,
                                       const ElasticModelOptions& options) {
  ElasticModel model;
  model.structure = s;
  model.reference = positions;
  model.structure.positions = positions;
  model.designed_forces = forces;
  const int m = s.num_elements();
  model.rest_lengths.resize(m);
  model.curve_of.assign(m, -1);
  double mean_cable = 0.0;
  int cables = 0;
  for (int e = 0; e < m; ++e)
    if (s.elements[e].kind == ElementKind::Cable && forces[e] > 0.0) mean_cable += forces[e], ++cables;
  mean_cable = cables > 0 ? mean_cable / cables : 1.0;
  for (int e = 0; e < m; ++e) {
    const double l = element_length(s, positions, e);
    model.rest_lengths[e] = l;
    if (s.elements[e].kind != ElementKind::Cable) continue;
    const bool pulls = forces[e] > 0.0;
    // A cable without tension gets the mean cord and sits exactly at rest.
    model.curve_of[e] = static_cast<int>(model.curves.size());
    model.curves.push_back(CableCurve::linear((pulls ? forces[e] : mean_cable) / cable_strain));
    if (pulls) model.rest_lengths[e] = l / (1.0 + cable_strain);
  }
  finish_model(model, options);
  return model;
}

// ---- ElasticEnergy ----------------------------------------------------------

ElasticEnergy::ElasticEnergy(const ElasticModel& model, const Eigen::Vector3d& gravity)
    : model_(model), map_(model.structure), gravity_(gravity), mass_(model.structure.lumped_mass()) {
  const Structure& s = model_.structure;
  const int n = s.num_nodes(), m = s.num_elements(), dofs = num_dofs();
  std::vector<Eigen::Triplet<double>> triplets;
  auto add_block = [&](int p, int q) {
    for (int c = 0; c < 3; ++c)
      for (int r = 0; r < 3; ++r) triplets.emplace_back(3 * p + r, 3 * q + c, 0.0);
  };
  for (int i = 0; i < n; ++i)
    if (map_.slot(i) >= 0) add_block(map_.slot(i), map_.slot(i));
  for (const Element& el : s.elements) {
    const int p = map_.slot(el.a), q = map_.slot(el.b);
    if (p >= 0 && q >= 0) add_block(p, q), add_block(q, p);
  }
  pattern_.resize(dofs, dofs);
  pattern_.setFromTriplets(triplets.begin(), triplets.end());
  pattern_.makeCompressed();
  pattern_.coeffs().setZero();

  auto slot_of = [&](int row, int col) {
    const int* inner = pattern_.innerIndexPtr();
    const int begin = pattern_.outerIndexPtr()[col], end = pattern_.outerIndexPtr()[col + 1];
    const int* it = std::lower_bound(inner + begin, inner + end, row);
    return static_cast<int>(it - inner);
  };
  auto block = [&](int p, int q) {
    BlockSlots b{-1, -1, -1};
    if (p < 0 || q < 0) return b;
    for (int c = 0; c < 3; ++c) b[c] = slot_of(3 * p, 3 * q + c);
    return b;
  };
  node_blocks_.resize(n);
  for (int i = 0; i < n; ++i) node_blocks_[i] = block(map_.slot(i), map_.slot(i));
  element_blocks_.resize(m);
  for (int e = 0; e < m; ++e) {
    const int p = map_.slot(s.elements[e].a), q = map_.slot(s.elements[e].b);
    element_blocks_[e] = {block(p, p), block(q, q), block(p, q), block(q, p)};
  }
  diagonal_slot_.resize(dofs);
  for (int k = 0; k < dofs; ++k) diagonal_slot_[k] = slot_of(k, k);
}

void ElasticEnergy::element_terms(int e, double l, double* psi, double* sigma, double* stiffness) const {
  const double L = model_.rest_lengths[e];
  const int curve = model_.curve_of[e];
  if (curve >= 0) {
    const CableCurve& c = model_.curves[curve];
    const double eps = l / L - 1.0;
    *psi = L * c.energy_density(eps);
    *sigma = c.force(eps);
    *stiffness = c.slope(eps) / L;
  } else {
    const double k = model_.strut_ea[e] / L;
    *psi = 0.5 * k * (l - L) * (l - L);
    *sigma = k * (l - L);
    *stiffness = k;
  }
}

double ElasticEnergy::energy(const Eigen::Matrix3Xd& x, std::span<const DragSpring> drags) const {
  const Structure& s = model_.structure;
  double total = 0.0, psi, sigma, k;
  for (int e = 0; e < s.num_elements(); ++e) {
    element_terms(e, (x.col(s.elements[e].b) - x.col(s.elements[e].a)).norm(), &psi, &sigma, &k);
    total += psi;
  }
  if (gravity_.squaredNorm() > 0.0)
    for (int i : map_.free_nodes()) total -= mass_[i] * gravity_.dot(x.col(i));
  for (const DragSpring& d : drags) total += 0.5 * d.stiffness * (x.col(d.node) - d.target).squaredNorm();
  return total;
}

double ElasticEnergy::energy_gradient(const Eigen::Matrix3Xd& x, Eigen::VectorXd& gradient,
                                      std::span<const DragSpring> drags) const {
  const Structure& s = model_.structure;
  gradient.setZero(num_dofs());
  double total = 0.0, psi, sigma, k;
  for (int e = 0; e < s.num_elements(); ++e) {
    const Element& el = s.elements[e];
    const Eigen::Vector3d d = x.col(el.b) - x.col(el.a);
    const double l = d.norm();
    element_terms(e, l, &psi, &sigma, &k);
    total += psi;
    if (sigma == 0.0 || !(l > 0.0)) continue;
    const Eigen::Vector3d f = (sigma / l) * d;
    if (const int p = map_.slot(el.a); p >= 0) gradient.segment<3>(3 * p) -= f;
    if (const int q = map_.slot(el.b); q >= 0) gradient.segment<3>(3 * q) += f;
  }
  if (gravity_.squaredNorm() > 0.0)
    for (int i : map_.free_nodes()) {
      total -= mass_[i] * gravity_.dot(x.col(i));
      gradient.segment<3>(3 * map_.slot(i)) -= mass_[i] * gravity_;
    }
  for (const DragSpring& dr : drags) {
    const Eigen::Vector3d r = x.col(dr.node) - dr.target;
    total += 0.5 * dr.stiffness * r.squaredNorm();
    if (const int p = map_.slot(dr.node); p >= 0) gradient.segment<3>(3 * p) += dr.stiffness * r;
  }
  return total;
}

void ElasticEnergy::hessian(const Eigen::Matrix3Xd& x, HessianMode mode, Eigen::SparseMatrix<double>& H,
                            std::span<const DragSpring> drags) const {
  const Structure& s = model_.structure;
  double* values = H.valuePtr();
  std::fill(values, values + H.nonZeros(), 0.0);
  auto add = [values](const BlockSlots& b, const Eigen::Matrix3d& K, double sign) {
    if (b[0] < 0) return;
    for (int c = 0; c < 3; ++c)
      for (int r = 0; r < 3; ++r) values[b[c] + r] += sign * K(r, c);
  };
  double psi, sigma, k;
  for (int e = 0; e < s.num_elements(); ++e) {
    const Element& el = s.elements[e];
    const Eigen::Vector3d d = x.col(el.b) - x.col(el.a);
    const double l = d.norm();
    if (!(l > 0.0)) continue;
    element_terms(e, l, &psi, &sigma, &k);
    const Eigen::Vector3d u = d / l;
    double geometric = sigma / l;
    if (mode == HessianMode::Definite && geometric < 0.0) geometric = 0.0;
    if (k == 0.0 && geometric == 0.0) continue;
    const Eigen::Matrix3d uu = u * u.transpose();
    const Eigen::Matrix3d K = k * uu + geometric * (Eigen::Matrix3d::Identity() - uu);
    const auto& blocks = element_blocks_[e];
    add(blocks[0], K, 1.0);
    add(blocks[1], K, 1.0);
    add(blocks[2], K, -1.0);
    add(blocks[3], K, -1.0);
  }
  for (const DragSpring& dr : drags) add(node_blocks_[dr.node], dr.stiffness * Eigen::Matrix3d::Identity(), 1.0);
}

void ElasticEnergy::restore_strut_lengths(const Eigen::Matrix3Xd& before, Eigen::Matrix3Xd& x) const {
  const Structure& s = model_.structure;
  for (int e = 0; e < s.num_elements(); ++e) {
    if (model_.curve_of[e] >= 0) continue;
    const Element& el = s.elements[e];
    const bool free_a = map_.slot(el.a) >= 0, free_b = map_.slot(el.b) >= 0;
    if (!free_a && !free_b) continue;
    const Eigen::Vector3d d = x.col(el.b) - x.col(el.a);
    const Eigen::Vector3d d0 = before.col(el.b) - before.col(el.a);
    const double l = d.norm(), l0 = d0.norm();
    if (!(l > 0.0) || !(l0 > 0.0)) continue;
    // Keep the step's first-order (axial) length change, drop the second-order stretch of a rotation.
    const double target = l0 + d0.dot(d - d0) / l0;
    if (!(target > 0.0)) continue;
    const Eigen::Vector3d change = (target - l) / l * d;  // added to b - a
    const double share_b = free_a && free_b ? 0.5 : (free_b ? 1.0 : 0.0);
    x.col(el.b) += share_b * change;
    x.col(el.a) -= (1.0 - share_b) * change;
  }
}

Eigen::VectorXd ElasticEnergy::element_forces(const Eigen::Matrix3Xd& x) const {
  const Structure& s = model_.structure;
  Eigen::VectorXd f(s.num_elements());
  double psi, k;
  for (int e = 0; e < s.num_elements(); ++e)
    element_terms(e, (x.col(s.elements[e].b) - x.col(s.elements[e].a)).norm(), &psi, &f[e], &k);
  return f;
}

int ElasticEnergy::cables_outside_measured_range(const Eigen::Matrix3Xd& x) const {
  const Structure& s = model_.structure;
  int count = 0;
  for (int e = 0; e < s.num_elements(); ++e) {
    const int c = model_.curve_of[e];
    if (c < 0) continue;
    const double eps = (x.col(s.elements[e].b) - x.col(s.elements[e].a)).norm() / model_.rest_lengths[e] - 1.0;
    const CableCurve& curve = model_.curves[c];
    if (eps > curve.slack_strain() && !curve.in_measured_range(eps)) ++count;
  }
  return count;
}

}  // namespace tensegrity
