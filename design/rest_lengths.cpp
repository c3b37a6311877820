#include "design/rest_lengths.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "model/errors.hpp"
#include "model/json_text.hpp"

namespace tensegrity {

namespace {

double element_length(const Eigen::Matrix3Xd& x, const Element& e) { return (x.col(e.b) - x.col(e.a)).norm(); }

}  // namespace

StrainSolve strain_for_force(const CableMaterial& m, double force) {
  StrainSolve r;
  if (!std::isfinite(force)) return r;
  double lo = m.strain_min, hi = m.strain_max;
  const double f_lo = m.force_unchecked(lo), f_hi = m.force_unchecked(hi);
  if (force < f_lo) {
    r.status = StrainSolveStatus::BelowRange;
    return r;
  }
  if (force > f_hi) {
    r.status = StrainSolveStatus::AboveRange;
    return r;
  }
  r.status = StrainSolveStatus::Ok;
  if (force == f_lo) {
    r.strain = lo;
    return r;
  }
  if (force == f_hi) {
    r.strain = hi;
    return r;
  }
  // Start from the secant of the bracket; F is increasing, so g = F - force is
  // negative at lo and positive at hi throughout.
  double eps = lo + (hi - lo) * (force - f_lo) / (f_hi - f_lo);
  for (int it = 0; it < 200; ++it) {
    r.iterations = it + 1;
    const double g = m.force_unchecked(eps) - force;
    if (g == 0.0) break;
    if (g < 0.0) lo = eps; else hi = eps;
    const double slope = m.slope_unchecked(eps);
    double next = slope > 0.0 ? eps - g / slope : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    // Stop once the step (or the bracket) is at the resolution of doubles.
    const double resolution = 4.0 * std::numeric_limits<double>::epsilon() * std::max(1.0, std::abs(eps));
    if (std::abs(next - eps) <= resolution || hi - lo <= resolution) {
      eps = next;
      break;
    }
    eps = next;
  }
  r.strain = eps;
  return r;
}

RestLengthDesign compute_rest_lengths(const Structure& s, const Eigen::Matrix3Xd& positions,
                                      const Eigen::VectorXd& forces,
                                      const std::vector<const CableMaterial*>& material_of) {
  const int m = s.num_elements();
  RestLengthDesign d;
  d.lengths.resize(m);
  d.rest_lengths.resize(m);
  d.strains = Eigen::VectorXd::Zero(m);
  for (int e = 0; e < m; ++e) {
    const double l = element_length(positions, s.elements[e]);
    d.lengths[e] = l;
    d.rest_lengths[e] = l;
    if (s.elements[e].kind == ElementKind::Strut) continue;
    const CableMaterial* mat = e < static_cast<int>(material_of.size()) ? material_of[e] : nullptr;
    if (!mat) {
      d.out_of_range.push_back(e);
      if (d.message.empty()) d.message = "cable " + std::to_string(e) + " has no material";
      continue;
    }
    const StrainSolve ss = strain_for_force(*mat, forces[e]);
    if (ss.status != StrainSolveStatus::Ok) {
      d.out_of_range.push_back(e);
      if (d.message.empty())
        d.message = "cable " + std::to_string(e) + ": force " + message_number(forces[e]) + " N is beyond material '" +
                    mat->name + "' (measured forces " + message_number(mat->force_min()) + " .. " +
                    message_number(mat->force_max()) + " N over strains " + message_number(mat->strain_min) + " .. " +
                    message_number(mat->strain_max) + ")";
      continue;
    }
    d.strains[e] = ss.strain;
    d.rest_lengths[e] = l / (1.0 + ss.strain);
  }
  d.ok = d.out_of_range.empty();
  return d;
}

RestLengthDesign naive_rest_lengths(const Structure& s, const Eigen::Matrix3Xd& positions, double fraction,
                                    const std::vector<const CableMaterial*>& material_of) {
  const int m = s.num_elements();
  RestLengthDesign d;
  d.lengths.resize(m);
  d.rest_lengths.resize(m);
  d.strains = Eigen::VectorXd::Zero(m);
  if (!(fraction > 0.0) || !std::isfinite(fraction)) {
    d.message = "the rest-length fraction must be a finite number > 0, got " + message_number(fraction);
    return d;
  }
  const double strain = 1.0 / fraction - 1.0;
  for (int e = 0; e < m; ++e) {
    const double l = element_length(positions, s.elements[e]);
    d.lengths[e] = l;
    d.rest_lengths[e] = l;
    if (s.elements[e].kind == ElementKind::Strut) continue;
    d.rest_lengths[e] = fraction * l;
    d.strains[e] = strain;
    const CableMaterial* mat = e < static_cast<int>(material_of.size()) ? material_of[e] : nullptr;
    if (mat && !mat->in_range(strain)) {
      d.out_of_range.push_back(e);
      if (d.message.empty())
        d.message = "fraction " + message_number(fraction) + " gives strain " + message_number(strain) +
                    ", outside the measured range [" + message_number(mat->strain_min) + ", " +
                    message_number(mat->strain_max) + "] of material '" + mat->name + "'";
    }
  }
  d.ok = d.out_of_range.empty();
  return d;
}

Eigen::VectorXd cable_forces_from_rest_lengths(const Structure& s, const Eigen::Matrix3Xd& positions,
                                               const Eigen::VectorXd& rest_lengths,
                                               const std::vector<const CableMaterial*>& material_of) {
  const int m = s.num_elements();
  Eigen::VectorXd f = Eigen::VectorXd::Zero(m);
  for (int e = 0; e < m; ++e) {
    if (s.elements[e].kind == ElementKind::Strut) continue;
    const CableMaterial* mat = e < static_cast<int>(material_of.size()) ? material_of[e] : nullptr;
    if (!mat) throw InputError("design", "elements[" + std::to_string(e) + "]", "cable without a material");
    f[e] = mat->force(element_length(positions, s.elements[e]) / rest_lengths[e] - 1.0);
  }
  return f;
}

}  // namespace tensegrity
