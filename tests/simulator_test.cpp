// Implicit Euler (Eq. 7) and the static relax: energy bookkeeping, damping,
// designed shapes that hold under gravity, sag when turned, and sag less with
// stiffer cords.
#include "simulation/simulator.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <random>
#include <vector>

#include "simulation_fixtures.hpp"

namespace tensegrity {
namespace {

using testing::prism_design;

// A free prism (no gravity, nothing fixed), nodes displaced by ~1% of its size.
Simulator perturbed_free_prism(const SimulationOptions& o, ElasticModel* out_model = nullptr) {
  const Design d = prism_design(4, "elastic-cord-1mm", 2.0);
  const ElasticModel model = make_elastic_model(d);
  if (out_model) *out_model = model;
  Simulator sim(model, Eigen::Vector3d::Zero(), o);
  Eigen::Matrix3Xd x = model.reference;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int i = 0; i < x.cols(); ++i) x.col(i) += 0.002 * Eigen::Vector3d(u(rng), u(rng), u(rng));
  sim.set_state(x, Eigen::Matrix3Xd::Zero(3, x.cols()));
  return sim;
}

struct EnergyRun {
  double initial = 0.0, final = 0.0, dissipation = 0.0, worst_balance = 0.0;
  bool monotone = true, converged = true;
};

EnergyRun run_energy(double h, double duration, double damping) {
  SimulationOptions o;
  o.time_step = h;
  o.mass_damping = damping;
  o.tolerance = 1e-9;
  Simulator sim = perturbed_free_prism(o);
  EnergyRun r;
  r.initial = sim.kinetic_energy() + sim.potential_energy();
  double previous = r.initial;
  const int steps = static_cast<int>(std::lround(duration / h));
  for (int k = 0; k < steps; ++k) {
    const StepReport s = sim.step();
    r.converged = r.converged && s.converged;
    const double now = sim.kinetic_energy() + sim.potential_energy();
    r.dissipation += s.velocity_jump + s.bregman;
    if (damping == 0.0)
      r.worst_balance = std::max(r.worst_balance, std::abs(now - previous + s.velocity_jump + s.bregman));
    r.monotone = r.monotone && now <= previous + 1e-12 * r.initial;
    previous = now;
  }
  r.final = previous;
  return r;
}

TEST(Simulator, WithoutDampingEnergyDriftsOnlyByImplicitEulersDissipation) {
  const EnergyRun r = run_energy(1.0 / 240.0, 0.25, 0.0);
  ASSERT_TRUE(r.converged);
  ASSERT_GT(r.initial, 1e-6);
  // Each step's exact balance H_{n+1} - H_n = -(1/2 |dv|_M^2 + D_E): holds to the Newton tolerance.
  EXPECT_LT(r.worst_balance, 1e-8 * r.initial);
  // The drift is a loss, and no larger than the scheme's expected dissipation.
  EXPECT_LE(r.final, r.initial);
  EXPECT_LE(r.initial - r.final, r.dissipation * (1.0 + 1e-6) + 1e-12);
  EXPECT_NEAR(r.initial - r.final, r.dissipation, 1e-6 * r.initial);
}

TEST(Simulator, ImplicitEulerDissipationShrinksWithTheStep) {
  const EnergyRun coarse = run_energy(1.0 / 120.0, 0.1, 0.0);
  const EnergyRun fine = run_energy(1.0 / 480.0, 0.1, 0.0);
  ASSERT_TRUE(coarse.converged && fine.converged);
  EXPECT_LT(fine.initial - fine.final, coarse.initial - coarse.final);
}

TEST(Simulator, WithDampingEnergyDecreasesMonotonically) {
  const EnergyRun r = run_energy(1.0 / 120.0, 0.5, 5.0);
  ASSERT_TRUE(r.converged);
  EXPECT_TRUE(r.monotone);
  EXPECT_LT(r.final, 0.5 * r.initial);
}

TEST(Simulator, FreeFallMatchesGravityExactly) {
  // A structure in self-equilibrium falls as a rigid body: x(t_n) from the
  // implicit Euler recurrence v_{n+1} = v_n + h g, x_{n+1} = x_n + h v_{n+1}.
  const Design d = prism_design(3, "elastic-cord-2mm", 1.0);
  const ElasticModel model = make_elastic_model(d);
  SimulationOptions o;
  o.time_step = 0.01;
  const Eigen::Vector3d g(1.0, 2.0, -9.81);
  Simulator sim(model, g, o);
  for (int k = 0; k < 10; ++k) ASSERT_TRUE(sim.step().converged);
  const double drop_factor = 0.01 * 0.01 * 10 * 11 / 2.0;  // h^2 n (n + 1) / 2
  for (int i = 0; i < model.reference.cols(); ++i)
    EXPECT_LT((sim.positions().col(i) - model.reference.col(i) - drop_factor * g).norm(), 1e-9) << i;
}

TEST(Simulator, DragPullsANodeTowardItsTarget) {
  const Design d = prism_design(3, "elastic-cord-1mm", 1.0);
  ElasticModel model = make_elastic_model(d);
  for (int i = 0; i < 3; ++i) model.structure.fixed[i] = true;
  SimulationOptions o;
  o.mass_damping = 10.0;
  Simulator sim(model, Eigen::Vector3d::Zero(), o);
  const Eigen::Vector3d target = model.reference.col(4) + Eigen::Vector3d(0.0, 0.0, 0.03);
  sim.set_drags({{4, target, 200.0}});
  for (int k = 0; k < 240; ++k) ASSERT_TRUE(sim.step().converged);
  const double before = (model.reference.col(4) - target).norm();
  const double after = (sim.positions().col(4) - target).norm();
  EXPECT_LT(after, 0.8 * before);
  // At rest, the same equilibrium as the static relax with that drag.
  const RelaxResult r = relax(sim.energy(), model.reference, sim.drags());
  ASSERT_EQ(r.status, Status::Converged) << r.message;
  EXPECT_LT((r.positions - sim.positions()).cwiseAbs().maxCoeff(), 1e-5 * model.length_scale);
}

class DesignedPrism : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = testing::temp_dir("simulator");
    scene_ = testing::gravity_prism_scene(dir_);
  }
  static void TearDownTestSuite() { testing::remove_temp_dir_unless_failed(dir_); }
  static Design design(const std::string& material) {
    const std::string out = dir_ + "/" + material.substr(material.rfind('/') + 1) + ".design.json";
    const std::string path = testing::run_design(scene_, {"--material", material, "--strain", "0.3"}, out);
    EXPECT_FALSE(path.empty()) << "tensegrity design failed, see " << out << ".logs/stderr";
    return read_design_file(path);
  }
  static double sag(const Design& d, const Eigen::Vector3d& gravity) {
    const ElasticModel model = make_elastic_model(d);
    const RelaxResult r = relax(ElasticEnergy(model, gravity), model.reference);
    EXPECT_EQ(r.status, Status::Converged) << r.message;
    return r.max_displacement / model.length_scale;
  }
  static std::string dir_, scene_;
};
std::string DesignedPrism::dir_, DesignedPrism::scene_;

