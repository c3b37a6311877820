#pragma once
// Rest lengths of elastic cables (paper section 5.1). A cable of stretched
// length l carrying force sigma > 0 has strain eps with F(eps) = sigma (its
// material's force-strain curve) and rest length
//
//   L = l / (1 + eps)   (m).
//
// Struts are much stiffer than the cables: they keep their geometric length.
// The paper's baseline ("naive"): every cable's rest length is one constant
// fraction of its stretched length, L = fraction * l, i.e. eps = 1/fraction - 1,
// whatever its force.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "model/material.hpp"
#include "model/structure.hpp"

namespace tensegrity {

enum class StrainSolveStatus {
  Ok,
  BelowRange,  // force < F(strain_min): not reachable within the measured curve
  AboveRange,  // force > F(strain_max)
  NotFinite,
};

struct StrainSolve {
  StrainSolveStatus status = StrainSolveStatus::NotFinite;
  double strain = 0.0;  // the eps in [strain_min, strain_max] with F(eps) = force (when Ok)
  int iterations = 0;
};

// Solves F(eps) = force on the measured range by safeguarded Newton: the
// bracket [lo, hi] with F(lo) <= force <= F(hi) shrinks every step, a Newton
// step leaving it is replaced by bisection. F is strictly increasing there (a
// CableMaterial guarantees it), so the root is unique. Converges to a few ulps
// of eps; no exceptions.
StrainSolve strain_for_force(const CableMaterial& material, double force);

struct RestLengthDesign {
  bool ok = false;
  std::string message;                // the first problem in words, when !ok
  Eigen::VectorXd lengths;            // m, stretched length l per element
  Eigen::VectorXd rest_lengths;       // m, struts: l; cables: l / (1 + eps)
  Eigen::VectorXd strains;            // per element; struts 0
  // Elements whose force is beyond their material's measured range.
  std::vector<int> out_of_range;
};

// `material_of[e]` is the material of cable e (nullptr for struts; every cable
// needs one). forces are the designed sigma (N), positions 3 x n (m). Each
// failing cable is listed in out_of_range, with its rest length set to l.
RestLengthDesign compute_rest_lengths(const Structure& s, const Eigen::Matrix3Xd& positions,
                                      const Eigen::VectorXd& forces,
                                      const std::vector<const CableMaterial*>& material_of);

// The baseline: cables L = fraction * l (0 < fraction <= 1 stretches them);
// strains 1/fraction - 1. Not ok when that strain is outside a cable's material
// range (pass nullptr materials to skip the check).
RestLengthDesign naive_rest_lengths(const Structure& s, const Eigen::Matrix3Xd& positions, double fraction,
                                    const std::vector<const CableMaterial*>& material_of);

// Forces the materials exert at the given geometry and rest lengths (cables:
// F(l / L - 1), struts: 0); throws InputError when a strain leaves a material's
// range. The round trip of compute_rest_lengths.
Eigen::VectorXd cable_forces_from_rest_lengths(const Structure& s, const Eigen::Matrix3Xd& positions,
                                               const Eigen::VectorXd& rest_lengths,
                                               const std::vector<const CableMaterial*>& material_of);

}  // namespace tensegrity
