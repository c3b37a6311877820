// The elastic energy of formulations/elastic_energy.hpp: the cable curve, the
// model built from a design, and finite-difference checks of the gradient and
// the (exact and definite) Hessians.
#include "formulations/elastic_energy.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <random>

#include "design/rest_lengths.hpp"
#include "model/reference_scenes.hpp"
#include "scenes/perturb.hpp"
#include "simulation_fixtures.hpp"

namespace tensegrity {
namespace {

using testing::prism_design;
using testing::shipped_material;

TEST(CableCurve, FollowsTheMaterialAndIsSlackBelowRest) {
  const CableMaterial m = shipped_material("elastic-cord-1mm");
  const CableCurve c(m);
  ASSERT_LT(m.coefficients[0], 0.0);  // the shipped fit crosses zero just above eps = 0
  EXPECT_GT(c.slack_strain(), 0.0);
  EXPECT_NEAR(m.force_unchecked(c.slack_strain()), 0.0, 1e-12);
  for (double eps : {0.05, 0.2, 0.5, 0.99}) EXPECT_DOUBLE_EQ(c.force(eps), m.force(eps)) << eps;
  for (double eps : {-0.3, -1e-9, 0.0, 0.5 * c.slack_strain()}) {
    EXPECT_EQ(c.force(eps), 0.0);
    EXPECT_EQ(c.energy_density(eps), 0.0);
    EXPECT_EQ(c.slope(eps), 0.0);
  }
  // Continued linearly beyond the measured range: value and slope continuous.
  const double top = m.strain_max;
  EXPECT_NEAR(c.force(top + 1e-9), m.force(top), 1e-6);
  EXPECT_NEAR(c.force(top + 0.1) - c.force(top), 0.1 * m.slope_unchecked(top), 1e-9);
  // W' = f and f' = slope, by central differences.
  for (double eps : {0.01, 0.1, 0.3, 0.7, 1.2}) {
    const double h = 1e-6;
    EXPECT_NEAR((c.energy_density(eps + h) - c.energy_density(eps - h)) / (2 * h), c.force(eps), 1e-7) << eps;
    EXPECT_NEAR((c.force(eps + h) - c.force(eps - h)) / (2 * h), c.slope(eps), 1e-5) << eps;
  }
  // Energy from the slack strain to 0.5 against a Simpson rule of F.
  const double a = c.slack_strain(), b = 0.5;
  double simpson = 0.0;
  const int N = 2000;
  for (int k = 0; k <= N; ++k) {
    const double t = a + (b - a) * k / N;
    simpson += (k == 0 || k == N ? 1 : (k % 2 ? 4 : 2)) * m.force_unchecked(t);
  }
  simpson *= (b - a) / (3 * N);
  EXPECT_NEAR(c.energy_density(b), simpson, 1e-12);
}

TEST(ElasticModel, DesignedForcesHoldAtTheDesignedGeometry) {
  const Design d = prism_design(4, "elastic-cord-1mm", 2.0);
  const ElasticModel model = make_elastic_model(d);
  const ElasticEnergy energy(model);
  const Eigen::VectorXd f = energy.element_forces(model.reference);
  for (int e = 0; e < f.size(); ++e) EXPECT_NEAR(f[e], d.solution.forces[e], 1e-9 * std::abs(d.solution.forces[e])) << e;
  // Strut strain under the largest strut force is the documented 1e-6.
  double strain = 0.0;
  for (int e = 0; e < f.size(); ++e)
    if (model.curve_of[e] < 0) {
      const double l = (model.reference.col(model.structure.elements[e].b) - model.reference.col(model.structure.elements[e].a)).norm();
      strain = std::max(strain, std::abs(l / model.rest_lengths[e] - 1.0));
    }
  EXPECT_NEAR(strain, 1e-6, 1e-12);
  // No gravity: a self-stressed equilibrium, zero gradient.
  Eigen::VectorXd g;
  energy.energy_gradient(model.reference, g);
  EXPECT_LT(g.cwiseAbs().maxCoeff(), 1e-9 * model.force_scale);
}

struct Perturbed {
  ElasticModel model;
  Eigen::Matrix3Xd x;
  std::vector<DragSpring> drags;
};

Perturbed perturbed_prism() {
  Design d = prism_design(3, "elastic-cord-2mm", 3.0, /*fix_bottom=*/true);
  d.structure.gravity = Eigen::Vector3d(0.3, -1.0, -9.81);
  Perturbed p{make_elastic_model(d), d.structure.positions, {}};
  // One cable made slack: its rest length longer than it is.
  p.model.rest_lengths[3] *= 1.5;  // a vertical cable
  scenes::NodeNoise noise;  // up to 4 mm per coordinate on the free nodes
  noise.fraction = 0.004;
  noise.length = scenes::LengthMeasure::OneMetre;
  noise.shape = scenes::NoiseShape::Cube;
  Structure moved = p.model.structure;
  moved.positions = p.x;
  p.x = scenes::with_node_noise(std::move(moved), noise, 7).positions;
  p.drags.push_back({4, Eigen::Vector3d(0.05, 0.02, 0.3), 25.0});
  return p;
}

TEST(ElasticEnergy, GradientMatchesFiniteDifferences) {
  const Perturbed p = perturbed_prism();
  const ElasticEnergy energy(p.model);
  Eigen::VectorXd g;
  const double e0 = energy.energy_gradient(p.x, g, p.drags);
  EXPECT_NEAR(e0, energy.energy(p.x, p.drags), 1e-14 * std::abs(e0));
  const FreeNodeMap& map = energy.free_map();
  const double h = 1e-7;
  for (int i : map.free_nodes())
    for (int a = 0; a < 3; ++a) {
      Eigen::Matrix3Xd xp = p.x, xm = p.x;
      xp(a, i) += h;
      xm(a, i) -= h;
      const double fd = (energy.energy(xp, p.drags) - energy.energy(xm, p.drags)) / (2 * h);
      // The stiff struts make E large: allow the round-off of the difference quotient.
      EXPECT_NEAR(fd, g[3 * map.slot(i) + a], 1e-6 * (1.0 + std::abs(fd))) << i << "," << a;
    }
}

TEST(ElasticEnergy, ExactHessianMatchesFiniteDifferencesAndDefiniteIsPositive) {
  const Perturbed p = perturbed_prism();
  const ElasticEnergy energy(p.model);
  Eigen::SparseMatrix<double> H = energy.pattern(), Hd = energy.pattern();
  energy.hessian(p.x, HessianMode::Exact, H, p.drags);
  energy.hessian(p.x, HessianMode::Definite, Hd, p.drags);
  const Eigen::MatrixXd dense = Eigen::MatrixXd(H);
  EXPECT_LT((dense - dense.transpose()).cwiseAbs().maxCoeff(), 1e-9 * dense.cwiseAbs().maxCoeff());
  const FreeNodeMap& map = energy.free_map();
  const int dofs = energy.num_dofs();
  Eigen::MatrixXd fd(dofs, dofs);
  const double h = 1e-8;
  for (int i : map.free_nodes())
    for (int a = 0; a < 3; ++a) {
      Eigen::Matrix3Xd xp = p.x, xm = p.x;
      xp(a, i) += h;
      xm(a, i) -= h;
      Eigen::VectorXd gp, gm;
      energy.energy_gradient(xp, gp, p.drags);
      energy.energy_gradient(xm, gm, p.drags);
      fd.col(3 * map.slot(i) + a) = (gp - gm) / (2 * h);
    }
  const double scale = dense.cwiseAbs().maxCoeff();
  EXPECT_LT((fd - dense).cwiseAbs().maxCoeff(), 1e-6 * scale);
  // Away from the strut axial terms, the cable and geometric entries too.
  const Eigen::MatrixXd dense_definite(Hd);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> exact(dense), definite(dense_definite);
  EXPECT_LT(exact.eigenvalues()[0], definite.eigenvalues()[0]);  // the dropped strut terms were negative
  EXPECT_GT(definite.eigenvalues()[0], -1e-12 * scale);
  // Definite = exact minus the compressed elements' geometric terms: check it on one strut.
  const Eigen::VectorXd sigma = energy.element_forces(p.x);
  EXPECT_LT(sigma.minCoeff(), 0.0);  // some element compressed: the dropped term existed
  EXPECT_EQ(sigma[3], 0.0);  // the slack cable
}

TEST(ElasticEnergy, HessianPatternIsBuiltOnceAndCoversEveryElement) {
  const Perturbed p = perturbed_prism();
  const ElasticEnergy energy(p.model);
  // 3 free nodes, all joined to each other by the top ring: a full 9 x 9.
  EXPECT_EQ(energy.pattern().nonZeros(), 81);
  for (int k = 0; k < energy.num_dofs(); ++k) {
    const int s = energy.diagonal_slot(k);
    EXPECT_EQ(energy.pattern().innerIndexPtr()[s], k);
  }
}

TEST(ElasticModel, LinearModelReproducesTheGivenForces) {
  PrismParameters pp;
  pp.n = 5;
  const Structure s = make_regular_prism(pp);
  Eigen::VectorXd sigma(s.num_elements());
  for (int e = 0; e < s.num_elements(); ++e) {
    const double l = (s.positions.col(s.elements[e].b) - s.positions.col(s.elements[e].a)).norm();
    sigma[e] = (e < 5 ? -1.0 : e < 10 ? 1.0 : 1.0 / (2 * std::sin(M_PI / 5))) * l;
  }
  const ElasticModel model = make_linear_elastic_model(s, s.positions, sigma, 0.2);
  const ElasticEnergy energy(model);
  const Eigen::VectorXd f = energy.element_forces(s.positions);
  for (int e = 0; e < f.size(); ++e) EXPECT_NEAR(f[e], sigma[e], 1e-9 * std::abs(sigma[e]));
}

}  // namespace
}  // namespace tensegrity