TEST_F(DesignedPrism, StaysPutUnderGravityInSimulationAndRelax) {
  const Design d = design("elastic-cord-1mm");
  const ElasticModel model = make_elastic_model(d);
  const double size = model.length_scale;
  const RelaxResult r = relax(ElasticEnergy(model), model.reference);
  ASSERT_EQ(r.status, Status::Converged) << r.message;
  EXPECT_LT(r.max_displacement, 1e-6 * size);
  EXPECT_EQ(r.cables_slack, 0);
  SimulationOptions o;
  Simulator sim(model, model.structure.gravity, o);
  for (int k = 0; k < 120; ++k) ASSERT_TRUE(sim.step().converged) << k;
  EXPECT_LT((sim.positions() - model.reference).colwise().norm().maxCoeff(), 1e-6 * size);
}

TEST_F(DesignedPrism, TurnedAgainstGravityItSagsAndStifferCordsSagLess) {
  const Design soft = design("elastic-cord-1mm");
  const Design stiff = design("elastic-cord-2mm");
  const Eigen::Vector3d down = soft.structure.gravity, sideways(9.81, 0.0, 0.0);
  EXPECT_LT(sag(soft, down), 1e-6);
  const double sag_soft = sag(soft, sideways), sag_stiff = sag(stiff, sideways);
  EXPECT_GT(sag_soft, 1e-3);  // visibly: more than 0.1% of its size
  EXPECT_LT(sag_stiff, sag_soft);
  // A cord four times stiffer than the 2 mm one (same curve shape): less again.
  CableMaterial m = testing::shipped_material("elastic-cord-2mm");
  for (double& c : m.coefficients) c *= 4.0;
  m.name = "cord-2mm-x4";
  const std::string path = dir_ + "/cord-2mm-x4.json";
  write_material_file(m, path);
  EXPECT_LT(sag(design(path), sideways), sag_stiff);
}

