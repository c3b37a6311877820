// Finite-difference checks of Eq. 5's derivatives (formulations/minimal_geometry_change_nlp.hpp):
// gradient, constraint Jacobian and Hessian of the Lagrangian, at random points
// with random multipliers, on scenes with and without gravity and fixed nodes.
#include "formulations/minimal_geometry_change_nlp.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "formulations/force_scale.hpp"
#include "model/reference_scenes.hpp"
#include "scenes/suites.hpp"

namespace tensegrity {
namespace {

using Dense = Eigen::MatrixXd;

struct NamedScene {
  std::string label;
  Structure structure;
};

std::vector<NamedScene> scenes() {
  using namespace tensegrity::scenes;
  return {
      {"prism3-twist15", prism(3, 15.0)},
      {"prism5-twist-10", prism(5, -10.0)},
      {"prism6-noise5", perturbed(prism(6, 5.0), 0.05, 21u)},
      {"prism4-gravity-fixed", perturbed(prism(4, 10.0, true), 0.02, 22u)},
      {"octahedron-noise5", perturbed(octahedron(), 0.05, 23u)},
      {"octahedron-gravity-fixed", perturbed(octahedron(true), 0.03, 24u)},
  };
}

// A point away from the scene: positions moved, forces of the right signs but
// otherwise random, so every derivative term is exercised.
Eigen::VectorXd random_point(const MinimalGeometryChangeNlp& nlp, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double f0 = nlp.force_scale().reference_force;
  Eigen::VectorXd sigma(nlp.num_forces());
  for (int e = 0; e < nlp.num_forces(); ++e) {
    const double magnitude = f0 * (0.5 + std::abs(u(rng)));
    sigma[e] = nlp.force_scale().lower[e] > 0.0 ? magnitude : -magnitude;
  }
  Eigen::VectorXd z = nlp.initial_point(sigma);
  for (int i = 0; i < nlp.num_positions(); ++i) z[i] += 0.05 * nlp.length_scale() * u(rng);
  return z;
}

Dense dense_jacobian(MinimalGeometryChangeNlp& nlp, const Eigen::VectorXd& z) {
  std::vector<int> rows, cols;
  nlp.jacobian_structure(rows, cols);
  std::vector<double> values(nlp.jacobian_nonzeros());
  nlp.jacobian_values(z, values.data());
  Dense J = Dense::Zero(nlp.num_constraints(), nlp.num_variables());
  for (std::size_t k = 0; k < rows.size(); ++k) J(rows[k], cols[k]) += values[k];
  return J;
}

// Worst |analytic - fd| over the largest analytic entry.
double relative_error(const Dense& analytic, const Dense& fd) {
  const double scale = std::max(analytic.cwiseAbs().maxCoeff(), 1e-300);
  return (analytic - fd).cwiseAbs().maxCoeff() / scale;
}

// Step per variable: relative to the length scale on q and to F0 on sigma.
double step(const MinimalGeometryChangeNlp& nlp, int j) {
  return 1e-6 * (j < nlp.num_positions() ? nlp.length_scale() : nlp.force_scale().reference_force);
}

class NlpDerivatives : public ::testing::TestWithParam<int> {};

TEST_P(NlpDerivatives, MatchFiniteDifferences) {
  const NamedScene scene = scenes()[GetParam()];
  const ForceScale scale = make_force_scale(scene.structure);
  MinimalGeometryChangeNlp nlp(scene.structure, scale);
  const int n = nlp.num_variables();
  const int mc = nlp.num_constraints();
  ASSERT_EQ(n, nlp.num_positions() + nlp.num_forces());
  ASSERT_EQ(mc, nlp.num_positions() + 1);

  std::mt19937 rng(1234u + GetParam());
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  double worst_gradient = 0.0, worst_jacobian = 0.0, worst_hessian = 0.0;
  for (int trial = 0; trial < 3; ++trial) {
    const Eigen::VectorXd z = random_point(nlp, rng);

    // Gradient.
    Eigen::VectorXd g;
    nlp.gradient(z, g);
    Dense g_fd(n, 1);
    for (int j = 0; j < n; ++j) {
      Eigen::VectorXd zp = z, zm = z;
      const double h = step(nlp, j);
      zp[j] += h;
      zm[j] -= h;
      g_fd(j, 0) = (nlp.objective(zp) - nlp.objective(zm)) / (2 * h);
    }
    worst_gradient = std::max(worst_gradient, relative_error(Dense(g), g_fd));

    // Constraint Jacobian (dense from the triplets).
    const Dense J = dense_jacobian(nlp, z);
    Dense J_fd(mc, n);
    Eigen::VectorXd cp, cm;
    for (int j = 0; j < n; ++j) {
      Eigen::VectorXd zp = z, zm = z;
      const double h = step(nlp, j);
      zp[j] += h;
      zm[j] -= h;
      nlp.constraints(zp, cp);
      nlp.constraints(zm, cm);
      J_fd.col(j) = (cp - cm) / (2 * h);
    }
    worst_jacobian = std::max(worst_jacobian, relative_error(J, J_fd));

    // Hessian of obj_factor * objective + lambda^T c, from the lower triangle,
    // against differences of the Lagrangian's gradient.
    const double obj_factor = 0.5 + std::abs(u(rng));
    Eigen::VectorXd lambda(mc);
    for (int r = 0; r < mc; ++r) lambda[r] = u(rng);
    std::vector<int> rows, cols;
    nlp.hessian_structure(rows, cols);
    ASSERT_EQ(static_cast<int>(rows.size()), nlp.hessian_nonzeros());
    std::vector<double> values(nlp.hessian_nonzeros());
    nlp.hessian_values(z, obj_factor, lambda, values.data());
    Dense H = Dense::Zero(n, n);
    for (std::size_t k = 0; k < rows.size(); ++k) {
      ASSERT_GE(rows[k], cols[k]) << "Hessian triplet above the diagonal";
      H(rows[k], cols[k]) += values[k];
      if (rows[k] != cols[k]) H(cols[k], rows[k]) += values[k];
    }
    auto lagrangian_gradient = [&](const Eigen::VectorXd& zz) {
      Eigen::VectorXd grad;
      nlp.gradient(zz, grad);
      return Eigen::VectorXd(obj_factor * grad + dense_jacobian(nlp, zz).transpose() * lambda);
    };
    Dense H_fd(n, n);
    for (int j = 0; j < n; ++j) {
      Eigen::VectorXd zp = z, zm = z;
      const double h = step(nlp, j);
      zp[j] += h;
      zm[j] -= h;
      H_fd.col(j) = (lagrangian_gradient(zp) - lagrangian_gradient(zm)) / (2 * h);
    }
    worst_hessian = std::max(worst_hessian, relative_error(H, H_fd));

    // Same point again: same values in the same order.
    std::vector<double> again(values.size());
    nlp.hessian_values(z, obj_factor, lambda, again.data());
    EXPECT_EQ(values, again);
  }
  std::printf("[ %s ] worst relative error: gradient %.2e, Jacobian %.2e, Hessian %.2e\n",
              scene.label.c_str(), worst_gradient, worst_jacobian, worst_hessian);
  EXPECT_LT(worst_gradient, 1e-7);
  EXPECT_LT(worst_jacobian, 1e-7);
  EXPECT_LT(worst_hessian, 1e-6);
}

INSTANTIATE_TEST_SUITE_P(Scenes, NlpDerivatives, ::testing::Range(0, 6),
                         [](const ::testing::TestParamInfo<int>& info) {
                           std::string label = scenes()[info.param].label;
                           for (char& c : label)
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           return label;
                         });

TEST(MinimalGeometryChangeNlp, ObjectiveIsScaledDistanceAndConstraintsAreEquilibrium) {
  const Structure s = scenes::prism(4, 10.0);
  const ForceScale scale = make_force_scale(s);
  MinimalGeometryChangeNlp nlp(s, scale);
  const Eigen::VectorXd sigma = reference_forces(s, scale);
  Eigen::VectorXd z = nlp.initial_point(sigma);
  EXPECT_EQ(nlp.objective(z), 0.0);
  z[0] += 0.3;
  z[4] -= 0.4;
  const double L = s.mean_element_length();
  EXPECT_NEAR(nlp.objective(z), 0.25 / (L * L), 1e-14);

  // At the reference forces the normalisation row holds exactly.
  Eigen::VectorXd c, lower, upper;
  nlp.constraints(z, c);
  nlp.constraint_bounds(lower, upper);
  EXPECT_NEAR(c[nlp.num_positions()], lower[nlp.num_positions()], 1e-12);
  EXPECT_EQ(lower[nlp.num_positions()], 4 * 3 * 1.0);  // 12 cables, F0 = 1 N

  // Round trip of positions and forces; fixed nodes are absent from q.
  const Eigen::Matrix3Xd x = nlp.positions(z);
  EXPECT_NEAR((x - s.positions).norm(), 0.5, 1e-14);
  EXPECT_EQ(nlp.forces(z), sigma);

  Eigen::VectorXd vl, vu;
  nlp.variable_bounds(vl, vu);
  EXPECT_TRUE(std::isinf(vl[0]));
  EXPECT_EQ(vu[nlp.num_positions()], -scale.margin);  // element 0 is a strut
}

TEST(MinimalGeometryChangeNlp, FixedNodesAreNotUnknowns) {
  const Structure s = scenes::prism(5, 0.0, true);
  MinimalGeometryChangeNlp nlp(s, make_force_scale(s));
  EXPECT_EQ(nlp.num_positions(), 3 * 5);
  EXPECT_EQ(nlp.num_forces(), 20);
  EXPECT_EQ(nlp.num_constraints(), 16);
}

}  // namespace
}  // namespace tensegrity

