// Actuation (simulation/actuation.hpp): the linearised rest-length
// sensitivity against finite differences of the static solve, a pose made by
// one cable's rest-length change is found again and reached, and on the duck
// (data/characters) a saddle start is reported while a stable one reaches a
// pose by rest-length changes the static solve verifies.
#include <gtest/gtest.h>

#include <cmath>

#include "formulations/elastic_energy.hpp"
#include "model/character.hpp"
#include "model/design.hpp"
#include "model/scene_io.hpp"
#include "model/solution.hpp"
#include "process_runner.hpp"
#include "model/reference_scenes.hpp"
#include "solvers/solver.hpp"
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

// The duck, form-found under gravity, with every cable a linear cord at `cable_strain`.
struct Duck {
  Structure scene;
  Eigen::Matrix3Xd x0;
  Eigen::VectorXd forces;
  ElasticModel model(double cable_strain) const { return make_linear_elastic_model(scene, x0, forces, cable_strain); }
};

const Duck& duck() {
  static const Duck d = [] {
    Duck out;
    out.scene = build_character_file(std::string(TENSEGRITY_SOURCE_DIR) + "/data/characters/duck.character.json").structure;
    const SolveResult r = solve_scene(*make_solver(default_solver_name()), out.scene, SolveOptions{});
    EXPECT_EQ(r.status, Status::Converged) << r.message;
    out.x0 = r.positions;
    out.forces = r.forces;
    return out;
  }();
  return d;
}

// Every free node of the duck's head moved by `by` (m).
Pose head_pose(const Duck& d, const Eigen::Vector3d& by) {
  Pose pose;
  pose.name = "head";
  for (int i = 0; i < d.scene.num_nodes(); ++i)
    if (d.scene.node_extra[i].value("block", "") == "head" && !d.scene.fixed[i]) pose.targets.push_back({i, d.x0.col(i) + by});
  return pose;
}

double rms_distance(const Pose& pose, const Eigen::Matrix3Xd& x) {
  double sum = 0.0;
  for (const auto& t : pose.targets) sum += (t.position - x.col(t.node)).squaredNorm();
  return std::sqrt(sum / pose.targets.size());
}

// Cords at 10 % strain are too soft for the duck's struts: its equilibrium is a
// saddle, and the static solve after any small rest-length change falls far
// from it, so no step could ever be verified. find_actuators says so.
TEST(Actuation, SaddleStartOfTheDuckIsReported) {
  const Duck& d = duck();
  const ElasticModel soft = d.model(0.1);
  const ActuationResult result = find_actuators(soft, d.x0, {head_pose(d, {0, -0.01, 0})});
  EXPECT_FALSE(result.stable_start);
  EXPECT_TRUE(result.levels.empty());
  EXPECT_NE(result.message.find("negative"), std::string::npos) << result.message;
  ElasticModel nudged = soft;
  nudged.rest_lengths[0] *= 1.0 + 1e-6;
  const RelaxResult moved = relax(ElasticEnergy(nudged), d.x0);
  const double far = (moved.positions - d.x0).colwise().norm().maxCoeff();
  EXPECT_TRUE(moved.status != Status::Converged || far > 0.01) << far;
}

// With stiffer cords the start is stable; dx/dL matches the static solve's
// finite differences at a link cable, a neck cable and a strut, and the
// Gauss-Newton stage reaches the pose much better than the start, with the
// reported error that of the static solve at the reported rest lengths.
TEST(Actuation, StableDuckReachesAPoseVerifiedByTheStaticSolve) {
  const Duck& d = duck();
  const ElasticModel model = d.model(0.003);
  const ElasticEnergy energy(model);
  const Eigen::MatrixXd dxdl = rest_length_sensitivity(energy, d.x0);
  const FreeNodeMap& map = energy.free_map();
  for (int e : {143, 282, 142}) {
    SCOPED_TRACE(e);
    const double h = 1e-6 * model.rest_lengths[e];
    const Eigen::VectorXd fd =
        (map.gather(relaxed_with_change(model, d.x0, e, h)) - map.gather(relaxed_with_change(model, d.x0, e, -h))) /
        (2.0 * h);
    EXPECT_GT(fd.norm(), 0.1);
    EXPECT_LE((dxdl.col(e) - fd).norm(), 1e-4 * fd.norm());
  }

  const Pose pose = head_pose(d, {0, -0.01, 0});
  ActuationOptions o;
  o.max_actuators = 2;
  const ActuationResult result = find_actuators(model, d.x0, {pose}, o);
  ASSERT_TRUE(result.stable_start) << result.message;
  ASSERT_EQ(result.levels.size(), 2u);
  double previous = 0.01;
  for (const ActuationLevel& level : result.levels) {
    const PoseResult& pr = level.poses[0];
    EXPECT_NEAR(pr.initial_error, 0.01, 1e-12);
    EXPECT_LT(pr.linear_error, 0.5 * pr.initial_error);
    EXPECT_LT(pr.reached_error, 0.5 * pr.initial_error);  // the steps are no longer all rejected
    EXPECT_LE(pr.reached_error, previous);                // a level starts where the previous one ended
    EXPECT_GT(pr.steps_accepted, 0);
    previous = pr.reached_error;
    ElasticModel changed = model;
    for (std::size_t k = 0; k < level.elements.size(); ++k) changed.rest_lengths[level.elements[k]] += pr.rest_length_change[k];
    const RelaxResult check = relax(ElasticEnergy(changed), d.x0);
    ASSERT_EQ(check.status, Status::Converged) << check.message;
    EXPECT_NEAR(rms_distance(pose, check.positions), pr.reached_error, 1e-6);
  }
}

