// Actuation (simulation/actuation.hpp): the linearised rest-length
// sensitivity against finite differences of the static solve, and a pose made
// by one cable's rest-length change is found again and reached.
#include <gtest/gtest.h>

#include <cmath>

#include "formulations/elastic_energy.hpp"
#include "model/reference_scenes.hpp"
#include "simulation/actuation.hpp"
#include "simulation_fixtures.hpp"
#include "simulation/simulator.hpp"

namespace tensegrity {
namespace {

struct StandingPrism {
  ElasticModel model;
  Eigen::Matrix3Xd x0;
};

// A 3-strut prism standing on its fixed bottom ring, cables at 10 % strain.
StandingPrism standing_prism() {
  PrismParameters p;
  p.n = 3;
  p.radius = 0.1;
  p.height = 0.12;
  p.fix_bottom = true;
  const Structure s = make_regular_prism(p);
  const Eigen::VectorXd sigma = testing::prism_forces(s, 3, 2.0);
  return {make_linear_elastic_model(s, s.positions, sigma, 0.1), s.positions};
}

Eigen::Matrix3Xd relaxed_with_change(const ElasticModel& model, const Eigen::Matrix3Xd& x0, int e, double dl) {
  ElasticModel changed = model;
  changed.rest_lengths[e] += dl;
  const RelaxResult r = relax(ElasticEnergy(changed), x0);
  EXPECT_EQ(r.status, Status::Converged) << r.message;
  return r.positions;
}

TEST(Actuation, SensitivityMatchesFiniteDifferences) {
  const StandingPrism p = standing_prism();
  const ElasticEnergy energy(p.model);
  const Eigen::MatrixXd dxdl = rest_length_sensitivity(energy, p.x0);
  const FreeNodeMap& map = energy.free_map();
  for (int e : {0, 3, 9, 11}) {  // a strut, a vertical and two top ring cables (the bottom ring is fixed)
    SCOPED_TRACE(e);
    const double h = 1e-6 * p.model.rest_lengths[e];
    const Eigen::VectorXd fd =
        (map.gather(relaxed_with_change(p.model, p.x0, e, h)) - map.gather(relaxed_with_change(p.model, p.x0, e, -h))) /
        (2.0 * h);
    EXPECT_GT(fd.norm(), 1e-3);
    EXPECT_LE((dxdl.col(e) - fd).norm(), 1e-4 * fd.norm());
  }
}

TEST(Actuation, OneCablePoseIsFoundAndReached) {
  const StandingPrism p = standing_prism();
  const int cable = 4;  // vertical-1
  const Eigen::Matrix3Xd target = relaxed_with_change(p.model, p.x0, cable, -0.05 * p.model.rest_lengths[cable]);
  Pose pose;
  pose.name = "lean";
  for (int i = 3; i < 6; ++i) pose.targets.push_back({i, target.col(i)});
  ActuationOptions o;
  o.max_actuators = 2;
  const ActuationResult result = find_actuators(p.model, p.x0, {pose}, o);
  ASSERT_TRUE(result.stable_start) << result.message;
  const auto& levels = result.levels;
  ASSERT_EQ(levels.size(), 2u);
  const PoseResult& one = levels[0].poses[0];
  EXPECT_GT(one.initial_error, 1e-3);  // the pose is millimetres away
  EXPECT_LT(one.linear_error, 0.2 * one.initial_error);
  EXPECT_LT(one.reached_error, 1e-6 * one.initial_error);
  EXPECT_EQ(levels[0].elements[0], cable);
  EXPECT_NEAR(one.rest_length_change[0], -0.05 * p.model.rest_lengths[cable], 1e-6 * p.model.rest_lengths[cable]);
}

}  // namespace
}  // namespace tensegrity
