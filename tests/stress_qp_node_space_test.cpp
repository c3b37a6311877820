// The stress QP solved through the node space (StressQpOptions::node_space)
// against the same QP solved with K: every phase (projected Newton, the
// interior-point phase, the polish, the certificate) on scenes with and
// without the normalisation row, feasible and infeasible.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "formulations/equilibrium.hpp"
#include "formulations/force_scale.hpp"
#include "gravity_tower_fixture.hpp"
#include "kernels/stress_qp.hpp"
#include "model/reference_scenes.hpp"
#include "scenes/towers.hpp"
#include "solvers/standing_check.hpp"

namespace tensegrity {
namespace {

struct Case {
  std::string name;
  Structure scene;
  // False on a near-mechanism: without the mu term (polish_to_optimum) its
  // forces are free along near-null directions of A, and only the objective
  // is the QP's answer (the 10-layer tower as generated: forces 8 N apart at
  // equal objectives).
  bool forces_determined_without_mu = true;
};

// The scenes by name; each is built only when a test asks for it (the
// gravity tower takes an alternating-gn solve, slow under the sanitizers).
const std::vector<std::string> kCaseNames = {"prism6",     "prism6_twisted",       "prism6_gravity_fixed_bottom",
                                             "octahedron", "tower10_as_generated", "tower10_gravity_noise1"};

Case make_case(int index) {
  const std::string& name = kCaseNames.at(index);
  PrismParameters prism;
  prism.n = 6;
  if (name == "prism6_twisted") prism.twist_offset = 0.3;  // not a tensegrity: a positive optimum
  if (name == "prism6_gravity_fixed_bottom") {
    prism.gravity = prism.fix_bottom = true;
    prism.strut_mass = prism.cable_mass = 0.1;
  }
  if (name == "octahedron") return {name, make_expandable_octahedron(OctahedronParameters{})};
  if (name == "tower10_as_generated") {
    scenes::TowerParameters tower;
    tower.noise = 0.0;
    return {name, scenes::make_prism_tower(tower), false};
  }
  if (name == "tower10_gravity_noise1") return {name, testing::gravity_tower_at_equilibrium(10)};
  return {name, make_regular_prism(prism)};
}

class NodeSpace : public ::testing::TestWithParam<int> {};

void expect_same_answer(const Case& c, StressQpOptions options) {
  const Structure& s = c.scene;
  Equilibrium eq(s);
  const ForceScale scale = make_force_scale(s);
  options.node_space = false;
  const StressQpResult with_k = StressQp(eq, scale, options).solve();
  options.node_space = true;
  const StressQpResult through_nodes = StressQp(eq, scale, options).solve();
  EXPECT_EQ(through_nodes.status, with_k.status) << through_nodes.message << " | " << with_k.message;
  // Equal optima (measured: 9 digits or more), and where the optimum is a
  // tensegrity both at rounding level (1e-30 N^2 on the prism).
  constexpr double kSameObjective = 1e-8;     // relative
  constexpr double kRoundingObjective = 1e-20;  // N^2: with F0 = 1 N, far above rounding, far below any residual
  EXPECT_NEAR(through_nodes.objective, with_k.objective,
              kSameObjective * std::max(with_k.objective, kRoundingObjective));
  // The forces (measured: 1e-12 relative or closer, 2e-10 on the tower as generated).
  constexpr double kSameForces = 1e-8;  // relative to |sigma|_inf
  if (c.forces_determined_without_mu || !options.polish_to_optimum) {
    EXPECT_LE((through_nodes.sigma - with_k.sigma).lpNorm<Eigen::Infinity>(),
              kSameForces * with_k.sigma.lpNorm<Eigen::Infinity>());
  }
}

TEST_P(NodeSpace, ProjectedNewtonAndPolishAgreeWithK) {
  const Case c = make_case(GetParam());
  SCOPED_TRACE(c.name);
  expect_same_answer(c, StressQpOptions{});
}

TEST_P(NodeSpace, InteriorPointPhaseAndCertificateAgreeWithK) {
  const Case c = make_case(GetParam());
  SCOPED_TRACE(c.name);
  StressQpOptions o;
  o.interior_point_after = 0;
  o.certify_optimum = true;
  o.polish_to_optimum = true;
  o.max_polish_steps = 200;
  expect_same_answer(c, o);
}

INSTANTIATE_TEST_SUITE_P(Scenes, NodeSpace, ::testing::Range(0, static_cast<int>(kCaseNames.size())),
                         [](const ::testing::TestParamInfo<int>& info) { return kCaseNames[info.param]; });

// The driver's check (which solves through the node space) finds the scenes
// that stand and gives up on the one to be solved, as with K.
TEST(NodeSpace, TheChecksVerdictsAreThoseWithK) {
  int rounded_differently = 0;  // the node space did run: its rounding is not K's
  for (int index = 0; index < static_cast<int>(kCaseNames.size()); ++index) {
    const Case c = make_case(index);
    SCOPED_TRACE(c.name);
    StressQpOptions check = standing_check_qp_options();
    ASSERT_TRUE(check.node_space);
    Equilibrium eq(c.scene);
    const ForceScale scale = make_force_scale(c.scene);
    const StressQpResult through_nodes = StressQp(eq, scale, check).solve();
    check.node_space = false;
    const StressQpResult with_k = StressQp(eq, scale, check).solve();
    EXPECT_EQ(through_nodes.gave_up, with_k.gave_up);
    EXPECT_EQ(through_nodes.status, with_k.status) << through_nodes.message << " | " << with_k.message;
    if (through_nodes.sigma != with_k.sigma) ++rounded_differently;
  }
  EXPECT_GT(rounded_differently, 0);
}

}  // namespace
}  // namespace tensegrity
