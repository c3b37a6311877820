// The stiffness-scaling QP: analytic answers on a prism in self-stress, KKT
// conditions under gravity, active bounds.
#include "formulations/stiffness_qp.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>

#include "formulations/equilibrium.hpp"
#include "formulations/force_scale.hpp"
#include "model/reference_scenes.hpp"
#include "model/verify.hpp"
#include "design/stiffness_solver.hpp"

namespace tensegrity {
namespace {

double length(const Structure& s, int e) {
  return (s.positions.col(s.elements[e].b) - s.positions.col(s.elements[e].a)).norm();
}

Structure prism(int n) {
  PrismParameters p;
  p.n = n;
  p.radius = 0.1;
  p.height = 0.12;
  return make_regular_prism(p);
}

// The analytic self-stress of the regular prism (reference_scenes.hpp): force
// densities struts -1, verticals 1, rings 1 / (2 sin(pi/n)); force = q l.
Eigen::VectorXd prism_self_stress(const Structure& s, int n) {
  Eigen::VectorXd f(s.num_elements());
  for (int e = 0; e < s.num_elements(); ++e) {
    const double q = e < n ? -1.0 : e < 2 * n ? 1.0 : 1.0 / (2.0 * std::sin(M_PI / n));
    f[e] = q * length(s, e);
  }
  return f;
}

Eigen::VectorXd cable_part(const Structure& s, const Eigen::VectorXd& v) {
  Eigen::VectorXd c = v;
  for (int e = 0; e < s.num_elements(); ++e)
    if (s.elements[e].kind == ElementKind::Strut) c[e] = 0.0;
  return c;
}

TEST(StiffnessQp, PrismSelfStressIsAnalytic) {
  for (int n : {3, 5}) {
    const Structure s = prism(n);
    Equilibrium eq(s);
    const Eigen::VectorXd s0 = prism_self_stress(s, n);
    EXPECT_LT((eq.A() * s0).norm(), 1e-14 * s0.norm()) << n;
  }
}

TEST(StiffnessQp, TargetsProportionalToASelfStressAreReproducedExactly) {
  for (int n : {3, 4, 6}) {
    const Structure s = prism(n);
    const Eigen::VectorXd s0 = 3.0 * prism_self_stress(s, n);
    const StiffnessProblem p = make_stiffness_problem(s, s0, 1e-3);
    const StiffnessResult r = solve_stiffness_qp(s, s.positions, p);
    ASSERT_EQ(r.status, Status::Converged) << r.message;
    EXPECT_LE((r.sigma - s0).cwiseAbs().maxCoeff(), 1e-12 * s0.cwiseAbs().maxCoeff()) << n;
    EXPECT_LE(r.relative_residual, 1e-10);
    EXPECT_LE(r.objective, 1e-24 * s0.squaredNorm());
    const Verification v = verify(s, s.positions, r.sigma, 1e-10);
    EXPECT_TRUE(v.ok);
  }
}

TEST(StiffnessQp, OneSelfStressMeansTheLeastSquaresProjection) {
  // The prism's self-stress space is one-dimensional: sigma = alpha s0 with
  // alpha = <s0, t> / <s0, s0> over the cables.
  const int n = 5;
  const Structure s = prism(n);
  const Eigen::VectorXd s0 = prism_self_stress(s, n);
  Eigen::VectorXd t = 2.0 * s0;
  for (int e = 0; e < s.num_elements(); ++e) t[e] *= 1.0 + 0.2 * std::sin(1.7 * e);
  const Eigen::VectorXd c = cable_part(s, s0), tc = cable_part(s, t);
  const double alpha = c.dot(tc) / c.dot(c);
  const StiffnessResult r = solve_stiffness_qp(s, s.positions, make_stiffness_problem(s, t, 1e-3));
  ASSERT_EQ(r.status, Status::Converged) << r.message;
  EXPECT_LE((r.sigma - alpha * s0).cwiseAbs().maxCoeff(), 1e-11 * s0.cwiseAbs().maxCoeff());
  EXPECT_NEAR(r.objective, 0.5 * (alpha * c - tc).squaredNorm(), 1e-12 * tc.squaredNorm());
  EXPECT_LE(r.relative_residual, 1e-10);
}

TEST(StiffnessQp, SignMarginBecomesActiveWithZeroTargets) {
  // Targets 0: the smallest admissible self-stress, where the cable with the
  // smallest s0 sits on its margin: alpha = margin / min_c s0_c.
  const int n = 3;
  const Structure s = prism(n);
  const Eigen::VectorXd s0 = prism_self_stress(s, n);
  const double margin = 0.05;
  double smallest = INFINITY;
  for (int e = n; e < s.num_elements(); ++e) smallest = std::min(smallest, s0[e]);
  const StiffnessProblem p = make_stiffness_problem(s, Eigen::VectorXd::Zero(s.num_elements()), margin);
  const StiffnessResult r = solve_stiffness_qp(s, s.positions, p);
  ASSERT_EQ(r.status, Status::Converged) << r.message;
  EXPECT_LE((r.sigma - margin / smallest * s0).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_GE(r.active_bounds, 1);
  Equilibrium eq(s);
  const StiffnessKkt kkt = stiffness_kkt(eq, p, r.sigma, 1e-12);
  EXPECT_EQ(kkt.active, r.active_bounds);
  EXPECT_LE(kkt.stationarity, 1e-12);
  EXPECT_LE(kkt.wrong_sign, 1e-12);
  EXPECT_GT(kkt.z.maxCoeff(), 0.0);  // the margin pushes: a positive lower-bound multiplier
}

// Checks w (sigma - t) + A^T lambda - z = 0 with the solver's own multipliers,
// the multiplier signs and complementarity.
// `degenerate`: bounds reached with zero multiplier (ties); the independent
// check's least-squares multipliers are then not unique, so only the solver's
// certificate is checked for signs.
void expect_kkt(const Structure& s, const StiffnessProblem& p, const StiffnessResult& r, double scale,
                bool degenerate = false) {
  Equilibrium eq(s);
  const Eigen::VectorXd stationarity =
      p.weight.cwiseProduct(r.sigma - p.target) + eq.A().transpose() * r.lambda - r.bound_multipliers;
  EXPECT_LE(stationarity.cwiseAbs().maxCoeff(), 1e-10 * scale);
  for (int e = 0; e < s.num_elements(); ++e) {
    const double z = r.bound_multipliers[e];
    const bool at_lower = r.sigma[e] - p.lower[e] <= 1e-12 * scale;
    const bool at_upper = p.upper[e] - r.sigma[e] <= 1e-12 * scale;
    if (at_lower) EXPECT_GE(z, -1e-10 * scale) << e;
    else if (at_upper) EXPECT_LE(z, 1e-10 * scale) << e;
    else EXPECT_LE(std::abs(z), 1e-10 * scale) << e;  // complementarity
    EXPECT_GE(r.sigma[e], p.lower[e]);
    EXPECT_LE(r.sigma[e], p.upper[e]);
  }
  const StiffnessKkt kkt = stiffness_kkt(eq, p, r.sigma, 1e-12 * scale);
  EXPECT_LE(kkt.stationarity, 1e-10 * scale);
  if (!degenerate) {
    EXPECT_LE(kkt.wrong_sign, 1e-10 * scale);
  }
  EXPECT_LE(kkt.equilibrium_norm, 1e-10 * scale);
}

Structure octahedron_under_gravity() {
  OctahedronParameters o;
  o.half_length = 0.1;
  o.gravity = o.fix_bottom = true;
  o.strut_mass = 0.02;
  o.cable_mass = 0.001;
  return make_expandable_octahedron(o);
}

TEST(StiffnessQp, GravityAndFixedBottomNodesSatisfyKkt) {
  const Structure s = octahedron_under_gravity();
  const int m = s.num_elements();
  Eigen::VectorXd t = Eigen::VectorXd::Zero(m);
  for (int e = 0; e < m; ++e)
    if (s.elements[e].kind == ElementKind::Cable) t[e] = 1.5 + 0.5 * std::cos(0.9 * e);
  const StiffnessProblem p = make_stiffness_problem(s, t, make_force_scale(s).margin);
  const StiffnessResult r = solve_stiffness_qp(s, s.positions, p);
  ASSERT_EQ(r.status, Status::Converged) << r.message;
  EXPECT_LE(r.relative_residual, 1e-10);
  EXPECT_TRUE(r.polished);
  expect_kkt(s, p, r, 2.0);
  // Optimal: no other feasible point does better, e.g. the optimum for
  // different targets (feasible here too: same constraints).
  const StiffnessResult other = solve_stiffness_qp(s, s.positions, make_stiffness_problem(s, 2.0 * t, p.lower[m - 1]));
  ASSERT_EQ(other.status, Status::Converged);
  EXPECT_LT(r.objective, stiffness_objective(p, other.sigma));
  // And it does better than the form-finding-style start: targets matter.
  EXPECT_LT(r.max_target_deviation, (other.sigma - t).cwiseAbs().maxCoeff());
}

TEST(StiffnessQp, UpperBoundsOfTheMaterialRangeBecomeActive) {
  // Every cable wants 10 N but may carry at most 2 N: the cable that the
  // structure loads most sits on its upper bound with a negative multiplier.
  const Structure s = octahedron_under_gravity();
  const int m = s.num_elements();
  Eigen::VectorXd t = Eigen::VectorXd::Zero(m);
  for (int e = 0; e < m; ++e)
    if (s.elements[e].kind == ElementKind::Cable) t[e] = 10.0;
  StiffnessProblem p = make_stiffness_problem(s, t, make_force_scale(s).margin);
  for (int e = 0; e < m; ++e)
    if (s.elements[e].kind == ElementKind::Cable) p.upper[e] = 2.0;
  const StiffnessResult r = solve_stiffness_qp(s, s.positions, p);
  ASSERT_EQ(r.status, Status::Converged) << r.message;
  int at_upper = 0, pushing = 0;
  for (int e = 0; e < m; ++e)
    if (s.elements[e].kind == ElementKind::Cable && r.sigma[e] == 2.0) {
      ++at_upper;
      EXPECT_LE(r.bound_multipliers[e], 0.0) << e;  // z = -z_upper
      if (r.bound_multipliers[e] < 0.0) ++pushing;
    }
  EXPECT_GE(at_upper, 1);
  EXPECT_GE(pushing, 1);
  EXPECT_LE(r.relative_residual, 1e-10);
  expect_kkt(s, p, r, 10.0, /*degenerate=*/true);
}

TEST(StiffnessQp, GravityWithoutSupportIsNotConverged) {
  PrismParameters pp;
  pp.n = 3;
  pp.gravity = true;
  pp.strut_mass = 0.01;
  const Structure s = make_regular_prism(pp);  // no fixed node: the weight cannot be balanced
  Eigen::VectorXd t = Eigen::VectorXd::Constant(s.num_elements(), 1.0);
  const StiffnessResult r = solve_stiffness_qp(s, s.positions, make_stiffness_problem(s, t, 1e-3));
  EXPECT_NE(r.status, Status::Converged);
  EXPECT_EQ(r.status, Status::Infeasible) << r.message;
  EXPECT_TRUE(r.sigma.allFinite());
}

}  // namespace
}  // namespace tensegrity