// ---- substeps -------------------------------------------------------------------

// The designed duck (data/characters) with its head tip, node 59, pulled 5 cm
// along +y by the drag spring `tensegrity simulate` uses, damping 2/s. At
// h = 1/60 s the first step's Newton solve does not converge within 50
// iterations: the exact Hessian of Phi stays indefinite, and the definite one
// converges only linearly.
class DuckDrag : public ::testing::Test {
 protected:
  static constexpr int kHeadTip = 59;
  static void SetUpTestSuite() {
    dir_ = testing::temp_dir("simulator-substeps");
    const std::string character = std::string(TENSEGRITY_SOURCE_DIR) + "/data/characters/duck.character.json";
    const std::string path = testing::run_design(character, {"--quiet"}, dir_ + "/duck.design.json");
    ASSERT_FALSE(path.empty()) << "tensegrity design failed, see " << dir_ << "/duck.design.json.logs/stderr";
    model_ = std::make_unique<ElasticModel>(make_elastic_model(read_design_file(path)));
  }
  void SetUp() override { ASSERT_TRUE(model_) << "no duck design"; }
  static void TearDownTestSuite() {
    model_.reset();
    testing::remove_temp_dir_unless_failed(dir_);
  }

  struct Run {
    Eigen::Matrix3Xd positions;
    std::vector<StepReport> reports;
    double time = 0.0;
  };
  // `steps` steps of h from rest; 0 halvings: one Newton solve per step.
  static Run drag(double h, int steps, int max_substep_halvings = kDefaultMaxSubstepHalvings) {
    const ElasticModel& model = *model_;
    SimulationOptions o;
    o.time_step = h;
    o.mass_damping = 2.0;
    o.max_substep_halvings = max_substep_halvings;
    Simulator sim(model, model.structure.gravity, o);
    const double stiffness = model.force_scale / (0.05 * model.length_scale);
    sim.set_drags({{kHeadTip, model.reference.col(kHeadTip) + Eigen::Vector3d(0.0, 0.05, 0.0), stiffness}});
    Run r;
    for (int k = 0; k < steps; ++k) r.reports.push_back(sim.step());
    r.positions = sim.positions();
    r.time = sim.time();
    return r;
  }
  static double max_distance(const Eigen::Matrix3Xd& a, const Eigen::Matrix3Xd& b) {
    return (a - b).colwise().norm().maxCoeff();
  }
  static std::string dir_;
  static std::unique_ptr<ElasticModel> model_;
};
std::string DuckDrag::dir_;
std::unique_ptr<ElasticModel> DuckDrag::model_;

TEST_F(DuckDrag, TheFullStepFailsAndItsHalvesAreTheHalfStepRun) {
  const double h = 1.0 / 60.0;
  ASSERT_FALSE(drag(h, 1, 0).reports[0].converged) << "the duck's first step converged at h: no case for substeps";
  // Split once, the step is two implicit-Euler steps of h/2 under the same
  // drag: the run at h/2, bit for bit.
  const Run split = drag(h, 1), half = drag(h / 2, 2);
  ASSERT_TRUE(split.reports[0].converged);
  EXPECT_EQ(split.reports[0].substeps, 2);
  EXPECT_EQ(split.reports[0].retries, 1);
  EXPECT_EQ(split.reports[0].smallest_substep, h / 2);
  EXPECT_EQ(split.time, h);
  EXPECT_TRUE((split.positions.array() == half.positions.array()).all())
      << "largest difference " << max_distance(split.positions, half.positions) << " m";
  // The command-line run of docs/CHARACTERS.md (2 s): every step converges now.
  const Run whole = drag(h, 120);
  int split_steps = 0;
  for (std::size_t k = 0; k < whole.reports.size(); ++k) {
    EXPECT_TRUE(whole.reports[k].converged) << k;
    split_steps += whole.reports[k].substeps > 1;
  }
  EXPECT_GE(split_steps, 3);
  EXPECT_NEAR(whole.time, 2.0, 1e-12);
}