// The buildable design (`tensegrity design`: stiffness scaling, real cord
// material) makes the duck stable; dx/dL matches the static solve there too,
// at cables and struts of the link, the neck, the head and the body, and one
// cable reaches the head pose the 10 % cords could not move towards, to the
// linear prediction within 10 %.
TEST(Actuation, DesignedDuckMatchesFiniteDifferencesAndReachesThePose) {
  const testing::ScratchDir dir("actuation-design");
  const std::string scene_file = dir.file("duck.scene.json"), solution_file = dir.file("duck.solution.json"),
                    design_file = dir.file("duck.design.json");
  ASSERT_EQ(dir.run({"build", std::string(TENSEGRITY_SOURCE_DIR) + "/data/characters/duck.character.json", "--out",
                     scene_file}).exit_status, 0);
  ASSERT_EQ(dir.run({"solve", scene_file, "--out", solution_file, "--quiet"}).exit_status, 0);
  ASSERT_EQ(dir.run({"design", scene_file, "--out", design_file, "--quiet"}).exit_status, 0);
  const Structure scene = read_scene_file(scene_file);
  const Eigen::Matrix3Xd x0 = read_solution_file(solution_file, scene).positions;
  const ElasticModel model = make_elastic_model(read_design_file(design_file));
  const ElasticEnergy energy(model);
  const ActuationResult start = find_actuators(model, x0, {}, ActuationOptions{});
  EXPECT_TRUE(start.stable_start) << start.message;
  const Eigen::MatrixXd dxdl = rest_length_sensitivity(energy, x0);
  const FreeNodeMap& map = energy.free_map();
  for (int e : {282, 143, 205, 80, 142, 3}) {  // link cable, neck cable, head cable, body tie, neck and body struts
    SCOPED_TRACE(e);
    const double h = 1e-6 * model.rest_lengths[e];
    const Eigen::VectorXd fd =
        (map.gather(relaxed_with_change(model, x0, e, h)) - map.gather(relaxed_with_change(model, x0, e, -h))) /
        (2.0 * h);
    EXPECT_GT(fd.norm(), 0.5);
    EXPECT_LE((dxdl.col(e) - fd).norm(), 2e-5 * fd.norm());
  }

  Pose pose;
  for (int i = 0; i < scene.num_nodes(); ++i)
    if (scene.node_extra[i].value("block", "") == "head" && !scene.fixed[i])
      pose.targets.push_back({i, x0.col(i) + Eigen::Vector3d(0, -0.01, 0)});
  ActuationOptions o;
  o.max_actuators = 1;
  const ActuationResult result = find_actuators(model, x0, {pose}, o);
  ASSERT_EQ(result.levels.size(), 1u);
  const PoseResult& pr = result.levels[0].poses[0];
  EXPECT_NEAR(pr.initial_error, 0.01, 1e-12);
  EXPECT_LT(pr.linear_error, 0.15 * pr.initial_error);
  EXPECT_LT(pr.reached_error, 0.15 * pr.initial_error);
  EXPECT_LT(std::abs(pr.reached_error - pr.linear_error), 0.1 * pr.linear_error);
  ElasticModel changed = model;
  changed.rest_lengths[result.levels[0].elements[0]] += pr.rest_length_change[0];
  const RelaxResult check = relax(ElasticEnergy(changed), x0);
  ASSERT_EQ(check.status, Status::Converged) << check.message;
  EXPECT_NEAR(rms_distance(pose, check.positions), pr.reached_error, 1e-6);
}

}  // namespace
}  // namespace tensegrity
