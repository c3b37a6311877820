// verify(): the formulas of docs/FORMATS.md (Solution file) on the analytic
// regular prism, whose force densities are known in closed form (struts -1,
// verticals 1, rings 1 / (2 sin(pi/n))), and on deliberately broken solutions.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "model/reference_scenes.hpp"
#include "model/verify.hpp"

namespace tensegrity {
namespace {

// Closed-form equilibrium forces (N) of the prism: force density times length.
Eigen::VectorXd prism_forces(const Structure& s, int n) {
  Eigen::VectorXd forces(s.num_elements());
  const double ring_density = 1.0 / (2.0 * std::sin(M_PI / n));
  for (int e = 0; e < s.num_elements(); ++e) {
    const double length = (s.positions.col(s.elements[e].b) - s.positions.col(s.elements[e].a)).norm();
    const int group = e / n;  // struts, verticals, bottom ring, top ring
    const double density = group == 0 ? -1.0 : group == 1 ? 1.0 : ring_density;
    forces[e] = density * length;
  }
  return forces;
}

int vertical_cable(int n, int k) { return n + k; }
int bottom_ring_cable(int n, int k) { return 2 * n + k; }

TEST(Verify, AnalyticPrismIsInEquilibrium) {
  for (int n = 3; n <= 12; ++n) {
    SCOPED_TRACE(n);
    PrismParameters p;
    p.n = n;
    p.radius = 1.3;
    p.height = 0.7;
    const Structure s = make_regular_prism(p);
    const Eigen::VectorXd forces = prism_forces(s, n);
    const Verification v = verify(s, s.positions, forces);
    EXPECT_LT(v.relative_residual, 1e-14);
    EXPECT_EQ(v.load_scale, forces.cwiseAbs().maxCoeff());
    EXPECT_EQ(v.wrong_signs, 0);
    EXPECT_EQ(v.moved_fixed_nodes, 0);
    EXPECT_EQ(v.geometry_change, 0.0);
    EXPECT_TRUE(v.all_finite);
    EXPECT_TRUE(v.equilibrium_ok);
    EXPECT_TRUE(v.ok);
    EXPECT_TRUE(v.problems.empty());
  }
}

TEST(Verify, OffTwistPrismIsNotInEquilibrium) {
  PrismParameters p;
  p.n = 5;
  p.twist_offset = 5.0 * M_PI / 180.0;
  const Structure s = make_regular_prism(p);
  const Verification v = verify(s, s.positions, prism_forces(s, 5));
  EXPECT_GT(v.relative_residual, 1e-3);
  EXPECT_FALSE(v.equilibrium_ok);
  EXPECT_FALSE(v.ok);
  EXPECT_EQ(v.wrong_signs, 0);
}

TEST(Verify, PerturbedForceGivesItsOwnResidual) {
  // Adding delta to one vertical cable unbalances its two end nodes by exactly
  // delta along the cable.
  const int n = 4;
  PrismParameters p;
  p.n = n;
  const Structure s = make_regular_prism(p);
  Eigen::VectorXd forces = prism_forces(s, n);
  const double delta = 0.0375;
  forces[vertical_cable(n, 1)] += delta;
  const Verification v = verify(s, s.positions, forces);
  EXPECT_NEAR(v.residual, delta, 1e-15);
  EXPECT_NEAR(v.relative_residual, delta / forces.cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_FALSE(v.equilibrium_ok);
  EXPECT_EQ(v.wrong_signs, 0);

  const Eigen::Matrix3Xd net = net_forces(s, s.positions, forces);
  const Eigen::Vector3d along = (s.positions.col(n + 1) - s.positions.col(1)).normalized();
  EXPECT_NEAR((net.col(1) - delta * along).norm(), 0.0, 1e-15);
  EXPECT_NEAR((net.col(n + 1) + delta * along).norm(), 0.0, 1e-15);
  EXPECT_NEAR(net.col(0).norm(), 0.0, 1e-15);
}

TEST(Verify, GravityLoadScaleIsTheLargestFreeNodeWeight) {
  const int n = 3;
  PrismParameters p;
  p.n = n;
  p.gravity = true;
  p.fix_bottom = true;
  p.strut_mass = 0.2;
  p.cable_mass = 0.05;
  Structure s = make_regular_prism(p);
  // Top node: half a strut, half a vertical, halves of two ring cables, plus
  // its own 0.3 kg on node n + 2. Bottom nodes are fixed and do not count.
  s.node_mass[n + 2] = 0.3;
  s.node_mass[0] = 5.0;
  const double top_mass = 0.5 * 0.2 + 0.5 * 0.05 * 3.0;
  EXPECT_NEAR(s.lumped_mass()[n], top_mass, 1e-15);
  const double heaviest = (top_mass + 0.3) * 9.81;

  // With the self-stress alone the weight of every top node is unbalanced.
  const Eigen::VectorXd forces = prism_forces(s, n);
  const Verification v = verify(s, s.positions, forces);
  EXPECT_NEAR(v.load_scale, heaviest, 1e-14);
  EXPECT_NEAR(v.residual, heaviest, 1e-13);
  EXPECT_NEAR(v.relative_residual, 1.0, 1e-13);
  EXPECT_FALSE(v.ok);

  // A million times the self-stress leaves the weight just as unbalanced;
  // dividing by max |sigma| would have called that a relative 1e-6.
  const Verification big = verify(s, s.positions, 1e6 * forces);
  EXPECT_NEAR(big.load_scale, heaviest, 1e-14);
  EXPECT_NEAR(big.relative_residual, 1.0, 1e-8);

  // Massless free nodes: the scale falls back to the largest force.
  for (Element& e : s.elements) e.mass = 0.0;
  s.node_mass.setZero();
  s.node_mass[0] = 5.0;  // a fixed node's weight goes to its support
  const Verification massless = verify(s, s.positions, forces);
  EXPECT_EQ(massless.load_scale, forces.cwiseAbs().maxCoeff());
  EXPECT_LT(massless.relative_residual, 1e-14);
}

TEST(Verify, WrongSignsCountedForEveryElement) {
  const int n = 3;
  PrismParameters p;
  p.n = n;
  p.fix_bottom = true;
  const Structure s = make_regular_prism(p);
  Eigen::VectorXd forces = prism_forces(s, n);
  // A bottom-ring cable joins two fixed nodes: no equilibrium is asked of it,
  // but its sign still counts.
  forces[bottom_ring_cable(n, 0)] = -1.0;
  Verification v = verify(s, s.positions, forces);
  EXPECT_EQ(v.wrong_signs, 1);
  EXPECT_TRUE(v.equilibrium_ok);
  EXPECT_FALSE(v.ok);
  ASSERT_EQ(v.problems.size(), 1u);
  EXPECT_NE(v.problems[0].find("elements[6]"), std::string::npos) << v.problems[0];

  forces = prism_forces(s, n);
  forces[0] = 0.0;                  // a strut must be < 0, not <= 0
  forces[vertical_cable(n, 2)] = 0.0;  // a cable must be > 0
  forces[2] = 1.0;
  v = verify(s, s.positions, forces);
  EXPECT_EQ(v.wrong_signs, 3);
}

TEST(Verify, FixedNodesMustBeBitIdentical) {
  const int n = 3;
  PrismParameters p;
  p.n = n;
  p.fix_bottom = true;
  const Structure s = make_regular_prism(p);
  const Eigen::VectorXd forces = prism_forces(s, n);
  Eigen::Matrix3Xd x = s.positions;
  x(0, 1) = std::nextafter(x(0, 1), 10.0);
  Verification v = verify(s, x, forces);
  EXPECT_EQ(v.moved_fixed_nodes, 1);
  EXPECT_FALSE(v.ok);
  EXPECT_LT(v.relative_residual, 1e-14);  // a fixed node's move barely changes the residual

  x = s.positions;
  ASSERT_EQ(x(1, 0), 0.0);
  x(1, 0) = -0.0;  // equal as numbers, not bit for bit
  x(2, 2) = -0.0;
  v = verify(s, x, forces);
  EXPECT_EQ(v.moved_fixed_nodes, 2);

  // Moving a free node changes the geometry by the Euclidean norm.
  x = s.positions;
  x.col(n) += Eigen::Vector3d(3e-3, -4e-3, 0.0);
  x.col(n + 1) += Eigen::Vector3d(0.0, 0.0, 12e-3);
  v = verify(s, x, forces);
  EXPECT_EQ(v.moved_fixed_nodes, 0);
  EXPECT_NEAR(v.geometry_change, 13e-3, 1e-16);  // rounding of x + dx
}

TEST(Verify, NonFiniteNumbersAreNeverOk) {
  const int n = 3;
  PrismParameters p;
  p.n = n;
  const Structure s = make_regular_prism(p);
  const double nan = std::numeric_limits<double>::quiet_NaN();

  Eigen::VectorXd forces = prism_forces(s, n);
  forces[4] = nan;
  Verification v = verify(s, s.positions, forces);
  EXPECT_FALSE(v.all_finite);
  EXPECT_TRUE(std::isnan(v.residual));
  EXPECT_FALSE(v.equilibrium_ok);
  EXPECT_EQ(v.wrong_signs, 1);
  EXPECT_FALSE(v.ok);

  Eigen::Matrix3Xd x = s.positions;
  x(2, n + 1) = std::numeric_limits<double>::infinity();
  v = verify(s, x, prism_forces(s, n));
  EXPECT_FALSE(v.all_finite);
  EXPECT_FALSE(v.ok);

  // A NaN on a node that is not the first one still shows in the residual.
  x = s.positions;
  x(0, 2 * n - 1) = nan;
  v = verify(s, x, prism_forces(s, n));
  EXPECT_TRUE(std::isnan(v.residual));
  EXPECT_FALSE(v.ok);
}

TEST(Verify, MismatchedSizesAndZeroForces) {
  PrismParameters p;
  const Structure s = make_regular_prism(p);
  const Verification wrong_size = verify(s, s.positions, Eigen::VectorXd::Ones(3));
  EXPECT_FALSE(wrong_size.ok);
  EXPECT_FALSE(wrong_size.problems.empty());

  // No load and no force: balanced, but every sign is wrong.
  const Verification zero = verify(s, s.positions, Eigen::VectorXd::Zero(s.num_elements()));
  EXPECT_EQ(zero.load_scale, 0.0);
  EXPECT_EQ(zero.relative_residual, 0.0);
  EXPECT_EQ(zero.wrong_signs, s.num_elements());
  EXPECT_FALSE(zero.ok);
}

TEST(Verify, FixedNodesCarryNoNetForce) {
  PrismParameters p;
  p.fix_bottom = true;
  p.gravity = true;
  p.strut_mass = 1.0;
  const Structure s = make_regular_prism(p);
  const Eigen::Matrix3Xd net = net_forces(s, s.positions, Eigen::VectorXd::Ones(s.num_elements()));
  for (int i = 0; i < 3; ++i) EXPECT_EQ(net.col(i).norm(), 0.0);
  EXPECT_GT(net.col(3).norm(), 0.0);
}

}  // namespace
}  // namespace tensegrity
