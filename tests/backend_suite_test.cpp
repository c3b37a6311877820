// One parametrized suite runs every registered backend on every reference
// scene with a known answer (OSQP/Ceres style), re-verifies every solution
// independently, and cross-checks the backends against each other.
#include <gtest/gtest.h>

#include <cstdio>
#include <map>

#include "model/verify.hpp"
#include "scenes/suites.hpp"
#include "solvers/solver.hpp"

namespace tensegrity {
namespace {

struct Case {
  std::string solver;
  int scene;
};

std::vector<Case> all_cases() {
  std::vector<Case> cases;
  const int n = static_cast<int>(scenes::backend_suite_scenes().size());
  for (const auto& s : solver_names())
    for (int k = 0; k < n; ++k) cases.push_back({s, k});
  return cases;
}

class BackendSuite : public ::testing::TestWithParam<Case> {};

TEST_P(BackendSuite, ConvergesAndVerifies) {
  const Case c = GetParam();
  const Structure scene = scenes::backend_suite_scenes()[c.scene];
  const auto solver = make_solver(c.solver);
  SolveOptions options;
  options.time_limit_s = 60.0;
  const SolveResult r = solve_scene(*solver, scene, options);
  ASSERT_EQ(r.status, Status::Converged) << scene.name << ": " << r.message;
  const Verification v = verify(scene, r.positions, r.forces, 1e-8);
  EXPECT_TRUE(v.ok) << scene.name;
  EXPECT_LE(v.relative_residual, 1e-8);
  EXPECT_EQ(v.wrong_signs, 0);
  EXPECT_GT(v.geometry_change, 0.0) << "perturbed scenes need a geometry change";
  // Stats agree with the independent check.
  EXPECT_NEAR(r.stats.geometry_change, v.geometry_change, 1e-12 * (1.0 + v.geometry_change));
  // The force scale (README): mean cable force = F0 per part; here one part
  // or two equal parts, and F0 = 1 N without gravity.
  if (!scene.has_gravity()) {
    double sum = 0.0;
    int cables = 0;
    for (int e = 0; e < scene.num_elements(); ++e)
      if (scene.elements[e].kind == ElementKind::Cable) sum += r.forces[e], ++cables;
    EXPECT_NEAR(sum / cables, 1.0, 1e-6) << scene.name;
  }
}

// Every backend, run without the driver's shortcut, must not move a scene
// that already is a tensegrity.
TEST(BackendSuiteEquilibrium, SceneAlreadyInEquilibriumIsReturnedUnchanged) {
  for (const auto& name : solver_names()) {
    const auto solver = make_solver(name);
    for (const Structure& scene : {scenes::prism(7), scenes::octahedron()}) {
      SolveOptions options;
      // Without the driver's shortcut: the backend itself must not move it.
      const SolveResult r = solver->Solve(scene, options, DriverControls{false});
      ASSERT_EQ(r.status, Status::Converged) << name << " " << scene.name << ": " << r.message;
      EXPECT_LE(r.stats.geometry_change, 1e-10 * scene.mean_element_length()) << name << " " << scene.name;
    }
  }
}

std::string case_name(const ::testing::TestParamInfo<Case>& info) {
  std::string s = info.param.solver + "_" + scenes::backend_suite_scenes()[info.param.scene].name;
  for (char& ch : s)
    if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
  return s;
}

INSTANTIATE_TEST_SUITE_P(AllBackends, BackendSuite, ::testing::ValuesIn(all_cases()), case_name);
GTEST_ALLOW_UNINSTANTIATED_PARAMETERIZED_TEST(BackendSuite);

// Eq. 5 solved whole is the local optimum the alternating scheme approximates:
// Ipopt's geometry change is never larger than the other backends' beyond
// Ipopt's own convergence accuracy (1e-5 relative: alternating-gn's interior
// steps reach the same optimum, measured 0.999998-1.000002 on most scenes).
// And alternating-gn stays within 5 % of it on this suite (measured <= 1.023).
TEST(BackendCrossCheck, IpoptGeometryChangeIsNeverLargerThanTheApproximations) {
  const auto names = solver_names();
  if (std::find(names.begin(), names.end(), "ipopt") == names.end()) GTEST_SKIP() << "no ipopt backend";
  const auto ipopt = make_solver("ipopt");
  for (const Structure& scene : scenes::backend_suite_scenes()) {
    const SolveResult best = solve_scene(*ipopt, scene, {});
    ASSERT_EQ(best.status, Status::Converged) << scene.name;
    for (const auto& name : names) {
      if (name == "ipopt") continue;
      const SolveResult r = solve_scene(*make_solver(name), scene, {});
      if (r.status != Status::Converged) continue;  // reported by the suite above
      const double ratio = r.stats.geometry_change / best.stats.geometry_change;
      std::printf("%-28s %-15s geometry change %.6g m, ratio to ipopt %.6f\n", scene.name.c_str(),
                  name.c_str(), r.stats.geometry_change, ratio);
      EXPECT_LE(best.stats.geometry_change, r.stats.geometry_change * (1.0 + 1e-5))
          << scene.name << " " << name;
      if (name == "alternating-gn") {
        EXPECT_LE(ratio, 1.05) << scene.name;
      }
    }
  }
}

}  // namespace
}  // namespace tensegrity