TEST_F(DuckDrag, TheCommandExitsZeroAndItsFramesCountTheSubsteps) {
  // docs/CHARACTERS.md's command, 10 steps: frames 1-5 are split in two.
  const Eigen::Vector3d target = model_->reference.col(kHeadTip) + Eigen::Vector3d(0.0, 0.05, 0.0);
  char drag_option[128];
  std::snprintf(drag_option, sizeof drag_option, "%d:%.17g,%.17g,%.17g", kHeadTip, target.x(), target.y(), target.z());
  const std::string frames = dir_ + "/duck.jsonl", logs = dir_ + "/simulate.logs";
  std::filesystem::create_directories(logs);
  const testing::ProgramRun run = testing::run_program(
      {"simulate", dir_ + "/duck.design.json", "--steps", "10", "--drag", drag_option, "--damping", "2", "--out",
       frames, "--no-vtk", "--quiet"},
      logs);
  ASSERT_EQ(run.exit_status, 0) << run.err;
  std::ifstream in(frames);
  std::string line;
  std::vector<nlohmann::json> lines;
  while (std::getline(in, line)) lines.push_back(nlohmann::json::parse(line));
  ASSERT_EQ(lines.size(), 11u);
  EXPECT_FALSE(lines[0].contains("substeps"));
  const Run reference = drag(1.0 / 60.0, 10);
  for (int k = 1; k <= 10; ++k) {
    EXPECT_EQ(lines[k].at("substeps").get<int>(), reference.reports[k - 1].substeps) << k;
    EXPECT_TRUE(lines[k].at("converged").get<bool>()) << k;
  }
  EXPECT_EQ(lines[1].at("substeps").get<int>(), 2);
}

TEST_F(DuckDrag, AMovedTargetIsInterpolatedOverTheHalves) {
  // Step 1 pulls 5 mm, step 2 moves the target to 5 cm. The split step 2 is
  // two steps of h/2 with the target half way and then at 5 cm.
  const ElasticModel& model = *model_;
  const double h = 1.0 / 60.0, stiffness = model.force_scale / (0.05 * model.length_scale);
  const Eigen::Vector3d near = model.reference.col(kHeadTip) + Eigen::Vector3d(0.0, 0.005, 0.0);
  const Eigen::Vector3d far = model.reference.col(kHeadTip) + Eigen::Vector3d(0.0, 0.05, 0.0);
  SimulationOptions o;
  o.time_step = h;
  o.mass_damping = 2.0;
  Simulator sim(model, model.structure.gravity, o);
  sim.set_drags({{kHeadTip, near, stiffness}});
  const StepReport first = sim.step();
  ASSERT_TRUE(first.converged);
  ASSERT_EQ(first.substeps, 1);
  SimulationOptions half_options = o;
  half_options.time_step = h / 2;
  half_options.max_substep_halvings = 0;
  Simulator half(model, model.structure.gravity, half_options);
  half.set_state(sim.positions(), sim.velocities());
  sim.set_drags({{kHeadTip, far, stiffness}});
  const StepReport second = sim.step();
  ASSERT_TRUE(second.converged);
  ASSERT_EQ(second.substeps, 2) << "the moved target's step was not split in two";
  half.set_drags({{kHeadTip, near + 0.5 * (far - near), stiffness}});
  ASSERT_TRUE(half.step().converged);
  half.set_drags({{kHeadTip, far, stiffness}});
  ASSERT_TRUE(half.step().converged);
  EXPECT_TRUE((sim.positions().array() == half.positions().array()).all())
      << "largest difference " << max_distance(sim.positions(), half.positions()) << " m";
  EXPECT_TRUE((sim.velocities().array() == half.velocities().array()).all());
}

