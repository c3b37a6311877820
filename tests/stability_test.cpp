// Stability: tangent stiffness eigenvalues (dense and shift-invert Lanczos),
// the stable / marginal / unstable verdicts, and prestress stability.
#include "simulation/stability.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "model/blocks.hpp"
#include "simulation_fixtures.hpp"

namespace tensegrity {
namespace {

TEST(Stability, EveryBlockIsStable) {
  const BlockLibrary library = BlockLibrary::load(std::string(TENSEGRITY_SOURCE_DIR) + "/data/blocks");
  ASSERT_GE(library.names().size(), 10u);
  for (const std::string& name : library.names()) {
    const Block& b = library.get(name, "test", name);
    const ElasticModel model = make_linear_elastic_model(b.structure, b.structure.positions, b.forces, 0.1);
    const StabilityReport r = analyze_stability(ElasticEnergy(model), b.structure.positions);
    EXPECT_TRUE(r.in_equilibrium) << name;
    EXPECT_EQ(r.rigid_modes_removed, 6) << name;
    EXPECT_EQ(r.verdict, Stability::Stable) << name << ": " << r.message;
    const PrestressReport p = prestress_stability(b.structure, b.structure.positions, b.forces);
    EXPECT_TRUE(p.prestress_stable) << name << ": " << p.message;
  }
}

TEST(Stability, PrismIsSuperStable) {
  for (int n : {3, 4, 6}) {
    PrismParameters pp;
    pp.n = n;
    const Structure s = make_regular_prism(pp);
    const Eigen::VectorXd sigma = testing::prism_forces(s, n, 1.0);
    const PrestressReport p = prestress_stability(s, s.positions, sigma);
    EXPECT_TRUE(p.omega_psd) << n;
    EXPECT_EQ(p.omega_nullity, 4) << n;
    EXPECT_EQ(p.direction_rank, 6) << n;
    EXPECT_TRUE(p.super_stable) << p.message;
    EXPECT_TRUE(p.prestress_stable) << p.message;
    EXPECT_EQ(p.flexes, 2 * n - 5) << n;  // 3(2n) - 6 - (4n - 1): the mechanisms, stiffened by the prestress
    EXPECT_GT(p.min_flex_stiffness, 0.0);
  }
}

// The 3-prism with its first vertical cable cut.
struct CutPrism {
  Structure s;
  Eigen::VectorXd forces;
};
CutPrism cut_prism() {
  PrismParameters pp;
  pp.n = 3;
  const Structure full = make_regular_prism(pp);
  const Eigen::VectorXd sigma = testing::prism_forces(full, 3, 1.0);
  CutPrism c;
  c.s = full;
  c.s.elements.clear();
  c.s.element_extra.clear();
  std::vector<double> f;
  for (int e = 0; e < full.num_elements(); ++e) {
    if (e == 3) continue;
    c.s.add_element(full.elements[e].a, full.elements[e].b, full.elements[e].kind);
    f.push_back(sigma[e]);
  }
  c.forces = Eigen::Map<Eigen::VectorXd>(f.data(), static_cast<Eigen::Index>(f.size()));
  return c;
}

TEST(Stability, PrismWithACableRemovedIsUnstable) {
  const CutPrism c = cut_prism();
  // As built and then cut: the remaining forces no longer balance.
  const ElasticModel model = make_linear_elastic_model(c.s, c.s.positions, c.forces, 0.1);
  const StabilityReport r = analyze_stability(ElasticEnergy(model), c.s.positions);
  EXPECT_FALSE(r.in_equilibrium);
  EXPECT_EQ(r.verdict, Stability::Unstable) << r.message;
  // Its only equilibrium at this shape carries no stress: the prism's mechanism
  // is then unstiffened, a zero eigenvalue.
  ElasticModel unstressed = model;
  for (int e = 0; e < c.s.num_elements(); ++e) {
    const auto& el = c.s.elements[e];
    // Struts at rest; cords a hair stretched (1e-9) so they keep their one-sided stiffness.
    const double l = (c.s.positions.col(el.b) - c.s.positions.col(el.a)).norm();
    unstressed.rest_lengths[e] = el.kind == ElementKind::Strut ? l : l / (1.0 + 1e-9);
  }
  const StabilityReport z = analyze_stability(ElasticEnergy(unstressed), c.s.positions);
  EXPECT_TRUE(z.in_equilibrium);
  EXPECT_EQ(z.verdict, Stability::Marginal) << z.message;
  EXPECT_EQ(z.zero_modes, 1);
  // No self-stress can stiffen it: not prestress stable.
  const PrestressReport p = prestress_stability(c.s, c.s.positions, Eigen::VectorXd::Zero(c.s.num_elements()));
  EXPECT_FALSE(p.prestress_stable);
  EXPECT_FALSE(p.super_stable);
  EXPECT_GE(p.flexes, 1);
}

TEST(Stability, InvertedPendulumHasTheAnalyticNegativeStiffness) {
  // A strut standing on a fixed node, 2 kg on top, 1.5 m long: K = EA/l u u^T - (m g / l)(I - u u^T).
  Structure s;
  s.add_node(Eigen::Vector3d::Zero(), true);
  s.add_node(Eigen::Vector3d(0, 0, 1.5), false, 2.0);
  s.add_element(0, 1, ElementKind::Strut);
  s.gravity = Eigen::Vector3d(0, 0, -9.81);
  const Eigen::VectorXd sigma = Eigen::VectorXd::Constant(1, -2.0 * 9.81);
  const ElasticModel model = make_linear_elastic_model(s, s.positions, sigma);
  const StabilityReport r = analyze_stability(ElasticEnergy(model), s.positions);
  EXPECT_TRUE(r.in_equilibrium) << r.relative_residual;
  EXPECT_EQ(r.verdict, Stability::Unstable);
  ASSERT_EQ(r.eigenvalues.size(), 3u);
  EXPECT_NEAR(r.eigenvalues[0], -2.0 * 9.81 / 1.5, 1e-7);
  EXPECT_NEAR(r.eigenvalues[1], -2.0 * 9.81 / 1.5, 1e-7);
  EXPECT_EQ(r.negative_modes, 2);
  // Hung below its support instead, it is stable with +m g / l.
  Structure hung = s;
  hung.positions.col(1) = Eigen::Vector3d(0, 0, -1.5);
  hung.elements[0].kind = ElementKind::Cable;
  const ElasticModel hm = make_linear_elastic_model(hung, hung.positions, -sigma, 0.1);
  const StabilityReport h = analyze_stability(ElasticEnergy(hm), hung.positions);
  EXPECT_EQ(h.verdict, Stability::Stable) << h.message;
  EXPECT_NEAR(h.eigenvalues[0], 2.0 * 9.81 / 1.5, 1e-7);
}

TEST(Stability, LanczosAgreesWithTheDenseSolver) {
  const BlockLibrary library = BlockLibrary::load(std::string(TENSEGRITY_SOURCE_DIR) + "/data/blocks");
  for (const std::string name : {"prism-12", "double-icosahedron"}) {
    const Block& b = library.get(name, "test", name);
    const ElasticModel model = make_linear_elastic_model(b.structure, b.structure.positions, b.forces, 0.1);
    const ElasticEnergy energy(model);
    StabilityOptions o;
    o.num_eigenvalues = 5;
    const StabilityReport dense = analyze_stability(energy, b.structure.positions, o);
    o.force_lanczos = true;
    const StabilityReport lanczos = analyze_stability(energy, b.structure.positions, o);
    EXPECT_EQ(dense.method, "dense");
    EXPECT_EQ(lanczos.method, "lanczos");
    ASSERT_EQ(dense.eigenvalues.size(), lanczos.eigenvalues.size());
    for (std::size_t k = 0; k < dense.eigenvalues.size(); ++k)
      EXPECT_NEAR(lanczos.eigenvalues[k], dense.eigenvalues[k], 1e-7 * dense.scale) << name << " " << k;
    EXPECT_EQ(lanczos.verdict, dense.verdict);
  }
  // And on an unstable equilibrium with a fixed node (inertia-placed shift).
  Structure s;
  s.add_node(Eigen::Vector3d::Zero(), true);
  s.add_node(Eigen::Vector3d(0, 0, 1.0), false, 1.0);
  s.add_element(0, 1, ElementKind::Strut);
  s.gravity = Eigen::Vector3d(0, 0, -9.81);
  const ElasticModel model = make_linear_elastic_model(s, s.positions, Eigen::VectorXd::Constant(1, -9.81));
  StabilityOptions o;
  o.force_lanczos = true;
  const StabilityReport r = analyze_stability(ElasticEnergy(model), s.positions, o);
  EXPECT_EQ(r.verdict, Stability::Unstable);
  EXPECT_EQ(r.negative_modes, 2);
  ASSERT_FALSE(r.eigenvalues.empty());
  EXPECT_NEAR(r.eigenvalues[0], -9.81, 1e-6);
}

TEST(Stability, DesignedPrismUnderGravityIsStable) {
  const Design d = testing::prism_design(4, "elastic-cord-1mm", 2.0);
  const ElasticModel model = make_elastic_model(d);
  const StabilityReport r = analyze_stability(ElasticEnergy(model), model.reference);
  EXPECT_EQ(r.verdict, Stability::Stable) << r.message;
  EXPECT_EQ(r.rigid_modes_removed, 6);
}

}  // namespace
}  // namespace tensegrity
