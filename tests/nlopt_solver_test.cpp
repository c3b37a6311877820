// The `nlopt` backend: reference prisms and octahedra (exact, perturbed,
// twisted, with gravity and fixed nodes) converge and verify; its algorithms,
// options, status mapping and trace behave as documented.
#include "solvers/nlopt/nlopt_solver.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "model/errors.hpp"
#include "model/verify.hpp"
#include "model/reference_scenes.hpp"
#include "scenes/suites.hpp"
#include "solvers/solver.hpp"

namespace tensegrity {
namespace {

SolveOptions options_with(std::map<std::string, std::string> backend = {}) {
  SolveOptions o;
  o.time_limit_s = 30.0;
  o.backend_options = std::move(backend);
  return o;
}

// The driver has verified every `converged` result; what is left to check is
// that it is the right one.
void expect_converged(const Structure& scene, const SolveResult& r) {
  ASSERT_EQ(r.status, Status::Converged) << scene.name << ": " << r.message;
}

// Ipopt solves the same Eq. 5 (with prestress=equal, the mean cable force
// held at F0 also under gravity) from the same start by another method.
constexpr double kSameOptimumGeometryChange = 1e-4;  // relative

double mean_cable_force(const Structure& s, const Eigen::VectorXd& forces) {
  double sum = 0.0;
  int cables = 0;
  for (int e = 0; e < s.num_elements(); ++e)
    if (s.elements[e].kind == ElementKind::Cable) sum += forces[e], ++cables;
  return sum / cables;
}

// Scenes beyond the conformance suite's (tests/conformance_test.cpp).
std::vector<Structure> reference_scenes() {
  std::vector<Structure> v;
  v.push_back(scenes::prism(3, 5.0));
  v.push_back(scenes::prism(6, 15.0, true));
  v.push_back(scenes::perturbed(scenes::prism(5), 0.01, 21u));
  v.push_back(scenes::perturbed(scenes::octahedron(true), 0.01, 22u));
  return v;
}

TEST(NloptSolver, ReferenceScenesConvergeToIpoptsOptimum) {
  const NloptSolver solver;
  const auto ipopt = make_solver("ipopt");
  for (const Structure& scene : reference_scenes()) {
    const SolveResult r = solve_scene(solver, scene, options_with());
    const SolveResult other = solve_scene(*ipopt, scene, options_with({{"prestress", "equal"}}));
    expect_converged(scene, r);
    expect_converged(scene, other);
    std::printf("[ %s ] geometry change %.10g, ipopt's %.10g\n", scene.name.c_str(), r.stats.geometry_change,
                other.stats.geometry_change);
    EXPECT_NEAR(r.stats.geometry_change, other.stats.geometry_change,
                kSameOptimumGeometryChange * other.stats.geometry_change + 1e-12) << scene.name;
    // Under gravity the load sets the force scale: a scene may already stand.
    if (!scene.has_gravity()) {
      EXPECT_GT(r.stats.geometry_change, 0.0) << scene.name;
      EXPECT_NEAR(mean_cable_force(scene, r.forces), 1.0, 1e-8) << scene.name;
    }
  }
}

TEST(NloptSolver, ExactPrismStaysPutWithAnalyticForceDensities) {
  const NloptSolver solver;
  for (int n : {3, 5, 8}) {
    const Structure scene = scenes::prism(n);
    SolveOptions o = options_with();
    // Without the driver's shortcut: the backend itself must not move it.
    const SolveResult r = solver.Solve(scene, o, DriverControls{false});
    expect_converged(scene, r);
    EXPECT_LE(r.stats.geometry_change, 1e-10);
    // Force densities (force / length): struts -1, verticals 1, rings 1/(2 sin(pi/n)).
    auto density = [&](int e) {
      const auto& el = scene.elements[e];
      return r.forces[e] / (scene.positions.col(el.b) - scene.positions.col(el.a)).norm();
    };
    const double vertical = density(n);
    EXPECT_NEAR(density(0) / vertical, -1.0, 1e-6) << n;
    EXPECT_NEAR(density(2 * n) / vertical, 1.0 / (2.0 * std::sin(M_PI / n)), 1e-6) << n;
    EXPECT_NEAR(density(3 * n) / vertical, 1.0 / (2.0 * std::sin(M_PI / n)), 1e-6) << n;
  }
}

TEST(NloptSolver, EveryAugmentedLagrangianVariantReachesTheSameGeometry) {
  const NloptSolver solver;
  const Structure scene = scenes::perturbed(scenes::prism(4), 0.05, 31u);
  const SolveResult reference = solve_scene(solver, scene, options_with());
  expect_converged(scene, reference);
  for (const char* algorithm : {"penalty-lbfgs", "auglag-eq-lbfgs", "al-tnewton"}) {
    const SolveResult r = solve_scene(solver, scene, options_with({{"algorithm", algorithm}}));
    expect_converged(scene, r);
    EXPECT_NEAR(r.stats.geometry_change, reference.stats.geometry_change,
                1e-4 * reference.stats.geometry_change)
        << algorithm;
  }
}

// A perturbed prism with its bottom ring fixed, without gravity (a perturbed
// scene under gravity still stands, and the driver's shortcut would return it).
TEST(NloptSolver, SlsqpConvergesWhenFixedNodesRemoveTheRigidModes) {
  const NloptSolver solver;
  PrismParameters p;
  p.n = 6;
  p.fix_bottom = true;
  const Structure scene = scenes::perturbed(make_regular_prism(p), 0.05, 6u);
  const SolveResult lbfgs = solve_scene(solver, scene, options_with());
  const SolveResult slsqp = solve_scene(solver, scene, options_with({{"algorithm", "slsqp"}}));
  expect_converged(scene, lbfgs);
  expect_converged(scene, slsqp);
  std::printf("slsqp %.10g lbfgs %.10g\n", slsqp.stats.geometry_change, lbfgs.stats.geometry_change);
  EXPECT_GT(lbfgs.stats.geometry_change, 0.0);
  EXPECT_NEAR(slsqp.stats.geometry_change, lbfgs.stats.geometry_change,
              1e-4 * lbfgs.stats.geometry_change);
}

TEST(NloptSolver, BudgetsBecomeStatusesNotConvergence) {
  const NloptSolver solver;
  const Structure scene = scenes::perturbed(scenes::octahedron(), 0.05, 3u);
  const SolveResult few = solver.Solve(scene, options_with({{"maxeval", "5"}}), DriverControls{false});
  EXPECT_EQ(few.status, Status::MaxIterations) << few.message;
  // The driver checks only `converged` claims: a budget status must not hide an equilibrium.
  EXPECT_FALSE(verify(scene, few.positions, few.forces, 1e-8).ok);

  SolveOptions instant = options_with();
  instant.time_limit_s = 1e-9;
  const SolveResult late = solver.Solve(scene, instant, DriverControls{false});
  // The clock is read between NLopt's evaluations: a fast machine may reach a
  // verified point first, an equilibrium on the way to the run without the
  // limit (within 1 % of its change; the stop may come a step before its
  // optimum); anything else is the time limit.
  if (late.status == Status::Converged) {
    const SolveResult unlimited = solver.Solve(scene, options_with(), DriverControls{false});
    EXPECT_NEAR(late.stats.geometry_change, unlimited.stats.geometry_change,
                1e-2 * unlimited.stats.geometry_change)
        << late.message;
  } else {
    EXPECT_EQ(late.status, Status::TimeLimit) << late.message;
  }
  EXPECT_TRUE(late.positions.allFinite());
  EXPECT_TRUE(late.forces.allFinite());
}

TEST(NloptSolver, TraceIsMonotoneInTimeAndEvaluationsAndEndsAtTheResult) {
  const NloptSolver solver;
  const Structure scene = scenes::perturbed(scenes::prism(6), 0.05, 17u);
  for (const char* algorithm : {"al-lbfgs", "auglag-eq-lbfgs"}) {
    const SolveResult r = solver.Solve(scene, options_with({{"algorithm", algorithm}}), DriverControls{false});
    ASSERT_EQ(r.status, Status::Converged) << r.message;
    ASSERT_FALSE(r.trace.empty());
    for (std::size_t k = 1; k < r.trace.size(); ++k) {
      EXPECT_GE(r.trace[k].seconds, r.trace[k - 1].seconds);
      EXPECT_GE(r.trace[k].evaluations, r.trace[k - 1].evaluations);
    }
    EXPECT_GT(r.trace.back().evaluations, 0);
    if (std::string(algorithm) == "al-lbfgs") {
      // One point per outer iteration, the last one at the returned solution.
      EXPECT_EQ(static_cast<int>(r.trace.size()), r.stats.iterations);
      EXPECT_NEAR(r.trace.back().geometry_change, r.stats.geometry_change, 1e-12);
      EXPECT_NEAR(r.trace.back().relative_residual, r.stats.relative_residual, 1e-12);
    }
  }
}

TEST(NloptSolver, RejectsUnknownAndMalformedOptions) {
  const NloptSolver solver;
  EXPECT_THROW(solver.ValidateOptions(options_with({{"algorithm", "newton"}})), InputError);
  EXPECT_THROW(solver.ValidateOptions(options_with({{"ftol_rel", "-1"}})), InputError);
  EXPECT_THROW(solver.ValidateOptions(options_with({{"maxeval", "many"}})), InputError);
  EXPECT_THROW(solver.ValidateOptions(options_with({{"init", "zero"}})), InputError);
  EXPECT_THROW(solver.ValidateOptions(options_with({{"penalty_growth", "1"}})), InputError);
  for (const auto& name : NloptSolver::algorithm_names())
    EXPECT_NO_THROW(solver.ValidateOptions(options_with({{"algorithm", name}}))) << name;
  EXPECT_NO_THROW(solver.ValidateOptions(options_with(
      {{"xtol_rel", "1e-10"}, {"maxeval", "1000"}, {"penalty_initial", "1"}, {"init", "reference"}})));
}

}  // namespace
}  // namespace tensegrity
