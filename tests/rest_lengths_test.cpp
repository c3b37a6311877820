// Rest lengths from forces through a material, and their round trip.
#include "design/rest_lengths.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "formulations/force_scale.hpp"
#include "model/errors.hpp"
#include "model/reference_scenes.hpp"
#include "model/verify.hpp"
#include "design/stiffness_solver.hpp"
#include "tests/simulation_fixtures.hpp"

namespace tensegrity {
namespace {

CableMaterial linear_material(double k, double lo, double hi) {
  CableMaterial m;
  m.name = "linear";
  m.diameter = 1e-3;
  m.coefficients = {0.0, k, 0.0, 0.0, 0.0, 0.0};
  m.strain_min = lo;
  m.strain_max = hi;
  return m;
}

using testing::shipped_material;

TEST(StrainForForce, LinearMaterialMatchesTheClosedForm) {
  const CableMaterial m = linear_material(5.0, 0.0, 2.0);
  for (double sigma : {1e-6, 0.37, 1.0, 4.2, 9.999, 10.0}) {
    const StrainSolve s = strain_for_force(m, sigma);
    ASSERT_EQ(s.status, StrainSolveStatus::Ok);
    EXPECT_NEAR(s.strain, sigma / 5.0, 1e-15 * (1.0 + sigma)) << sigma;
    EXPECT_LE(s.iterations, 3);  // Newton on a line: one step from the secant start
  }
  EXPECT_EQ(strain_for_force(m, 10.0 + 1e-9).status, StrainSolveStatus::AboveRange);
  EXPECT_EQ(strain_for_force(m, -1e-9).status, StrainSolveStatus::BelowRange);
  EXPECT_EQ(strain_for_force(m, std::nan("")).status, StrainSolveStatus::NotFinite);
}

TEST(StrainForForce, CubicMaterialMatchesTheClosedForm) {
  // F = eps + eps^3 on [0, 2]: eps from Cardano's formula for eps^3 + eps - F = 0.
  CableMaterial m = linear_material(1.0, 0.0, 2.0);
  m.coefficients[3] = 1.0;
  for (double F : {0.01, 0.5, 2.0, 7.5, 10.0}) {
    const double d = std::sqrt(F * F / 4.0 + 1.0 / 27.0);
    const double exact = std::cbrt(F / 2.0 + d) + std::cbrt(F / 2.0 - d);
    const StrainSolve s = strain_for_force(m, F);
    ASSERT_EQ(s.status, StrainSolveStatus::Ok);
    EXPECT_NEAR(s.strain, exact, 1e-14) << F;
    EXPECT_LT(s.iterations, 30);
  }
}

TEST(StrainForForce, ShippedMaterialInvertsEveryForceInItsRange) {
  const CableMaterial m = shipped_material("elastic-cord-1mm");
  for (int i = 0; i <= 200; ++i) {
    const double eps = m.strain_min + (m.strain_max - m.strain_min) * i / 200.0;
    const double F = m.force(eps);
    const StrainSolve s = strain_for_force(m, F);
    ASSERT_EQ(s.status, StrainSolveStatus::Ok);
    EXPECT_NEAR(m.force(s.strain), F, 1e-13 * (1.0 + std::abs(F)));
    EXPECT_NEAR(s.strain, eps, 1e-10);
  }
  EXPECT_EQ(strain_for_force(m, m.force_max() * 1.001).status, StrainSolveStatus::AboveRange);
}

Structure prism_scene() {
  PrismParameters p;
  p.n = 4;
  p.radius = 0.1;
  p.height = 0.15;
  return make_regular_prism(p);
}

// Forces in equilibrium through the stiffness QP, targets from a strain.
Eigen::VectorXd designed_forces(const Structure& s, const CableMaterial& m, double strain) {
  Eigen::VectorXd targets = Eigen::VectorXd::Zero(s.num_elements());
  for (int e = 0; e < s.num_elements(); ++e)
    if (s.elements[e].kind == ElementKind::Cable) targets[e] = m.force(strain);
  StiffnessProblem p = make_stiffness_problem(s, targets, make_force_scale(s).margin);
  for (int e = 0; e < s.num_elements(); ++e)
    if (s.elements[e].kind == ElementKind::Cable) {
      p.lower[e] = std::max(p.lower[e], m.force_min());
      p.upper[e] = m.force_max();
    }
  const StiffnessResult r = solve_stiffness_qp(s, s.positions, p);
  EXPECT_EQ(r.status, Status::Converged) << r.message;
  return r.sigma;
}

void expect_round_trip(const Structure& s, const Eigen::VectorXd& forces, const CableMaterial& m) {
  std::vector<const CableMaterial*> mat(s.num_elements(), nullptr);
  for (int e = 0; e < s.num_elements(); ++e)
    if (s.elements[e].kind == ElementKind::Cable) mat[e] = &m;
  const RestLengthDesign d = compute_rest_lengths(s, s.positions, forces, mat);
  ASSERT_TRUE(d.ok) << d.message;
  Eigen::VectorXd back = cable_forces_from_rest_lengths(s, s.positions, d.rest_lengths, mat);
  for (int e = 0; e < s.num_elements(); ++e) {
    const double l = (s.positions.col(s.elements[e].b) - s.positions.col(s.elements[e].a)).norm();
    if (s.elements[e].kind == ElementKind::Strut) {
      EXPECT_EQ(d.rest_lengths[e], l);  // struts keep their geometric length
      back[e] = forces[e];              // rigid: they carry what equilibrium asks
      continue;
    }
    EXPECT_LT(d.rest_lengths[e], l);    // stretched cables are shorter at rest
    EXPECT_NEAR(d.strains[e], l / d.rest_lengths[e] - 1.0, 1e-14);
    EXPECT_LE(std::abs(back[e] - forces[e]), 1e-9 * std::abs(forces[e])) << "cable " << e;
  }
  const Verification v = verify(s, s.positions, back, 1e-9);
  EXPECT_TRUE(v.ok) << (v.problems.empty() ? "" : v.problems.front());
  EXPECT_LE(v.relative_residual, 1e-9);
}

TEST(RestLengths, RoundTripOnAPrismInSelfStress) {
  const CableMaterial m = shipped_material("elastic-cord-1mm");
  const Structure s = prism_scene();
  expect_round_trip(s, designed_forces(s, m, 0.3), m);
}

TEST(RestLengths, RoundTripUnderGravityWithFixedBottomNodes) {
  // The expandable octahedron standing on its two lowest nodes: the load of
  // its (symmetric) masses has no moment about the axis through them, so the
  // regular geometry carries it.
  OctahedronParameters p;
  p.half_length = 0.1;
  p.gravity = p.fix_bottom = true;
  p.strut_mass = 0.01;
  p.cable_mass = 0.0005;
  const Structure s = make_expandable_octahedron(p);
  const CableMaterial m = shipped_material("elastic-cord-2mm");
  expect_round_trip(s, designed_forces(s, m, 0.25), m);
}

TEST(RestLengths, ForceBeyondTheMaterialIsReported) {
  const CableMaterial m = linear_material(5.0, 0.0, 1.0);
  Structure s;
  s.add_node({0, 0, 0}, true);
  s.add_node({1, 0, 0});
  s.add_element(0, 1, ElementKind::Cable);
  std::vector<const CableMaterial*> mat = {&m};
  Eigen::VectorXd f(1);
  f << 2.5;
  RestLengthDesign d = compute_rest_lengths(s, s.positions, f, mat);
  ASSERT_TRUE(d.ok);
  EXPECT_NEAR(d.rest_lengths[0], 1.0 / 1.5, 1e-15);
  f << 6.0;
  d = compute_rest_lengths(s, s.positions, f, mat);
  EXPECT_FALSE(d.ok);
  EXPECT_EQ(d.out_of_range, std::vector<int>{0});
  EXPECT_NE(d.message.find("beyond material 'linear'"), std::string::npos) << d.message;
  EXPECT_THROW(m.force(1.5), InputError);
}

TEST(RestLengths, NaiveFractionBaseline) {
  const CableMaterial m = linear_material(5.0, 0.0, 1.0);
  const Structure s = prism_scene();
  std::vector<const CableMaterial*> mat(s.num_elements(), nullptr);
  for (int e = 0; e < s.num_elements(); ++e)
    if (s.elements[e].kind == ElementKind::Cable) mat[e] = &m;
  const RestLengthDesign d = naive_rest_lengths(s, s.positions, 0.8, mat);
  ASSERT_TRUE(d.ok);
  for (int e = 0; e < s.num_elements(); ++e) {
    const double l = (s.positions.col(s.elements[e].b) - s.positions.col(s.elements[e].a)).norm();
    const bool cable = s.elements[e].kind == ElementKind::Cable;
    EXPECT_NEAR(d.rest_lengths[e], cable ? 0.8 * l : l, 1e-15);
    EXPECT_NEAR(d.strains[e], cable ? 0.25 : 0.0, 1e-15);
  }
  EXPECT_FALSE(naive_rest_lengths(s, s.positions, 0.4, mat).ok);  // strain 1.5 > 1
  EXPECT_FALSE(naive_rest_lengths(s, s.positions, 0.0, mat).ok);
}

}  // namespace
}  // namespace tensegrity
