// What every registered backend shares through the scene driver
// (solvers/solver.hpp): its name in the registry, the rejection of an option
// it does not know, `infeasible` for gravity on a part without fixed nodes
// before any backend iteration, and `max_iterations` for a one-iteration budget.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "model/errors.hpp"
#include "model/reference_scenes.hpp"
#include "scenes/perturb.hpp"
#include "solvers/solver.hpp"

namespace tensegrity {
namespace {

class EveryBackend : public ::testing::TestWithParam<std::string> {};

TEST(BackendRegistry, NamesTheDocumentedBackends) {
  EXPECT_EQ(solver_names(), (std::vector<std::string>{"alternating", "alternating-gn", "eq5-newton", "ipopt", "nlopt"}));
}

TEST_P(EveryBackend, IsMadeUnderItsRegisteredName) {
  EXPECT_EQ(make_solver(GetParam())->name(), GetParam());
}

TEST_P(EveryBackend, RejectsAnUnknownOptionByName) {
  SolveOptions options;
  options.backend_options = {{"no_such_option", "1"}};
  try {
    make_solver(GetParam())->ValidateOptions(options);
    ADD_FAILURE() << "no_such_option=1 was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no_such_option"), std::string::npos) << e.what();
  }
}

// A perturbed prism with strut masses under gravity and no fixed node: no
// equilibrium exists, and the driver says so without running the backend
// (also without its equilibrium shortcut), returning the scene unchanged.
TEST_P(EveryBackend, GravityWithoutSupportIsInfeasibleAtOnce) {
  PrismParameters p;
  p.n = 4;
  p.gravity = true;
  p.strut_mass = 0.1;
  scenes::NodeNoise noise;
  noise.fraction = 0.05;
  const Structure scene = scenes::with_node_noise(make_regular_prism(p), noise, 3u);
  const SolveResult r = make_solver(GetParam())->Solve(scene, SolveOptions{}, DriverControls{false});
  EXPECT_EQ(r.status, Status::Infeasible) << r.message;
  EXPECT_EQ(r.message, "gravity acts on a part without fixed nodes: no equilibrium exists");
  EXPECT_EQ(r.stats.iterations, 0);
  EXPECT_TRUE(r.trace.empty());
  EXPECT_TRUE(r.positions == scene.positions);
  EXPECT_EQ(r.stats.geometry_change, 0.0);
  ASSERT_EQ(r.forces.size(), scene.num_elements());
  EXPECT_TRUE(r.forces.allFinite());
}

// One backend iteration (outer iteration for the alternating schemes) cannot
// form-find a twisted, perturbed prism: the budget is the status, and the
// result is the backend's finite iterate, not the scene.
TEST_P(EveryBackend, OneIterationIsMaxIterations) {
  scenes::NodeNoise noise;
  noise.fraction = 0.05;
  PrismParameters p;
  p.n = 8;
  p.twist_offset = 15.0 * M_PI / 180.0;
  const Structure scene = scenes::with_node_noise(make_regular_prism(p), noise, 9u);
  SolveOptions options;
  options.max_iterations = 1;
  const SolveResult r = make_solver(GetParam())->Solve(scene, options, DriverControls{false});
  std::printf("%s: %s, %d iterations, relative residual %.1e\n", GetParam().c_str(), r.message.c_str(),
              r.stats.iterations, r.stats.relative_residual);
  EXPECT_EQ(r.status, Status::MaxIterations) << r.message;
  EXPECT_EQ(r.stats.iterations, 1);
  EXPECT_GT(r.stats.relative_residual, options.tolerance);
  EXPECT_TRUE(r.positions.allFinite() && r.forces.allFinite());
}

std::string test_name(const ::testing::TestParamInfo<std::string>& info) {
  std::string s = info.param;
  for (char& c : s)
    if (c == '-') c = '_';
  return s;
}

INSTANTIATE_TEST_SUITE_P(Registry, EveryBackend, ::testing::ValuesIn(solver_names()), test_name);

}  // namespace
}  // namespace tensegrity
