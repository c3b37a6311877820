// What every registered backend shares through the scene driver
// (solvers/solver.hpp): its name in the registry, the rejection of an option
// it does not know, and the precheck that makes gravity on a part without
// fixed nodes `infeasible` before any backend iteration.
#include <gtest/gtest.h>

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

std::string test_name(const ::testing::TestParamInfo<std::string>& info) {
  std::string s = info.param;
  for (char& c : s)
    if (c == '-') c = '_';
  return s;
}

INSTANTIATE_TEST_SUITE_P(Registry, EveryBackend, ::testing::ValuesIn(solver_names()), test_name);

}  // namespace
}  // namespace tensegrity