TEST_F(DuckDrag, AStepFailingAtEveryLevelIsReportedOnceSplitToTheSmallest) {
  // One Newton iteration per solve cannot converge at any step size: the step
  // is split to h/16 everywhere (16 substeps, 15 abandoned solves), reported
  // not converged, and still ends at h with finite positions.
  const ElasticModel& model = *model_;
  SimulationOptions o;
  o.mass_damping = 2.0;
  o.max_newton_iterations = 1;
  Simulator sim(model, model.structure.gravity, o);
  sim.set_drags({{kHeadTip, model.reference.col(kHeadTip) + Eigen::Vector3d(0.0, 0.05, 0.0),
                  model.force_scale / (0.05 * model.length_scale)}});
  const StepReport r = sim.step();
  const int smallest = 1 << kDefaultMaxSubstepHalvings;
  EXPECT_FALSE(r.converged);
  EXPECT_EQ(r.substeps, smallest);
  EXPECT_EQ(r.retries, smallest - 1);
  EXPECT_EQ(r.newton_iterations, 2 * smallest - 1);  // one per solve
  EXPECT_EQ(r.smallest_substep, o.time_step / smallest);
  EXPECT_EQ(sim.time(), o.time_step);
  EXPECT_TRUE(sim.positions().allFinite() && sim.velocities().allFinite());
}

TEST_F(DuckDrag, ARunThatNeverSplitsIsBitIdenticalToOneSolvePerStep) {
  // From step 4 on the steps converge at h: continue a run from the same state both ways.
  const double h = 1.0 / 60.0;
  const Run with_retry = drag(h / 2, 12), without = drag(h / 2, 12, 0);
  for (const StepReport& r : with_retry.reports) ASSERT_EQ(r.substeps, 1);
  EXPECT_EQ(with_retry.time, without.time);
  EXPECT_TRUE((with_retry.positions.array() == without.positions.array()).all())
      << "largest difference " << max_distance(with_retry.positions, without.positions) << " m";
  for (std::size_t k = 0; k < without.reports.size(); ++k)
    EXPECT_EQ(with_retry.reports[k].newton_iterations, without.reports[k].newton_iterations) << k;
}

TEST(Simulator, AStepThatConvergesIsUnchangedByTheRetry) {
  // The free prism of the energy tests (with stiffness damping): every step
  // converges at once, and the states with the retry on and off agree bit for bit.
  SimulationOptions on, off;
  on.time_step = off.time_step = 1.0 / 120.0;
  on.stiffness_damping = off.stiffness_damping = 1e-3;
  off.max_substep_halvings = 0;
  Simulator a = perturbed_free_prism(on), b = perturbed_free_prism(off);
  for (int k = 0; k < 30; ++k) {
    const StepReport ra = a.step(), rb = b.step();
    ASSERT_TRUE(ra.converged && rb.converged) << k;
    EXPECT_EQ(ra.substeps, 1);
    EXPECT_EQ(ra.retries, 0);
    EXPECT_EQ(ra.smallest_substep, on.time_step);
    EXPECT_EQ(ra.newton_iterations, rb.newton_iterations);
  }
  EXPECT_TRUE((a.positions().array() == b.positions().array()).all());
  EXPECT_TRUE((a.velocities().array() == b.velocities().array()).all());
}

TEST(Relax, GravityWithoutSupportIsInfeasible) {
  const Design d = prism_design(3, "elastic-cord-1mm", 1.0);
  const ElasticModel model = make_elastic_model(d);
  const RelaxResult r = relax(ElasticEnergy(model, Eigen::Vector3d(0, 0, -9.81)), model.reference);
  EXPECT_EQ(r.status, Status::Infeasible);
}

TEST(Relax, FindsTheSelfStressedShapeFromADisplacedStart) {
  const Design d = prism_design(5, "elastic-cord-1mm", 1.5);
  const ElasticModel model = make_elastic_model(d);
  const ElasticEnergy energy(model);
  Eigen::Matrix3Xd x = model.reference;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int i = 0; i < x.cols(); ++i) x.col(i) += 0.01 * Eigen::Vector3d(u(rng), u(rng), u(rng));
  const RelaxResult r = relax(energy, x);
  ASSERT_EQ(r.status, Status::Converged) << r.message;
  // Same shape up to a rigid motion: every element length as designed.
  for (int e = 0; e < model.structure.num_elements(); ++e) {
    const auto& el = model.structure.elements[e];
    const double l0 = (model.reference.col(el.b) - model.reference.col(el.a)).norm();
    const double l1 = (r.positions.col(el.b) - r.positions.col(el.a)).norm();
    EXPECT_NEAR(l1, l0, 1e-7 * l0) << e;
    EXPECT_NEAR(r.forces[e], d.solution.forces[e], 1e-6 * std::abs(d.solution.forces[e])) << e;
  }
}

}  // namespace
}  // namespace tensegrity
