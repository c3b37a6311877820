// The fabrication end-to-end check: a designed structure settles at
// its designed shape under gravity, the paper's constant-fraction baseline
// does not for any fraction of a sweep; and the force-cap LP that explains an
// infeasible design.
#include "design/naive_sweep.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "formulations/force_scale.hpp"
#include "formulations/stiffness_qp.hpp"
#include "model/scene_io.hpp"
#include "simulation_fixtures.hpp"
#include "design/force_cap.hpp"
#include "solvers/solver.hpp"

namespace tensegrity {
namespace {

class GravityPrismDesign : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = testing::temp_dir("naive-sweep");
    const std::string scene = testing::gravity_prism_scene(dir_, 4);
    const std::string path =
        testing::run_design(scene, {"--material", "elastic-cord-2mm", "--strain", "0.3"}, dir_ + "/prism.design.json");
    ASSERT_FALSE(path.empty()) << "tensegrity design failed, see " << dir_ << "/prism.design.json.logs/stderr";
    design_ = read_design_file(path);
  }
  static void TearDownTestSuite() { testing::remove_temp_dir_unless_failed(dir_); }
  static std::string dir_;
  static Design design_;
};
std::string GravityPrismDesign::dir_;
Design GravityPrismDesign::design_;

TEST_F(GravityPrismDesign, DesignedHoldsItsShapeAndNoNaiveFractionDoes) {
  // The whole range the 2 mm cord was measured on: strains 1 down to 0.
  const std::vector<double> fractions = fraction_grid(0.5, 1.0, 501);
  const NaiveComparison c = naive_fraction_sweep(design_, fractions);
  ASSERT_EQ(c.designed.status, Status::Converged) << c.designed.message;
  EXPECT_GT(c.designed.size, 0.1);
  EXPECT_LT(c.designed.relative_displacement, 1e-9);
  EXPECT_EQ(c.designed.slack_cables, 0);
  ASSERT_EQ(c.naive.size(), fractions.size());
  ASSERT_GE(c.best, 0);
  const NaivePoint& best = c.naive[c.best];
  EXPECT_TRUE(best.in_material_range);
  EXPECT_EQ(best.settling.status, Status::Converged) << best.settling.message;
  // A regular prism is nearly the naive case (its cables differ in force by a
  // factor ~2 only), yet the best baseline still moves a million times more
  // than the design: measured 1.03e-3 of the size at F = 0.987.
  EXPECT_GT(best.settling.relative_displacement, 5e-4) << "fraction " << best.fraction;
  std::printf("designed %.3g, best naive fraction %.4g: %.4g of the size\n", c.designed.relative_displacement,
              best.fraction, best.settling.relative_displacement);
  for (const NaivePoint& p : c.naive) {
    EXPECT_GE(p.settling.max_displacement, best.settling.max_displacement - 1e-15) << p.fraction;
    if (p.settling.status == Status::Converged) {
      EXPECT_TRUE(std::isfinite(p.settling.max_displacement));
    }
  }
}

TEST_F(GravityPrismDesign, SimulationAgreesWithTheStaticSettling) {
  SettleOptions o;
  o.method = SettleMethod::Simulate;
  o.duration = 4.0;
  const Settling designed = settle(design_, o);
  ASSERT_EQ(designed.status, Status::Converged) << designed.message;
  EXPECT_LT(designed.relative_displacement, 1e-9);
  // A damped simulation of the baseline comes to rest where the relax ends.
  const Design naive = naive_design(design_, 0.75);
  const Settling simulated = settle(naive, o);
  const Settling relaxed = settle(naive);
  ASSERT_EQ(relaxed.status, Status::Converged) << relaxed.message;
  EXPECT_GT(relaxed.relative_displacement, 1e-2);
  EXPECT_NEAR(simulated.max_displacement, relaxed.max_displacement, 1e-3 * relaxed.max_displacement);
  EXPECT_LT(simulated.kinetic_energy, 1e-9);
  std::printf("naive 0.75: relax %.6g m, simulate %.6g m, kinetic %.3g J\n", relaxed.max_displacement,
              simulated.max_displacement, simulated.kinetic_energy);
}

TEST_F(GravityPrismDesign, NaiveDesignHasTheFractionAsRestLengthsAndTheMaterialForces) {
  const Design naive = naive_design(design_, 0.8);
  const Structure& s = naive.structure;
  const auto materials = naive.material_pointers();
  for (int e = 0; e < s.num_elements(); ++e) {
    const double l = (s.positions.col(s.elements[e].b) - s.positions.col(s.elements[e].a)).norm();
    if (s.elements[e].kind == ElementKind::Strut) {
      EXPECT_DOUBLE_EQ((*naive.solution.rest_lengths)[e], (*design_.solution.rest_lengths)[e]);
      EXPECT_DOUBLE_EQ(naive.solution.forces[e], design_.solution.forces[e]);
    } else {
      EXPECT_NEAR((*naive.solution.rest_lengths)[e], 0.8 * l, 1e-15 * l);
      EXPECT_NEAR(naive.strains[e], 0.25, 1e-12);
      EXPECT_NEAR(naive.solution.forces[e], materials[e]->force(0.25), 1e-12);
    }
  }
  EXPECT_TRUE(naive_fraction_in_material_range(design_, 0.5));
  EXPECT_FALSE(naive_fraction_in_material_range(design_, 0.49));
  const std::vector<double> grid = default_fraction_grid(design_, 3, 0.25);
  ASSERT_EQ(grid.size(), 3u);
  EXPECT_DOUBLE_EQ(grid.front(), 0.5);
  EXPECT_DOUBLE_EQ(grid.back(), 0.8);
}

// The prism standing on its fixed bottom ring has exactly as many unknown
// forces touching free nodes as equations, so its forces are unique up to the
// bottom ring (between fixed nodes, held at the margin): the smallest
// achievable cap ratio is max sigma_c / cap_c of those forces.
TEST_F(GravityPrismDesign, ForceCapEqualsTheLargestRatioWhenTheForcesAreUnique) {
  const Structure& s = design_.structure;
  const Eigen::VectorXd& unique = design_.solution.forces;
  SolveOptions options;
  const int m = s.num_elements();
  const ForceScale fs = make_force_scale(s, options.margin_fraction);
  const StiffnessProblem p = make_stiffness_problem(s, Eigen::VectorXd::Zero(m), fs.margin);
  Eigen::VectorXd cap = Eigen::VectorXd::Constant(m, INFINITY);
  double expected = 0.0;
  int expected_cable = -1;
  for (int e = 0; e < m; ++e) {
    if (s.elements[e].kind != ElementKind::Cable) continue;
    const bool touches_free = !s.fixed[s.elements[e].a] || !s.fixed[s.elements[e].b];
    cap[e] = 0.5 + 0.1 * e;  // distinct caps, so one cable is the bottleneck
    if (touches_free && unique[e] / cap[e] > expected) expected = unique[e] / cap[e], expected_cable = e;
  }
  ASSERT_GT(expected, 0.0);
  const ForceCapResult r = smallest_force_cap(s, s.positions, p.lower, p.upper, cap);
  ASSERT_EQ(r.status, Status::Converged) << r.message;
  EXPECT_NEAR(r.ratio, expected, 1e-6 * expected);
  ASSERT_FALSE(r.tightest.empty());
  EXPECT_EQ(r.tightest.front(), expected_cable);
  double total_share = 0.0;
  for (double w : r.share) total_share += w;
  EXPECT_NEAR(total_share, 1.0, 1e-4);
}

}  // namespace
}  // namespace tensegrity
