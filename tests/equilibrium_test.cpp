// Equilibrium: A(x), f = A sigma + f_g, df/dq and the Hessian of lambda^T f,
// checked against the plain formula of docs/FORMATS.md, closed-form prism forces and
// central finite differences on several scenes. One file past 500 lines:
// every derivative's gradient check shares the scene list and the
// finite-difference helpers.
#include "formulations/equilibrium.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "model/reference_scenes.hpp"
#include "scenes/perturb.hpp"

namespace tensegrity {
namespace {

struct Scene {
  std::string label;
  Structure structure;
};

// Gives every node a small own mass so gravity loads differ from node to node.
void add_node_masses(Structure& s, std::mt19937& rng) {
  std::uniform_real_distribution<double> mass(0.01, 0.05);
  for (int i = 0; i < s.num_nodes(); ++i) s.node_mass[i] = mass(rng);
}

// Gaussian noise of standard deviation `amplitude` (m) on every free node.
void perturb_free_nodes(Structure& s, double amplitude, std::mt19937& rng) {
  scenes::NodeNoise noise;
  noise.fraction = amplitude;
  noise.length = scenes::LengthMeasure::OneMetre;
  noise.shape = scenes::NoiseShape::Gaussian;
  scenes::add_node_noise(s, noise, rng);
}

std::vector<Scene> derivative_scenes() {
  std::mt19937 rng(20240611);
  std::vector<Scene> scenes;
  for (int n : {3, 5, 8}) {
    for (int variant = 0; variant < 3; ++variant) {
      PrismParameters p;
      p.n = n;
      p.radius = 0.7;
      p.height = 1.3;
      p.twist_offset = 0.3;  // off equilibrium
      p.gravity = variant > 0;
      p.fix_bottom = variant == 2;
      p.strut_mass = variant > 0 ? 0.1 : 0.0;
      p.cable_mass = variant > 0 ? 0.02 : 0.0;
      Structure s = make_regular_prism(p);
      if (variant > 0) add_node_masses(s, rng);
      const char* names[3] = {"no gravity", "gravity, free", "gravity, fixed bottom"};
      scenes.push_back({"prism-" + std::to_string(n) + " twisted, " + names[variant], s});
      Structure perturbed = s;
      perturb_free_nodes(perturbed, 0.08, rng);
      scenes.push_back({"prism-" + std::to_string(n) + " perturbed, " + names[variant], perturbed});
    }
  }
  for (int variant = 0; variant < 3; ++variant) {
    OctahedronParameters p;
    p.half_length = 0.5;
    p.gravity = variant > 0;
    p.fix_bottom = variant == 2;
    p.strut_mass = variant > 0 ? 0.05 : 0.0;
    p.cable_mass = variant > 0 ? 0.01 : 0.0;
    Structure s = make_expandable_octahedron(p);
    scenes.push_back({"octahedron " + std::to_string(variant), s});
    Structure perturbed = s;
    perturb_free_nodes(perturbed, 0.04, rng);
    scenes.push_back({"octahedron perturbed " + std::to_string(variant), perturbed});
  }
  return scenes;
}

Eigen::VectorXd random_vector(int size, double scale, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-scale, scale);
  Eigen::VectorXd v(size);
  for (int i = 0; i < size; ++i) v[i] = u(rng);
  return v;
}

// The formula of docs/FORMATS.md (Solution file), written independently of Equilibrium: at every free
// node i, sum over touching elements of sigma_e (x_j - x_i)/|x_j - x_i| + m_i g.
Eigen::VectorXd documented_net_forces(const Structure& s, const Eigen::Matrix3Xd& x,
                                    const Eigen::VectorXd& sigma) {
  Eigen::Matrix3Xd net = Eigen::Matrix3Xd::Zero(3, s.num_nodes());
  const Eigen::VectorXd mass = s.lumped_mass();
  for (int i = 0; i < s.num_nodes(); ++i) net.col(i) = mass[i] * s.gravity;
  for (int e = 0; e < s.num_elements(); ++e) {
    const int a = s.elements[e].a, b = s.elements[e].b;
    const Eigen::Vector3d d = x.col(b) - x.col(a);
    net.col(a) += sigma[e] * d / d.norm();
    net.col(b) -= sigma[e] * d / d.norm();
  }
  std::vector<double> stacked;
  for (int i = 0; i < s.num_nodes(); ++i)
    if (!s.fixed[i])
      for (int k = 0; k < 3; ++k) stacked.push_back(net(k, i));
  return Eigen::Map<Eigen::VectorXd>(stacked.data(), static_cast<Eigen::Index>(stacked.size()));
}

double relative_error(const Eigen::MatrixXd& analytic, const Eigen::MatrixXd& reference) {
  const double scale = std::max(analytic.cwiseAbs().maxCoeff(), reference.cwiseAbs().maxCoeff());
  return scale > 0.0 ? (analytic - reference).cwiseAbs().maxCoeff() / scale : 0.0;
}

// The symmetric Hessian of lambda^T f with respect to z = (q, sigma), from the
// lower-triangle triplets (also checks that only the lower triangle is given).
Eigen::MatrixXd dense_hessian(const Equilibrium& eq, const Eigen::VectorXd& sigma,
                              const Eigen::VectorXd& lambda) {
  std::vector<int> rows, cols;
  eq.hessian_structure(rows, cols);
  std::vector<double> values(eq.hessian_nonzeros());
  eq.hessian_values(sigma, lambda, values.data());
  const int nz = eq.num_equations() + eq.num_elements();
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(nz, nz);
  for (std::size_t k = 0; k < rows.size(); ++k) {
    EXPECT_GE(rows[k], cols[k]) << "entry " << k << " is above the diagonal";
    EXPECT_LT(rows[k], nz);
    EXPECT_GE(cols[k], 0);
    H(rows[k], cols[k]) += values[k];
    if (rows[k] != cols[k]) H(cols[k], rows[k]) += values[k];
  }
  return H;
}

struct WorstErrors {
  double residual = 0.0, a_columns = 0.0, jacobian = 0.0, hessian_qq = 0.0, hessian_qsigma = 0.0;
};

TEST(EquilibriumDerivatives, FiniteDifferencesOnSeveralScenes) {
  std::mt19937 rng(7);
  WorstErrors worst;
  const std::vector<Scene> scenes = derivative_scenes();
  ASSERT_GE(scenes.size(), 20u);
  for (const Scene& scene : scenes) {
    SCOPED_TRACE(scene.label);
    const Structure& s = scene.structure;
    Equilibrium eq(s);
    const int nq = eq.num_equations();
    const int m = eq.num_elements();
    const double h = 1e-6 * s.mean_element_length();
    const Eigen::VectorXd sigma = random_vector(m, 2.0, rng);
    const Eigen::VectorXd lambda = random_vector(nq, 1.0, rng);
    const Eigen::VectorXd q0 = eq.free_nodes().gather(s.positions);

    // f against the formula of docs/FORMATS.md, and A sigma + f_g against f.
    const Eigen::VectorXd f = eq.residual(sigma);
    const Eigen::VectorXd reference = documented_net_forces(s, s.positions, sigma);
    worst.residual = std::max(worst.residual, relative_error(f, reference));
    const Eigen::VectorXd a_sigma = eq.A() * sigma + eq.gravity_load();
    worst.residual = std::max(worst.residual, relative_error(a_sigma, reference));

    // A = df/dsigma.
    Eigen::MatrixXd fd_a(nq, m);
    for (int e = 0; e < m; ++e) {
      Eigen::VectorXd plus = sigma, minus = sigma;
      plus[e] += 1e-3;
      minus[e] -= 1e-3;
      fd_a.col(e) = (eq.residual(plus) - eq.residual(minus)) / 2e-3;
    }
    worst.a_columns = std::max(worst.a_columns, relative_error(Eigen::MatrixXd(eq.A()), fd_a));

    // J = df/dq, and the Hessian blocks from differences of the analytic
    // gradients J^T lambda (q-q) and A^T lambda (sigma-q).
    eq.set_free_coordinates(q0);
    const Eigen::MatrixXd J = Eigen::MatrixXd(eq.jacobian_positions(sigma));
    const Eigen::MatrixXd H = dense_hessian(eq, sigma, lambda);
    Eigen::MatrixXd fd_j(nq, nq), fd_hqq(nq, nq), fd_hsq(m, nq);
    for (int k = 0; k < nq; ++k) {
      Eigen::VectorXd q = q0;
      q[k] += h;
      eq.set_free_coordinates(q);
      const Eigen::VectorXd f_plus = eq.residual(sigma);
      const Eigen::VectorXd gq_plus = eq.jacobian_positions(sigma).transpose() * lambda;
      const Eigen::VectorXd gs_plus = eq.A().transpose() * lambda;
      q[k] = q0[k] - h;
      eq.set_free_coordinates(q);
      const Eigen::VectorXd f_minus = eq.residual(sigma);
      const Eigen::VectorXd gq_minus = eq.jacobian_positions(sigma).transpose() * lambda;
      const Eigen::VectorXd gs_minus = eq.A().transpose() * lambda;
      fd_j.col(k) = (f_plus - f_minus) / (2 * h);
      fd_hqq.col(k) = (gq_plus - gq_minus) / (2 * h);
      fd_hsq.col(k) = (gs_plus - gs_minus) / (2 * h);
    }
    eq.set_free_coordinates(q0);
    worst.jacobian = std::max(worst.jacobian, relative_error(J, fd_j));
    EXPECT_LT(relative_error(J, J.transpose()), 1e-14) << "df/dq must be symmetric";
    worst.hessian_qq = std::max(worst.hessian_qq, relative_error(H.topLeftCorner(nq, nq), fd_hqq));
    worst.hessian_qsigma =
        std::max(worst.hessian_qsigma, relative_error(H.bottomLeftCorner(m, nq), fd_hsq));
    EXPECT_EQ(H.bottomRightCorner(m, m).cwiseAbs().maxCoeff(), 0.0) << "f is linear in sigma";

    // The sigma-q block also equals d(J^T lambda)/dsigma (J is linear in sigma).
    Eigen::MatrixXd fd_hqs(nq, m);
    for (int e = 0; e < m; ++e) {
      Eigen::VectorXd plus = sigma, minus = sigma;
      plus[e] += 1e-3;
      minus[e] -= 1e-3;
      const Eigen::VectorXd g_plus = eq.jacobian_positions(plus).transpose() * lambda;
      const Eigen::VectorXd g_minus = eq.jacobian_positions(minus).transpose() * lambda;
      fd_hqs.col(e) = (g_plus - g_minus) / 2e-3;
    }
    worst.hessian_qsigma =
        std::max(worst.hessian_qsigma, relative_error(H.topRightCorner(nq, m), fd_hqs));
  }
  std::printf("[ worst relative error over %zu scenes ] f vs documented formula %.2e, A vs FD %.2e, "
              "df/dq vs FD %.2e, Hessian q-q vs FD %.2e, Hessian q-sigma vs FD %.2e\n",
              scenes.size(), worst.residual, worst.a_columns, worst.jacobian, worst.hessian_qq,
              worst.hessian_qsigma);
  EXPECT_LT(worst.residual, 1e-13);
  EXPECT_LT(worst.a_columns, 1e-9);
  EXPECT_LT(worst.jacobian, 1e-6);
  EXPECT_LT(worst.hessian_qq, 1e-6);
  EXPECT_LT(worst.hessian_qsigma, 1e-6);
}

// Second differences of the scalar lambda^T f itself, independent of J.
// The matrix-free product J v (Algorithm 1's gradient steps use it instead of
// the assembled J) against the assembled J, both ways (J is symmetric), and
// against a central difference of f along v.
TEST(EquilibriumDerivatives, JacobianProductMatchesAssembledJacobianAndDifferences) {
  std::mt19937 rng(11);
  double worst_assembled = 0.0, worst_transpose = 0.0, worst_difference = 0.0;
  for (const Scene& scene : derivative_scenes()) {
    SCOPED_TRACE(scene.label);
    Equilibrium eq(scene.structure);
    const int nq = eq.num_equations();
    const Eigen::VectorXd sigma = random_vector(eq.num_elements(), 2.0, rng);
    const Eigen::VectorXd v = random_vector(nq, 1.0, rng);
    Eigen::VectorXd product(3);  // wrong size on purpose: the product resizes it
    eq.jacobian_positions_product(sigma, v, product);
    ASSERT_EQ(product.size(), nq);
    const Eigen::SparseMatrix<double>& J = eq.jacobian_positions(sigma);
    const Eigen::VectorXd assembled = J * v;
    const Eigen::VectorXd transposed = J.transpose() * v;
    worst_assembled = std::max(worst_assembled, relative_error(product, assembled));
    worst_transpose = std::max(worst_transpose, relative_error(product, transposed));
    const double h = 1e-6 * scene.structure.mean_element_length();
    const Eigen::VectorXd q0 = eq.free_nodes().gather(scene.structure.positions);
    eq.set_free_coordinates(q0 + h * v);
    const Eigen::VectorXd f_plus = eq.residual(sigma);
    eq.set_free_coordinates(q0 - h * v);
    const Eigen::VectorXd f_minus = eq.residual(sigma);
    eq.set_free_coordinates(q0);
    worst_difference = std::max(worst_difference, relative_error(product, (f_plus - f_minus) / (2.0 * h)));
  }
  std::printf("J v: worst relative error against J v %.2e, J^T v %.2e, differences %.2e\n", worst_assembled,
              worst_transpose, worst_difference);
  EXPECT_LE(worst_assembled, 1e-13);
  EXPECT_LE(worst_transpose, 1e-13);
  EXPECT_LE(worst_difference, 1e-7);
}

Structure regular_prism_3() {
  PrismParameters p;
  p.n = 3;
  return make_regular_prism(p);
}

// The equilibrium of `s` (a regular 3-prism) with its vertical cable 0-3
// collapsed to zero length.
Equilibrium collapsed(const Structure& s) {
  Equilibrium eq(s);
  Eigen::Matrix3Xd x = s.positions;
  x.col(3) = x.col(0);
  eq.set_positions(x);
  return eq;
}

// A collapsed element contributes nothing to J v, as it contributes nothing to J.
TEST(EquilibriumValues, JacobianProductSkipsZeroLengthElements) {
  const Structure s = regular_prism_3();
  Equilibrium eq = collapsed(s);
  ASSERT_TRUE(eq.degenerate());
  const Eigen::VectorXd sigma = Eigen::VectorXd::LinSpaced(s.num_elements(), -1.0, 2.0);
  const Eigen::VectorXd v = Eigen::VectorXd::LinSpaced(eq.num_equations(), 0.5, -0.7);
  Eigen::VectorXd product;
  eq.jacobian_positions_product(sigma, v, product);
  ASSERT_TRUE(product.allFinite());
  const Eigen::VectorXd assembled = eq.jacobian_positions(sigma) * v;
  EXPECT_LE((product - assembled).cwiseAbs().maxCoeff(), 1e-13 * assembled.cwiseAbs().maxCoeff());
}

TEST(EquilibriumDerivatives, HessianAgainstSecondDifferencesOfTheLagrangian) {
  std::mt19937 rng(11);
  PrismParameters p;
  p.n = 5;
  p.twist_offset = -0.2;
  p.gravity = true;
  p.fix_bottom = true;
  p.strut_mass = 0.1;
  Structure s = make_regular_prism(p);
  perturb_free_nodes(s, 0.05, rng);
  Equilibrium eq(s);
  const int nq = eq.num_equations(), m = eq.num_elements();
  const Eigen::VectorXd sigma = random_vector(m, 2.0, rng);
  const Eigen::VectorXd lambda = random_vector(nq, 1.0, rng);
  const Eigen::VectorXd z0 = (Eigen::VectorXd(nq + m) << eq.free_nodes().gather(s.positions), sigma).finished();
  auto lagrangian = [&](const Eigen::VectorXd& z) {
    eq.set_free_coordinates(z.head(nq));
    return lambda.dot(eq.residual(z.tail(m)));
  };
  const Eigen::MatrixXd H = [&] {
    eq.set_free_coordinates(z0.head(nq));
    return dense_hessian(eq, sigma, lambda);
  }();
  const double h = 1e-4;
  Eigen::MatrixXd fd(nq + m, nq + m);
  for (int i = 0; i < nq + m; ++i)
    for (int j = 0; j <= i; ++j) {
      auto at = [&](double di, double dj) {
        Eigen::VectorXd z = z0;
        z[i] += di;
        z[j] += dj;
        return lagrangian(z);
      };
      fd(i, j) = fd(j, i) = (at(h, h) - at(h, -h) - at(-h, h) + at(-h, -h)) / (4 * h * h);
    }
  const double error = relative_error(H, fd);
  std::printf("[ Hessian of lambda^T f vs second differences ] worst relative error %.2e\n", error);
  EXPECT_LT(error, 1e-6);
}

TEST(EquilibriumStructure, ShapeAndSparsityOfA) {
  PrismParameters p;
  p.n = 6;
  p.fix_bottom = true;
  Structure s = make_regular_prism(p);
  // One extra element between two fixed nodes: an empty column.
  s.add_element(0, 3, ElementKind::Cable);
  Equilibrium eq(s);
  ASSERT_EQ(eq.free_nodes().num_free(), 6);
  EXPECT_EQ(eq.num_equations(), 18);
  EXPECT_EQ(eq.A().rows(), 18);
  EXPECT_EQ(eq.A().cols(), s.num_elements());
  for (int e = 0; e < s.num_elements(); ++e) {
    const int free_ends = (s.fixed[s.elements[e].a] ? 0 : 1) + (s.fixed[s.elements[e].b] ? 0 : 1);
    const int nonzeros = eq.A().outerIndexPtr()[e + 1] - eq.A().outerIndexPtr()[e];
    EXPECT_LE(nonzeros, 6);
    EXPECT_EQ(nonzeros, 3 * free_ends) << "element " << e;
  }
  // Each column holds u and -u: its entries sum to zero when both ends are free.
  const Eigen::MatrixXd A = eq.A();
  for (int e = 2 * p.n; e < 3 * p.n; ++e) EXPECT_EQ(A.col(e).norm(), 0.0);  // bottom ring: both fixed
  for (int e = 3 * p.n; e < 4 * p.n; ++e) EXPECT_NEAR(A.col(e).sum(), 0.0, 1e-15);
}

TEST(EquilibriumStructure, FixedNodesCarryNoRows) {
  PrismParameters p;
  p.n = 4;
  p.gravity = true;
  p.fix_bottom = true;
  p.strut_mass = 0.2;
  Structure s = make_regular_prism(p);
  Equilibrium eq(s);
  const FreeNodeMap& map = eq.free_nodes();
  EXPECT_EQ(map.num_free(), 4);
  for (int k = 0; k < 4; ++k) EXPECT_EQ(map.slot(k), -1);
  for (int k = 0; k < 4; ++k) EXPECT_EQ(map.slot(4 + k), k);
  EXPECT_EQ(eq.num_equations(), 12);
  EXPECT_EQ(eq.jacobian_positions(Eigen::VectorXd::Ones(s.num_elements())).rows(), 12);
  // Moving a fixed node changes the free nodes' residual but adds no row.
  const Eigen::VectorXd sigma = Eigen::VectorXd::LinSpaced(s.num_elements(), -1.0, 2.0);
  Eigen::Matrix3Xd x = s.positions;
  x(0, 0) += 0.1;
  eq.set_positions(x);
  const Eigen::VectorXd f = eq.residual(sigma);
  ASSERT_EQ(f.size(), 12);
  EXPECT_LT((f - documented_net_forces(s, x, sigma)).cwiseAbs().maxCoeff(), 1e-14);
  // Top node k: own mass 0 plus half a strut (0.1 kg); loads on fixed nodes are absent.
  for (int k = 0; k < 4; ++k) EXPECT_DOUBLE_EQ(eq.gravity_load()[3 * k + 2], -9.81 * 0.1);
}

TEST(EquilibriumStructure, GravityOnlyWhenItLoadsAFreeNode) {
  PrismParameters p;
  p.n = 3;
  p.gravity = true;  // but no mass anywhere
  Structure s = make_regular_prism(p);
  Equilibrium massless(s);
  EXPECT_FALSE(massless.has_gravity());
  EXPECT_EQ(massless.gravity_load().cwiseAbs().maxCoeff(), 0.0);

  p.cable_mass = 0.02;
  p.strut_mass = 0.1;
  Structure heavy = make_regular_prism(p);
  heavy.node_mass[0] = 0.3;
  Equilibrium eq(heavy);
  EXPECT_TRUE(eq.has_gravity());
  // Node 0: own 0.3, half a strut, half a vertical, half of two ring cables.
  EXPECT_NEAR(eq.gravity_load()[2], -9.81 * (0.3 + 0.05 + 0.01 + 0.02), 1e-14);
  EXPECT_EQ(eq.gravity_load()[0], 0.0);
}

TEST(EquilibriumValues, AnalyticPrismIsInEquilibrium) {
  double worst = 0.0;
  for (int n = 3; n <= 12; ++n) {
    PrismParameters p;
    p.n = n;
    p.radius = 0.8;
    p.height = 1.7;
    const Structure s = make_regular_prism(p);
    Equilibrium eq(s);
    // Element order: struts, verticals, bottom ring, top ring.
    Eigen::VectorXd density(s.num_elements());
    density.segment(0, n).setConstant(-1.0);
    density.segment(n, n).setConstant(1.0);
    density.segment(2 * n, 2 * n).setConstant(1.0 / (2.0 * std::sin(M_PI / n)));
    const Eigen::VectorXd sigma = density.cwiseProduct(eq.lengths());
    const double residual = eq.residual(sigma).cwiseAbs().maxCoeff();
    worst = std::max(worst, residual / sigma.cwiseAbs().maxCoeff());
    EXPECT_LT(residual, 1e-13) << "n = " << n;

    PrismParameters twisted = p;
    twisted.twist_offset = 5.0 * M_PI / 180.0;
    Equilibrium off(make_regular_prism(twisted));
    const Eigen::VectorXd sigma_off = density.cwiseProduct(off.lengths());
    EXPECT_GT(off.residual(sigma_off).cwiseAbs().maxCoeff(), 1e-3) << "n = " << n;
  }
  std::printf("[ closed-form prism forces, n = 3..12 ] worst residual / max |sigma| = %.2e\n", worst);
}

// The expandable octahedron under gravity on its fixed bottom nodes.
Structure loaded_octahedron() {
  OctahedronParameters p;
  p.gravity = true;
  p.fix_bottom = true;
  p.strut_mass = 0.05;
  return make_expandable_octahedron(p);
}

TEST(EquilibriumValues, RefreshOnlyRewritesValues) {
  std::mt19937 rng(3);
  Structure s = loaded_octahedron();
  Equilibrium eq(s);
  const Eigen::VectorXd sigma = random_vector(s.num_elements(), 1.0, rng);
  const Eigen::VectorXd lambda = random_vector(eq.num_equations(), 1.0, rng);
  Structure moved = s;
  perturb_free_nodes(moved, 0.05, rng);

  auto snapshot = [&](const Eigen::Matrix3Xd& x) {
    eq.set_positions(x);
    std::vector<double> values(eq.A().valuePtr(), eq.A().valuePtr() + eq.A().nonZeros());
    const Eigen::SparseMatrix<double>& J = eq.jacobian_positions(sigma);
    values.insert(values.end(), J.valuePtr(), J.valuePtr() + J.nonZeros());
    std::vector<double> h(eq.hessian_nonzeros());
    eq.hessian_values(sigma, lambda, h.data());
    values.insert(values.end(), h.begin(), h.end());
    const Eigen::VectorXd f = eq.residual(sigma);
    values.insert(values.end(), f.data(), f.data() + f.size());
    return values;
  };
  const double* a_values = eq.A().valuePtr();
  const double* j_values = eq.jacobian_positions(sigma).valuePtr();
  const int a_nonzeros = static_cast<int>(eq.A().nonZeros());
  std::vector<int> rows0, cols0;
  eq.hessian_structure(rows0, cols0);

  const std::vector<double> first = snapshot(s.positions);
  const std::vector<double> again = snapshot(s.positions);
  const std::vector<double> elsewhere = snapshot(moved.positions);
  const std::vector<double> back = snapshot(s.positions);
  EXPECT_EQ(first, again);
  EXPECT_EQ(first, back);
  EXPECT_NE(first, elsewhere);
  // Same storage and patterns throughout.
  EXPECT_EQ(eq.A().valuePtr(), a_values);
  EXPECT_EQ(eq.jacobian_positions(sigma).valuePtr(), j_values);
  EXPECT_EQ(eq.A().nonZeros(), a_nonzeros);
  std::vector<int> rows1, cols1;
  eq.hessian_structure(rows1, cols1);
  EXPECT_EQ(rows0, rows1);
  EXPECT_EQ(cols0, cols1);
}

// Algorithm 1's line search moves with set_free_coordinates_and_residual: f
// must be the residual an element-by-element scatter gives (to the bit: the
// per-node sums add in element order), and A's values, written only when A()
// is next read, those of set_free_coordinates at the same point.
TEST(EquilibriumValues, FusedMoveAndResidualMatchesTheSeparateCalls) {
  std::mt19937 rng(11);
  const Structure s = loaded_octahedron();
  Equilibrium fused(s), separate(s);
  const Eigen::VectorXd sigma = random_vector(s.num_elements(), 1.0, rng);
  Structure moved = s;
  perturb_free_nodes(moved, 0.05, rng);
  Eigen::VectorXd q(fused.num_equations());
  for (int k = 0; k < fused.free_nodes().num_free(); ++k)
    q.segment<3>(3 * k) = moved.positions.col(fused.free_nodes().free_nodes()[k]);

  const std::vector<double> a_before(fused.A().valuePtr(), fused.A().valuePtr() + fused.A().nonZeros());
  Eigen::VectorXd f;
  fused.set_free_coordinates_and_residual(q, sigma, f);
  separate.set_free_coordinates(q);

  // The scatter, written out: +sigma u at end a, -sigma u at end b, over f_g.
  Eigen::VectorXd scattered = separate.gravity_load();
  for (int e = 0; e < s.num_elements(); ++e) {
    const Eigen::Vector3d force = sigma[e] * separate.directions().col(e);
    const int sa = separate.free_nodes().slot(s.elements[e].a), sb = separate.free_nodes().slot(s.elements[e].b);
    if (sa >= 0) scattered.segment<3>(3 * sa) += force;
    if (sb >= 0) scattered.segment<3>(3 * sb) -= force;
  }
  ASSERT_EQ(f.size(), scattered.size());
  for (int i = 0; i < f.size(); ++i) EXPECT_EQ(f[i], scattered[i]) << i;
  EXPECT_EQ(separate.residual(sigma), f);
  EXPECT_GT((f - fused.gravity_load()).norm(), 1e-3);  // the moved geometry does load the nodes
  EXPECT_EQ(fused.lengths(), separate.lengths());
  EXPECT_EQ(fused.directions(), separate.directions());

  const std::vector<double> a_fused(fused.A().valuePtr(), fused.A().valuePtr() + fused.A().nonZeros());
  const std::vector<double> a_separate(separate.A().valuePtr(), separate.A().valuePtr() + separate.A().nonZeros());
  EXPECT_EQ(a_fused, a_separate);
  EXPECT_NE(a_fused, a_before);
  Eigen::VectorXd q_before = q;
  for (int k = 0; k < fused.free_nodes().num_free(); ++k)
    q_before.segment<3>(3 * k) = s.positions.col(fused.free_nodes().free_nodes()[k]);
  fused.set_free_coordinates_and_residual(q_before, sigma, f);
  const std::vector<double> a_back(fused.A().valuePtr(), fused.A().valuePtr() + fused.A().nonZeros());
  EXPECT_EQ(a_back, a_before);
}

TEST(EquilibriumStructure, HessianLayout) {
  PrismParameters p;
  p.n = 4;
  p.fix_bottom = true;
  const Structure s = make_regular_prism(p);
  Equilibrium eq(s);
  std::vector<int> rows, cols;
  eq.hessian_structure(rows, cols);
  ASSERT_EQ(static_cast<int>(rows.size()), eq.hessian_nonzeros());
  const int nq = eq.num_equations();
  for (int k = 0; k < nq; ++k) {
    const int idx = eq.hessian_diagonal_index(k);
    EXPECT_EQ(rows[idx], k);
    EXPECT_EQ(cols[idx], k);
  }
  // 4 free nodes: 4 diagonal blocks (6 each), 4 top-ring pairs (9 each); sigma
  // rows: struts and verticals have one free end (3), top ring two (6), bottom ring none.
  EXPECT_EQ(eq.hessian_nonzeros(), 4 * 6 + 4 * 9 + 8 * 3 + 4 * 6);
  // No duplicate (row, col) pairs.
  std::vector<std::pair<int, int>> pairs;
  for (std::size_t k = 0; k < rows.size(); ++k) pairs.emplace_back(rows[k], cols[k]);
  std::sort(pairs.begin(), pairs.end());
  EXPECT_EQ(std::adjacent_find(pairs.begin(), pairs.end()), pairs.end());
}

TEST(EquilibriumValues, ZeroLengthElementGivesNoNaN) {
  const Structure s = regular_prism_3();
  Equilibrium eq = collapsed(s);
  EXPECT_TRUE(eq.degenerate());
  const Eigen::VectorXd sigma = Eigen::VectorXd::Ones(s.num_elements());
  EXPECT_TRUE(eq.residual(sigma).allFinite());
  EXPECT_TRUE(Eigen::MatrixXd(eq.jacobian_positions(sigma)).allFinite());
  std::vector<double> h(eq.hessian_nonzeros());
  eq.hessian_values(sigma, Eigen::VectorXd::Ones(eq.num_equations()), h.data());
  for (double v : h) EXPECT_TRUE(std::isfinite(v));
  eq.set_positions(s.positions);
  EXPECT_FALSE(eq.degenerate());
}

}  // namespace
}  // namespace tensegrity
