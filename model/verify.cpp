#include "model/verify.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <string>

namespace tensegrity {

namespace {

std::string format_number(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.3g", v);
  return buffer;
}

bool is_fixed(const Structure& s, int i) { return i < static_cast<int>(s.fixed.size()) && s.fixed[i]; }

bool same_bits(double a, double b) { return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b); }

}  // namespace

Eigen::Matrix3Xd net_forces(const Structure& scene, const Eigen::Matrix3Xd& positions,
                            const Eigen::VectorXd& forces) {
  const int n = scene.num_nodes();
  Eigen::Matrix3Xd net = Eigen::Matrix3Xd::Zero(3, n);
  for (int e = 0; e < scene.num_elements(); ++e) {
    const int i = scene.elements[e].a, j = scene.elements[e].b;
    const Eigen::Vector3d d = positions.col(j) - positions.col(i);
    // A zero-length element has no direction: its force is undefined (NaN).
    const Eigen::Vector3d pull_on_i = forces[e] * d / d.norm();
    net.col(i) += pull_on_i;
    net.col(j) -= pull_on_i;
  }
  if (scene.has_gravity()) {
    const Eigen::VectorXd m = scene.lumped_mass();
    for (int i = 0; i < n; ++i) net.col(i) += m[i] * scene.gravity;
  }
  for (int i = 0; i < n; ++i)
    if (is_fixed(scene, i)) net.col(i).setZero();
  return net;
}

Verification verify(const Structure& scene, const Eigen::Matrix3Xd& positions, const Eigen::VectorXd& forces,
                    double tolerance) {
  Verification v;
  const int n = scene.num_nodes(), m = scene.num_elements();
  if (positions.cols() != n || forces.size() != m) {
    v.all_finite = positions.allFinite() && forces.allFinite();
    v.residual = v.relative_residual = std::numeric_limits<double>::quiet_NaN();
    v.problems.push_back(std::to_string(positions.cols()) + " positions and " + std::to_string(forces.size()) +
                         " forces for a scene of " + std::to_string(n) + " nodes and " + std::to_string(m) +
                         " elements");
    return v;
  }

  v.all_finite = positions.allFinite() && forces.allFinite();
  if (!v.all_finite) v.problems.push_back("non-finite numbers in the positions or forces");

  int zero_length = 0;
  for (const Element& e : scene.elements)
    if (!((positions.col(e.b) - positions.col(e.a)).norm() > 0.0)) ++zero_length;
  if (zero_length > 0) v.problems.push_back(std::to_string(zero_length) + " elements of zero length");

  const Eigen::Matrix3Xd net = net_forces(scene, positions, forces);
  int worst_node = -1;
  bool residual_is_nan = false;
  for (int i = 0; i < n; ++i) {
    if (is_fixed(scene, i)) continue;
    const double r = net.col(i).norm();
    if (std::isnan(r)) residual_is_nan = true;
    if (r > v.residual) {
      v.residual = r;
      worst_node = i;
    }
  }
  // std::max-style scans skip NaN silently; a NaN anywhere must show.
  if (residual_is_nan) v.residual = std::numeric_limits<double>::quiet_NaN();

  if (scene.has_gravity()) {
    const Eigen::VectorXd mass = scene.lumped_mass();
    const double g = scene.gravity.norm();
    for (int i = 0; i < n; ++i)
      if (!is_fixed(scene, i)) v.load_scale = std::max(v.load_scale, mass[i] * g);
  }
  if (!(v.load_scale > 0.0)) {
    v.load_scale = 0.0;
    for (int e = 0; e < m; ++e) v.load_scale = std::max(v.load_scale, std::abs(forces[e]));
  }
  if (v.load_scale > 0.0)
    v.relative_residual = v.residual / v.load_scale;
  else  // no load and no force: only an exactly balanced (empty) state counts as zero
    v.relative_residual = v.residual == 0.0 ? 0.0 : std::numeric_limits<double>::infinity();

  v.equilibrium_ok = v.relative_residual <= tolerance;
  if (!v.equilibrium_ok) {
    std::string problem = "relative residual " + format_number(v.relative_residual) + " > tolerance " +
                          format_number(tolerance) + " (residual " + format_number(v.residual) + " N";
    if (worst_node >= 0 && !residual_is_nan) problem += " at node " + std::to_string(worst_node);
    v.problems.push_back(problem + ")");
  }

  v.geometry_change = (positions - scene.positions).norm();

  int first_wrong = -1;
  for (int e = 0; e < m; ++e) {
    const bool cable = scene.elements[e].kind == ElementKind::Cable;
    // Written so that NaN counts as wrong.
    const bool right = cable ? forces[e] > 0.0 : forces[e] < 0.0;
    if (!right) {
      ++v.wrong_signs;
      if (first_wrong < 0) first_wrong = e;
    }
  }
  if (v.wrong_signs > 0)
    v.problems.push_back(std::to_string(v.wrong_signs) + " elements with the wrong sign (first: elements[" +
                         std::to_string(first_wrong) + "], a " + to_string(scene.elements[first_wrong].kind) +
                         " with force " + format_number(forces[first_wrong]) + " N)");

  int first_moved = -1;
  for (int i = 0; i < n; ++i) {
    if (!is_fixed(scene, i)) continue;
    bool moved = false;
    for (int k = 0; k < 3; ++k) moved = moved || !same_bits(positions(k, i), scene.positions(k, i));
    if (moved) {
      ++v.moved_fixed_nodes;
      if (first_moved < 0) first_moved = i;
    }
  }
  if (v.moved_fixed_nodes > 0)
    v.problems.push_back(std::to_string(v.moved_fixed_nodes) + " fixed nodes not at their scene position (first: node " +
                         std::to_string(first_moved) + ")");

  v.ok = v.all_finite && zero_length == 0 && v.equilibrium_ok && v.wrong_signs == 0 && v.moved_fixed_nodes == 0;
  return v;
}

}  // namespace tensegrity