namespace tensegrity {
namespace {

// Under gravity the cable-sum row holds the mean cable force at kappa times the
// weight (docs/THEORY-force-scale.md: the upper bound made Ipopt wander).
TEST(MinimalGeometryChangeNlp, UnderGravityTheCableSumRowHoldsKappaTimesTheWeight) {
  PrismParameters p;
  p.n = 4;
  p.gravity = true;
  p.fix_bottom = true;
  p.strut_mass = 0.5;
  const Structure s = make_regular_prism(p);
  const ForceScale scale = make_force_scale(s, 1e-3, 20.0);
  MinimalGeometryChangeNlp nlp(s, scale);
  ASSERT_EQ(nlp.num_constraints(), nlp.num_positions() + 1);
  Eigen::VectorXd lower, upper;
  nlp.constraint_bounds(lower, upper);
  const int row = nlp.num_positions();
  EXPECT_NEAR(lower[row], 20.0 * 12 * scale.reference_force, 1e-9);
  EXPECT_NEAR(upper[row], 20.0 * 12 * scale.reference_force, 1e-9);
  EXPECT_EQ(lower.head(row).lpNorm<Eigen::Infinity>(), 0.0);
  Eigen::VectorXd c;
  const Eigen::VectorXd sigma = reference_forces(s, scale);
  nlp.constraints(nlp.initial_point(sigma), c);
  EXPECT_NEAR(c[row], 12 * scale.reference_force, 1e-9);  // the row is c^T sigma
}

}  // namespace
}  // namespace tensegrity
