// Eq. 4 by Ipopt in residual form (kernels/stress_qp_ipopt.hpp): against the
// closed form of regular prisms, against the stress QP's certified optimum
// where a residual remains, the caller's stop test, and the equilibrium of a
// large near-mechanism that the stress QP's normal matrix loses.
#include "kernels/stress_qp_ipopt.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "formulations/equilibrium.hpp"
#include "formulations/force_scale.hpp"
#include "kernels/stress_qp.hpp"
#include "model/reference_scenes.hpp"
#include "model/verify.hpp"
#include "scenes/towers.hpp"
#include "solvers/solver.hpp"

namespace tensegrity {
namespace {

constexpr double kTolerance = 1e-8;  // verify()'s default relative residual
constexpr double kNoTimeLimit = 60.0;

ForceMeasure relative_residual_of(const Structure& s) {
  return [&s](const Eigen::VectorXd& sigma) { return verify(s, s.positions, sigma, kTolerance).relative_residual; };
}

void expect_within_bounds(const ForceScale& scale, const Eigen::VectorXd& sigma) {
  for (int e = 0; e < sigma.size(); ++e) {
    EXPECT_GE(sigma[e], scale.lower[e]) << "element " << e;
    EXPECT_LE(sigma[e], scale.upper[e]) << "element " << e;
  }
}

TEST(StressQpIpopt, RegularPrismsReachTheClosedFormForceDensities) {
  for (int n : {3, 5, 8}) {
    SCOPED_TRACE("n = " + std::to_string(n));
    PrismParameters p;
    p.n = n;
    const Structure s = make_regular_prism(p);
    Equilibrium eq(s);
    const ForceScale scale = make_force_scale(s);
    // stop_below 0: Ipopt runs to its own end.
    const StressQpIpoptResult r = solve_stress_qp_with_ipopt(eq, scale, {}, kNoTimeLimit, relative_residual_of(s), 0.0);
    ASSERT_EQ(r.sigma.size(), s.num_elements()) << r.message;
    EXPECT_LE(r.measure, 1e-10);
    EXPECT_DOUBLE_EQ(r.measure, relative_residual_of(s)(r.sigma));
    expect_within_bounds(scale, r.sigma);
    // The self-stress is unique up to its level, and the level is the normalisation.
    const double vertical = r.sigma[n] / (s.positions.col(s.elements[n].b) - s.positions.col(s.elements[n].a)).norm();
    const double ring = 1.0 / (2.0 * std::sin(M_PI / n));
    for (int e = 0; e < 4 * n; ++e) {
      const double len = (s.positions.col(s.elements[e].b) - s.positions.col(s.elements[e].a)).norm();
      const double expected = e < n ? -1.0 : (e < 2 * n ? 1.0 : ring);
      EXPECT_NEAR(r.sigma[e] / len / vertical, expected, 1e-7) << "element " << e;
    }
    EXPECT_NEAR(r.sigma.tail(3 * n).mean(), 1.0, 1e-9);
  }
}

// Prisms twisted 0.6 rad short of their equilibrium angle, with a fixed
// bottom under gravity, are no tensegrities (the signs cannot hold). Both
// methods then minimise the same |A sigma + f_g|^2 over the same box (no
// normalisation: the load sets the scale), and the stress QP certifies its
// optimum, so Ipopt's objective must match it.
TEST(StressQpIpopt, MatchesTheStressQpsCertifiedOptimumWhereAResidualRemains) {
  for (int n : {3, 6}) {
    SCOPED_TRACE("n = " + std::to_string(n));
    PrismParameters p;
    p.n = n;
    p.twist_offset = -0.6;
    p.gravity = true;
    p.fix_bottom = true;
    p.strut_mass = 0.4;
    p.cable_mass = 0.05;
    const Structure s = make_regular_prism(p);
    Equilibrium eq(s);
    eq.set_positions(s.positions);
    const ForceScale scale = make_force_scale(s);
    ASSERT_FALSE(scale.has_normalisation());
    StressQpOptions options;
    options.certify_optimum = true;
    StressQp qp(eq, scale, options);
    const StressQpResult optimum = qp.solve();
    ASSERT_TRUE(optimum.optimal) << optimum.message;
    const auto objective = [&](const Eigen::VectorXd& sigma) {
      return (eq.A() * sigma + eq.gravity_load()).squaredNorm();
    };
    const StressQpIpoptResult r = solve_stress_qp_with_ipopt(eq, scale, {}, kNoTimeLimit, objective, 0.0);
    ASSERT_EQ(r.sigma.size(), s.num_elements()) << r.message;
    expect_within_bounds(scale, r.sigma);
    EXPECT_GT(optimum.objective, 1e-3 * scale.reference_force * scale.reference_force);
    EXPECT_NEAR(r.measure, optimum.objective, 1e-7 * optimum.objective);
  }
}

TEST(StressQpIpopt, StopsAtTheFirstIterateThatPassesTheCallersTest) {
  PrismParameters p;
  p.n = 6;
  const Structure s = make_regular_prism(p);
  Equilibrium eq(s);
  const ForceScale scale = make_force_scale(s);
  const StressQpIpoptResult full = solve_stress_qp_with_ipopt(eq, scale, {}, kNoTimeLimit, relative_residual_of(s), 0.0);
  constexpr double kLoose = 1e-3;
  const StressQpIpoptResult early =
      solve_stress_qp_with_ipopt(eq, scale, {}, kNoTimeLimit, relative_residual_of(s), kLoose);
  EXPECT_EQ(early.status, Status::Converged) << early.message;
  EXPECT_NE(early.message.find("caller's test"), std::string::npos) << early.message;
  EXPECT_LE(early.measure, kLoose);
  EXPECT_GT(early.measure, full.measure);
  EXPECT_LT(early.iterations, full.iterations);
}

// The 40-layer tower's equilibrium without gravity (2,320 elements): the
// stress QP at its default step cap stops short of the equilibrium that
// alternating-gn found, and Ipopt on the residual form reaches it.
TEST(StressQpIpopt, FindsTheEquilibriumOfALargeNearMechanism) {
  scenes::TowerParameters p;
  p.layers = 40;
  p.cables = 50 * p.layers;
  const Structure tower = scenes::make_prism_tower(p);
  const SolveResult solved = make_solver("alternating-gn")->Solve(tower, SolveOptions{}, {});
  ASSERT_EQ(solved.status, Status::Converged) << solved.message;
  Structure s = tower;
  s.positions = solved.positions;
  Equilibrium eq(s);
  eq.set_positions(s.positions);
  const ForceScale scale = make_force_scale(s);
  StressQp qp(eq, scale);
  const StressQpResult kernel = qp.solve();
  EXPECT_GT(relative_residual_of(s)(kernel.sigma), kTolerance);
  const StressQpIpoptResult r =
      solve_stress_qp_with_ipopt(eq, scale, kernel.sigma, kNoTimeLimit, relative_residual_of(s), 0.1 * kTolerance);
  ASSERT_EQ(r.sigma.size(), s.num_elements()) << r.message;
  EXPECT_LE(r.measure, kTolerance) << r.message;
  expect_within_bounds(scale, r.sigma);
  EXPECT_TRUE(verify(s, s.positions, r.sigma, kTolerance).ok);
}

}  // namespace
}  // namespace tensegrity
