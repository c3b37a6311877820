// The stress QP (Eq. 4): analytic tensegrities, infeasible geometry, KKT
// conditions against dense algebra, warm starts, and a brute-force
// cross-check of the bound-constrained least-squares kernel. One file past
// 500 lines: the cases share the dense reference algebra and the KKT checker.
#include "kernels/stress_qp.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <cstdio>
#include <initializer_list>
#include <limits>
#include <random>
#include <algorithm>
#include <string>
#include <vector>

#include "gravity_tower_fixture.hpp"
#include "scenes/families.hpp"
#include "scenes/perturb.hpp"
#include "scenes/towers.hpp"
#include "formulations/components.hpp"
#include "formulations/equilibrium.hpp"
#include "formulations/force_scale.hpp"
#include "model/reference_scenes.hpp"
#include "model/verify.hpp"
#include "solvers/solver.hpp"
#include "solvers/standing_check.hpp"

namespace tensegrity {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Max over free nodes of the net force (independent formula of model/verify),
// divided by max |sigma|.
double relative_residual(const Structure& s, const Eigen::Matrix3Xd& x, const Eigen::VectorXd& sigma) {
  const Eigen::Matrix3Xd f = net_forces(s, x, sigma);
  double worst = 0.0;
  for (int i = 0; i < s.num_nodes(); ++i)
    if (!s.fixed[i]) worst = std::max(worst, f.col(i).norm());
  return worst / sigma.lpNorm<Eigen::Infinity>();
}

double length(const Structure& s, int e) {
  return (s.positions.col(s.elements[e].b) - s.positions.col(s.elements[e].a)).norm();
}

TEST(StressQp, RegularPrismsReachEquilibriumWithClosedFormForceDensities) {
  for (int n = 3; n <= 12; ++n) {
    SCOPED_TRACE("n = " + std::to_string(n));
    PrismParameters p;
    p.n = n;
    const Structure s = make_regular_prism(p);
    Equilibrium eq(s);
    const ForceScale scale = make_force_scale(s);
    StressQp qp(eq, scale);
    const StressQpResult r = qp.solve();
    EXPECT_TRUE(r.optimal);
    EXPECT_EQ(r.active_bounds, 0);
    EXPECT_LE(relative_residual(s, s.positions, r.sigma), 1e-12);
    EXPECT_LE(r.max_node_residual, 1e-12 * r.sigma.lpNorm<Eigen::Infinity>());

    // Force densities relative to the vertical cables' (elements n..2n-1).
    const double vertical = r.sigma[n] / length(s, n);
    const double ring = 1.0 / (2.0 * std::sin(M_PI / n));
    for (int e = 0; e < 4 * n; ++e) {
      const double expected = e < n ? -1.0 : (e < 2 * n ? 1.0 : ring);
      EXPECT_NEAR(r.sigma[e] / length(s, e) / vertical, expected, 1e-9) << "element " << e;
    }
    // Normalisation: mean cable force = F0 = 1 N.
    EXPECT_NEAR(r.sigma.tail(3 * n).mean(), 1.0, 1e-12);
    EXPECT_NEAR(r.normalisation_error, 0.0, 1e-11);
  }
}

TEST(StressQp, TwistedPrismIsNotATensegrity) {
  for (int n : {3, 4, 6, 9}) {
    SCOPED_TRACE("n = " + std::to_string(n));
    PrismParameters p;
    p.n = n;
    p.twist_offset = 5.0 * M_PI / 180.0;
    const Structure s = make_regular_prism(p);
    Equilibrium eq(s);
    StressQp qp(eq, make_force_scale(s));
    const StressQpResult r = qp.solve();
    EXPECT_TRUE(r.optimal);  // the best forces exist; they just leave a residual
    EXPECT_GE(relative_residual(s, s.positions, r.sigma), 1e-3);
    EXPECT_GE(r.max_node_residual, 1e-3 * r.sigma.lpNorm<Eigen::Infinity>());
  }
}

TEST(StressQp, ExpandableOctahedron) {
  const Structure s = make_expandable_octahedron({});
  ASSERT_EQ(s.num_elements(), 30);
  const double strut = length(s, 0);
  for (int e = 0; e < 30; ++e) {
    if (e < 6) EXPECT_NEAR(length(s, e), strut, 1e-14);
    else EXPECT_NEAR(strut / length(s, e), std::sqrt(8.0 / 3.0), 1e-12);
  }
  Equilibrium eq(s);
  StressQp qp(eq, make_force_scale(s));
  const StressQpResult r = qp.solve();
  EXPECT_TRUE(r.optimal);
  EXPECT_LE(relative_residual(s, s.positions, r.sigma), 1e-12);
  for (int e = 6; e < 30; ++e) EXPECT_NEAR(r.sigma[e], 1.0, 1e-9);  // mean cable force F0 = 1 N
  for (int e = 0; e < 6; ++e) {
    for (int k = 6; k < 30; ++k)
      EXPECT_NEAR(-r.sigma[e] / r.sigma[k], std::sqrt(6.0), 1e-9) << e << ", " << k;
  }
}

// Dense data of the problem: half objective 1/2 |A s + f|^2 + w^2/2 (c.s - t)^2
// (+ mu/2 |s|^2), as N s - b.
struct DenseProblem {
  Eigen::MatrixXd A;
  Eigen::VectorXd f, c, lower, upper;
  double t = 0.0, w2 = 1.0;
  Eigen::MatrixXd normal(double mu) const {
    Eigen::MatrixXd N = A.transpose() * A + w2 * c * c.transpose();
    N.diagonal().array() += mu;
    return N;
  }
  Eigen::VectorXd rhs() const { return -A.transpose() * f + w2 * t * c; }
  Eigen::VectorXd gradient(const Eigen::VectorXd& s, double mu) const { return normal(mu) * s - rhs(); }
};

DenseProblem dense_problem(const Equilibrium& eq, const ForceScale& scale, double w) {
  DenseProblem d;
  d.A = Eigen::MatrixXd(eq.A());
  d.f = eq.has_gravity() ? eq.gravity_load() : Eigen::VectorXd::Zero(eq.num_equations());
  d.c = scale.has_normalisation() ? scale.normalisation_row : Eigen::VectorXd::Zero(eq.num_elements());
  d.t = scale.has_normalisation() ? scale.normalisation_target : 0.0;
  d.w2 = w * w;
  d.lower = scale.lower;
  d.upper = scale.upper;
  return d;
}

// The unique minimiser of the strictly convex box QP, by enumerating which
// bound (none, lower, upper) every variable sits at (m <= ~12).
Eigen::VectorXd brute_force(const DenseProblem& p, double mu) {
  const int m = static_cast<int>(p.c.size());
  const Eigen::MatrixXd N = p.normal(mu);
  const Eigen::VectorXd b = p.rhs();
  const double scale = std::max(1.0, b.lpNorm<Eigen::Infinity>());
  std::vector<int> state(m, 0);  // 0 free, 1 lower, 2 upper
  Eigen::VectorXd best;
  int found = 0;
  while (true) {
    bool possible = true;
    for (int i = 0; i < m && possible; ++i)
      possible = state[i] == 0 || (state[i] == 1 ? std::isfinite(p.lower[i]) : std::isfinite(p.upper[i]));
    if (possible) {
      std::vector<int> free;
      Eigen::VectorXd s = Eigen::VectorXd::Zero(m);
      for (int i = 0; i < m; ++i) {
        if (state[i] == 0) free.push_back(i);
        else s[i] = state[i] == 1 ? p.lower[i] : p.upper[i];
      }
      const int k = static_cast<int>(free.size());
      Eigen::MatrixXd Nff(k, k);
      Eigen::VectorXd bf(k);
      for (int a = 0; a < k; ++a) {
        bf[a] = b[free[a]];
        for (int j = 0; j < m; ++j)
          if (state[j] != 0) bf[a] -= N(free[a], j) * s[j];
        for (int c = 0; c < k; ++c) Nff(a, c) = N(free[a], free[c]);
      }
      const Eigen::VectorXd sf = Nff.ldlt().solve(bf);
      for (int a = 0; a < k; ++a) s[free[a]] = sf[a];
      const Eigen::VectorXd g = N * s - b;
      bool kkt = true;
      for (int i = 0; i < m && kkt; ++i) {
        if (state[i] == 0) kkt = s[i] >= p.lower[i] - 1e-12 * scale && s[i] <= p.upper[i] + 1e-12 * scale;
        else if (state[i] == 1) kkt = g[i] >= -1e-12 * scale;
        else kkt = g[i] <= 1e-12 * scale;
      }
      if (kkt) {
        best = s;
        ++found;
      }
    }
    int i = 0;
    while (i < m && state[i] == 2) state[i++] = 0;
    if (i == m) break;
    ++state[i];
  }
  EXPECT_GE(found, 1);
  return best;
}

TEST(StressQp, GravityPrismWithFixedBottomMeetsKktConditions) {
  for (double offset : {0.0, 0.2}) {
    SCOPED_TRACE("twist offset " + std::to_string(offset));
    PrismParameters p;
    p.n = 3;
    p.twist_offset = offset;
    p.gravity = true;
    p.fix_bottom = true;
    p.strut_mass = 0.4;
    p.cable_mass = 0.05;
    const Structure s = make_regular_prism(p);
    Equilibrium eq(s);
    const ForceScale scale = make_force_scale(s);
    ASSERT_GT(scale.reference_force, 1.0);  // the part's weight
    const StressQpOptions options;
    StressQp qp(eq, scale, options);
    const StressQpResult r = qp.solve();
    EXPECT_TRUE(r.optimal);
    const Eigen::VectorXd& sigma = r.sigma;
    const DenseProblem d = dense_problem(eq, scale, options.normalisation_weight);

    // KKT of the full objective (with the mu term), which the polish may
    // perturb by mu |sigma| at most.
    const Eigen::VectorXd g = d.gradient(sigma, options.mu);
    const double tol = 1e-12 * scale.reference_force + 2.0 * options.mu * sigma.lpNorm<Eigen::Infinity>();
    int at_bound = 0;
    for (int e = 0; e < s.num_elements(); ++e) {
      ASSERT_GE(sigma[e], d.lower[e]);
      ASSERT_LE(sigma[e], d.upper[e]);
      if (sigma[e] == d.lower[e]) {
        ++at_bound;
        EXPECT_GE(g[e], -tol) << e;  // multiplier of a lower bound: g >= 0
      } else if (sigma[e] == d.upper[e]) {
        ++at_bound;
        EXPECT_LE(g[e], tol) << e;
      } else {
        EXPECT_NEAR(g[e], 0.0, tol) << e;
      }
    }
    EXPECT_EQ(at_bound, r.active_bounds);
    // Objective reported without the mu term.
    const Eigen::VectorXd res = d.A * sigma + d.f;
    const double e_norm = d.c.dot(sigma) - d.t;
    EXPECT_NEAR(r.objective, res.squaredNorm() + d.w2 * e_norm * e_norm, 1e-12 * (1.0 + r.objective));

    // Independent dense solve of the regularised problem (unique minimiser).
    // [A; w c^T] has a null space here (12 forces, 10 conditions), inside
    // which only mu chooses: the regularised normal matrix has condition
    // ~1/mu, so any double-precision solver fixes that choice to about
    // eps / mu ~ 1e-6 relative, while the equilibrium part M sigma (what the
    // polish makes exact) agrees to rounding.
    const Eigen::VectorXd reference = brute_force(d, options.mu);
    const double size = reference.lpNorm<Eigen::Infinity>();
    EXPECT_LE((sigma - reference).lpNorm<Eigen::Infinity>(), 1e-5 * size);
    EXPECT_LE((d.A * (sigma - reference)).lpNorm<Eigen::Infinity>(), 1e-9 * size);
    EXPECT_NEAR(d.c.dot(sigma - reference), 0.0, 1e-9 * size);
    EXPECT_LE(r.objective, (d.A * reference + d.f).squaredNorm() +
                               d.w2 * std::pow(d.c.dot(reference) - d.t, 2) + 1e-12 * size * size);
  }
}

TEST(StressQp, WarmStartAfterSmallGeometryChange) {
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 1.0);
  for (double offset : {0.0, 5.0 * M_PI / 180.0}) {
    SCOPED_TRACE("twist offset " + std::to_string(offset));
    PrismParameters p;
    p.n = 6;
    p.twist_offset = offset;
    const Structure s = make_regular_prism(p);
    Equilibrium eq(s);
    const ForceScale scale = make_force_scale(s);
    StressQp qp(eq, scale);
    StressQpResult previous = qp.solve();
    ASSERT_TRUE(previous.optimal);
    Eigen::Matrix3Xd x = s.positions;
    for (int step = 0; step < 5; ++step) {
      for (int i = 0; i < x.size(); ++i) x.data()[i] += 1e-5 * noise(rng);
      eq.set_positions(x);
      const StressQpResult warm = qp.solve(previous.sigma);
      StressQp fresh(eq, scale);
      const StressQpResult cold = fresh.solve();
      EXPECT_TRUE(warm.optimal);
      EXPECT_TRUE(cold.optimal);
      EXPECT_LE(warm.iterations, 3);
      EXPECT_LE(warm.factorizations, 3);
      EXPECT_LE((warm.sigma - cold.sigma).lpNorm<Eigen::Infinity>(),
                1e-10 * cold.sigma.lpNorm<Eigen::Infinity>());
      previous = warm;
    }
  }
}

// Algorithm 1's situation on the 80-strut / 500-cable tower: a proximal warm
// solve after each small move of the nodes down Eq. 6's gradient. About 140
// forces sit at their sign margin and A has many near-null directions, so the
// coupled Newton step pushes forces at a bound out of the box; before such
// forces were pinned, these solves crept along at a fixed projected gradient
// into the 100-iteration cap (60-100 factorizations each, not optimal).
TEST(StressQp, ProximalWarmSolvesOnThePerturbedTowerSettle) {
  const Structure s = scenes::perturbed_tower(std::string(TENSEGRITY_SOURCE_DIR) + "/data", false);
  Equilibrium eq(s);
  const ForceScale scale = make_force_scale(s);
  StressQpOptions options;
  options.proximal = true;
  StressQp qp(eq, scale, options);
  StressQpResult r = qp.solve();
  ASSERT_TRUE(r.optimal);
  const double mean_length = s.mean_element_length();
  Eigen::VectorXd q = eq.free_nodes().gather(s.positions), f, g(eq.num_equations());
  int factorizations = 0, optimal = 0, at_bound = 0;
  const int moves = 12;
  for (int move = 0; move < moves; ++move) {
    f = eq.residual(r.sigma);
    eq.jacobian_positions_product(r.sigma, f, g);
    q -= (1e-3 * mean_length / g.norm()) * g;
    eq.set_free_coordinates(q);
    const double normalisation_error = scale.normalisation_row.dot(r.sigma) - scale.normalisation_target;
    const double warm_objective = eq.residual(r.sigma).squaredNorm() + normalisation_error * normalisation_error;
    const StressQpResult next = qp.solve(r.sigma);
    factorizations += next.factorizations;
    optimal += next.optimal;
    at_bound += next.active_bounds;
    EXPECT_LE(next.objective, warm_objective);
    r = next;
  }
  std::printf("%d moves: %d optimal, %.1f factorizations and %.0f forces at a bound per solve\n", moves,
              optimal, double(factorizations) / moves, double(at_bound) / moves);
  EXPECT_EQ(optimal, moves);
  EXPECT_LE(factorizations, 12 * moves);
  EXPECT_GE(at_bound, 50 * moves);  // the degenerate case this test is about
}

// The stored gravity tower, as the driver sees it (one part, without the 8
// cables between fixed nodes): about 115 forces end at their sign margin
// with multipliers of 1e-9 .. 1e-6 of the force scale. The interior-point
// phase must drive those slacks below their multipliers, so that its
// crossover hands projected Newton the whole active set. With its old
// stopping gap (1e-12 scale^2) nothing was snapped and the bounds were found
// one per iteration: 80 iterations here, and ~450 (1200 factorizations) on
// a 0.3 % perturbation of it, where Algorithm 1's warm solves hit the cap.
TEST(StressQp, InteriorPointCrossoverFindsTheGravityTowersWeaklyActiveBounds) {
  const Structure whole = scenes::tower_equilibrium(std::string(TENSEGRITY_SOURCE_DIR) + "/data", true);
  const Partition partition = split_into_parts(whole);
  ASSERT_EQ(partition.parts.size(), 1u);
  for (double noise : {0.0, 0.003}) {
    const Structure s = scenes::with_tower_noise(partition.parts[0].structure, noise, 1);
    Equilibrium eq(s);
    StressQp qp(eq, make_force_scale(s));
    const StressQpResult r = qp.solve();
    SCOPED_TRACE("noise " + std::to_string(noise));
    EXPECT_TRUE(r.optimal);
    EXPECT_GE(r.active_bounds, 100);
    EXPECT_LE(r.iterations, 40);
    EXPECT_LE(r.factorizations, 130);  // the polish refactorizes when a bound joins the held set
    std::printf("gravity tower, noise %.3f: %d iterations, %d factorizations, %d forces at a bound\n", noise,
                r.iterations, r.factorizations, r.active_bounds);
  }
}

// Algorithm 1 re-solves the QP after every position phase, warm from the
// previous forces. After a small move the previous active set is still the
// active set, but the gradient at the old forces points into the box at many
// of its bounds; freeing them cost a pinning round (a factorization) each:
// 5-6 factorizations per warm solve on the perturbed gravity tower, where the
// faithful scheme spent a quarter of its time in them. The first step now
// keeps every bound of the warm start: one factorization when the set holds.
// (After moves of 1e-5 strut lengths the set itself changes: 4-15.)
TEST(StressQp, WarmSolveAfterASmallMoveKeepsTheActiveSetInOneFactorization) {
  const Structure whole = scenes::tower_equilibrium(std::string(TENSEGRITY_SOURCE_DIR) + "/data", true);
  const Partition partition = split_into_parts(whole);
  ASSERT_EQ(partition.parts.size(), 1u);
  const Structure start = scenes::with_tower_noise(partition.parts[0].structure, 0.003, 1);
  Equilibrium eq(start);
  StressQp qp(eq, make_force_scale(start));
  const StressQpResult first = qp.solve();
  ASSERT_TRUE(first.optimal);
  ASSERT_GE(first.active_bounds, 100);
  int total = 0, solves = 0;
  Eigen::VectorXd sigma = first.sigma;
  for (int seed = 2; seed <= 6; ++seed) {
    // Every free node moved by up to 1e-7 strut lengths, as in a crawling position phase.
    const Structure moved = scenes::with_tower_noise(start, 1e-7, seed);
    eq.set_positions(moved.positions);
    const StressQpResult warm = qp.solve(sigma);
    SCOPED_TRACE("seed " + std::to_string(seed));
    EXPECT_TRUE(warm.optimal);
    // The same optimum as a cold solve at this geometry.
    Equilibrium eq_cold(moved);
    StressQp cold_qp(eq_cold, make_force_scale(start));
    const StressQpResult cold = cold_qp.solve();
    ASSERT_TRUE(cold.optimal);
    EXPECT_EQ(warm.active_bounds, cold.active_bounds);
    EXPECT_NEAR(warm.objective, cold.objective, 1e-6 * cold.objective + 1e-20);
    EXPECT_EQ(warm.factorizations, 1);  // 4 each without keeping the bounds
    total += warm.factorizations;
    ++solves;
    sigma = warm.sigma;
  }
  std::printf("warm solves after small moves: %.1f factorizations each\n", double(total) / solves);
}

// Two identical cables between the same nodes share their force in any split:
// the mu term alone picks it. Centred on the origin it is the even split; with
// `proximal` a warm solve keeps the warm start's split (the direction (1, -1)
// on the pair is exactly null in A), after a geometry change too, and the
// residual is the same either way.
TEST(StressQp, ProximalWarmSolveKeepsTheWarmStartAmongEquallyGoodForces) {
  PrismParameters p;
  p.n = 4;
  Structure s = make_regular_prism(p);
  const int first = p.n;  // a vertical cable
  const int second = static_cast<int>(s.elements.size());
  s.elements.push_back(s.elements[first]);
  Equilibrium eq(s);
  const ForceScale scale = make_force_scale(s);
  StressQp plain(eq, scale);
  const StressQpResult cold = plain.solve();
  ASSERT_TRUE(cold.optimal);
  const double pair = cold.sigma[first] + cold.sigma[second];
  EXPECT_NEAR(cold.sigma[first], cold.sigma[second], 1e-6 * pair);

  Eigen::VectorXd uneven = cold.sigma;
  uneven[first] = 0.75 * pair;
  uneven[second] = 0.25 * pair;
  Eigen::Matrix3Xd x = s.positions;
  x(0, 0) += 1e-3 * s.mean_element_length();  // no longer a tensegrity
  eq.set_positions(x);
  StressQpOptions options;
  options.proximal = true;
  StressQp proximal(eq, scale, options);
  const StressQpResult kept = proximal.solve(uneven);
  const StressQpResult even = plain.solve(uneven);
  ASSERT_TRUE(kept.optimal);
  ASSERT_TRUE(even.optimal);
  EXPECT_NEAR(kept.sigma[first] - kept.sigma[second], 0.5 * pair, 1e-6 * pair);
  EXPECT_NEAR(even.sigma[first] - even.sigma[second], 0.0, 1e-6 * pair);
  EXPECT_NEAR(kept.objective, even.objective, 1e-9 * even.objective + 1e-24);
  EXPECT_GT(even.objective, 1e-12);  // the moved node leaves a residual
  // A cold solve ignores `proximal`. Checked where the cold start (+F0 on
  // cables, -F0 on struts) is uneven along null directions of A: a strut on
  // the doubled cable's nodes makes three equal columns; centred on that
  // start, the strut would keep about -F0 instead of its margin.
  Structure with_strut = s;
  with_strut.elements.push_back(s.elements[first]);
  with_strut.elements.back().kind = ElementKind::Strut;
  Equilibrium eq3(with_strut);
  const ForceScale scale3 = make_force_scale(with_strut);
  StressQp plain3(eq3, scale3), proximal3(eq3, scale3, options);
  const StressQpResult a = plain3.solve(), b = proximal3.solve();
  ASSERT_TRUE(a.optimal);
  EXPECT_LE((a.sigma - b.sigma).lpNorm<Eigen::Infinity>(), 1e-12 * a.sigma.lpNorm<Eigen::Infinity>());
}

// A random element set on random nodes (some fixed, with gravity) gives a
// random sparse A with unit columns; random two-sided / one-sided / absent
// bounds and a random normalisation row make a generic bounded least-squares
// problem, checked against the enumeration above (mu-free objective, which the
// polish reaches when [A; w c^T] has full column rank).
// A random bounded least-squares instance on a small structure under gravity:
// bounds of every kind (two-sided, one-sided, none), a normalisation row.
struct BoundedInstance {
  Structure s;
  ForceScale scale;
};
BoundedInstance random_bounded_instance(std::mt19937& rng) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  BoundedInstance out;
  Structure& s = out.s;
  const int nodes = 6;
  for (int i = 0; i < nodes; ++i)
    s.add_node({unit(rng), unit(rng), unit(rng)}, i >= 4, 0.5 + 0.5 * unit(rng));
  s.gravity = Eigen::Vector3d(0.3 * unit(rng), 0.3 * unit(rng), -9.81);
  std::vector<std::pair<int, int>> pairs;
  for (int a = 0; a < nodes; ++a)
    for (int b = a + 1; b < nodes; ++b)
      if (!(a >= 4 && b >= 4)) pairs.emplace_back(a, b);
  std::shuffle(pairs.begin(), pairs.end(), rng);
  const int m = 10;
  for (int e = 0; e < m; ++e)
    s.add_element(pairs[e].first, pairs[e].second, e % 3 == 0 ? ElementKind::Strut : ElementKind::Cable);
  out.scale = make_force_scale(s);
  ForceScale& scale = out.scale;
  for (int e = 0; e < m; ++e) {
    const double a = 3.0 * unit(rng), b = 3.0 * unit(rng);
    switch (e % 4) {
      case 0: scale.lower[e] = std::min(a, b); scale.upper[e] = std::max(a, b); break;
      case 1: scale.lower[e] = a; scale.upper[e] = kInf; break;
      case 2: scale.lower[e] = -kInf; scale.upper[e] = a; break;
      default: scale.lower[e] = -kInf; scale.upper[e] = kInf; break;
    }
  }
  return out;
}

TEST(StressQp, RandomBoundedLeastSquaresMatchesBruteForce) {
  std::mt19937 rng(2024);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  int with_active_bounds = 0;
  for (int instance = 0; instance < 40; ++instance) {
    SCOPED_TRACE("instance " + std::to_string(instance));
    const BoundedInstance inst = random_bounded_instance(rng);
    const Structure& s = inst.s;
    const ForceScale& scale = inst.scale;
    const int m = s.num_elements();
    Equilibrium eq(s);
    StressQpOptions options;
    options.normalisation_weight = 0.7;
    StressQp qp(eq, scale, options);
    const StressQpResult r = qp.solve();
    EXPECT_TRUE(r.optimal);
    const DenseProblem d = dense_problem(eq, scale, options.normalisation_weight);
    const Eigen::VectorXd reference = brute_force(d, 0.0);
    const double size = std::max(1.0, reference.lpNorm<Eigen::Infinity>());
    EXPECT_LE((r.sigma - reference).lpNorm<Eigen::Infinity>(), 1e-9 * size);
    const Eigen::VectorXd res = d.A * reference + d.f;
    const double e_ref = d.c.dot(reference) - d.t;
    EXPECT_NEAR(r.objective, res.squaredNorm() + d.w2 * e_ref * e_ref, 1e-10 * (1.0 + r.objective));
    if (r.active_bounds > 0) ++with_active_bounds;

    // A warm start from a poor point finds the same minimiser.
    Eigen::VectorXd poor(m);
    for (int e = 0; e < m; ++e) poor[e] = 5.0 * unit(rng);
    const StressQpResult again = qp.solve(poor);
    EXPECT_TRUE(again.optimal);
    EXPECT_LE((again.sigma - reference).lpNorm<Eigen::Infinity>(), 1e-9 * size);
  }
  EXPECT_GE(with_active_bounds, 20);  // the instances do exercise the bounds
}

// The certificate of an optimum (certify_optimum): on the random instances
// above, whose optima have positive residuals, the lower bound is proven and
// lies between a quarter of the brute-force optimum's objective and that
// objective itself (weak duality: no force vector in the box does better).
TEST(StressQp, CertifiedLowerBoundLiesBelowTheBruteForceOptimum) {
  std::mt19937 rng(2024);
  int positive = 0;
  for (int instance = 0; instance < 40; ++instance) {
    SCOPED_TRACE("instance " + std::to_string(instance));
    const BoundedInstance inst = random_bounded_instance(rng);
    Equilibrium eq(inst.s);
    StressQpOptions options;
    options.normalisation_weight = 0.7;
    options.certify_optimum = true;
    StressQp qp(eq, inst.scale, options);
    const StressQpResult r = qp.solve();
    EXPECT_TRUE(r.optimal) << r.message;
    const DenseProblem d = dense_problem(eq, inst.scale, options.normalisation_weight);
    const Eigen::VectorXd reference = brute_force(d, 0.0);
    const Eigen::VectorXd res = d.A * reference + d.f;
    const double e_ref = d.c.dot(reference) - d.t;
    const double optimum = res.squaredNorm() + d.w2 * e_ref * e_ref;
    EXPECT_LE(r.objective_lower_bound, optimum * (1.0 + 1e-9) + 1e-15);
    EXPECT_GE(r.objective_lower_bound, 0.25 * r.objective);
    positive += optimum > 1e-6;
  }
  EXPECT_GE(positive, 30);  // the bound is exercised away from zero
}

// The 10-layer tower of `generate tower` (580 elements) at an equilibrium:
// its free set is nearly singular, so the stress QP stops at points whose
// gradient is tiny while the residual is still 1e-6 of the scale. With a
// looser KKT tolerance those points pass the gradient test; certified, none
// of them is called optimal, and every bound stays below its objective.
TEST(StressQp, CertificateRejectsKktPointsOfANearMechanism) {
  scenes::TowerParameters p;
  p.layers = 10;
  p.cables = 500;
  const Structure tower = scenes::make_prism_tower(p);
  const SolveResult solved = make_solver("alternating-gn")->Solve(tower, SolveOptions{}, {});
  ASSERT_EQ(solved.status, Status::Converged) << solved.message;
  Structure s = tower;
  s.positions = solved.positions;
  Equilibrium eq(s);
  const ForceScale scale = make_force_scale(s);
  constexpr double kScaleTolerance = 1e-8;
  int rejected = 0, solves = 0;
  for (double kkt_tolerance : {1e-7, 1e-8, 1e-9, 1e-10, 1e-11}) {
    StressQpOptions options;
    options.optimality_tolerance = kkt_tolerance;
    options.certify_optimum = true;
    StressQp qp(eq, scale, options);
    const StressQpResult r = qp.solve();
    const Verification v = verify(s, s.positions, r.sigma, kScaleTolerance);
    SCOPED_TRACE("KKT tolerance " + std::to_string(kkt_tolerance) + ": " + r.message);
    ++solves;
    EXPECT_LE(r.objective_lower_bound, r.objective);
    if (r.optimal) {
      EXPECT_TRUE(v.ok) << "relative residual " << v.relative_residual;
    }
    if (r.message.find("not certified") != std::string::npos) {
      EXPECT_EQ(r.status, StressQpStatus::Uncertified);
      ++rejected;
    }
  }
  EXPECT_GE(rejected, 1) << "no KKT point to reject: the test no longer exercises the certificate";
  std::printf("%d of %d KKT points rejected by the certificate\n", rejected, solves);
}

// A spent step cap is its own status, and its message names the cap: the
// twisted, perturbed prism needs several active-set steps from a cold start.
TEST(StressQp, SpentStepCapIsIterationLimitNotAProof) {
  PrismParameters p;
  p.n = 8;
  p.twist_offset = 15.0 * M_PI / 180.0;
  scenes::NodeNoise noise;
  noise.fraction = 0.05;
  const Structure s = scenes::with_node_noise(make_regular_prism(p), noise, 9u);
  Equilibrium eq(s);
  const ForceScale scale = make_force_scale(s);
  StressQpOptions capped;
  capped.max_iterations = 0;
  capped.max_polish_steps = 0;
  StressQp qp(eq, scale, capped);
  const StressQpResult r = qp.solve();
  EXPECT_EQ(r.status, StressQpStatus::IterationLimit) << r.message;
  EXPECT_EQ(r.message.rfind("step cap reached (max_iterations 0, max_polish_steps 0)", 0), 0u) << r.message;
  EXPECT_STREQ(to_string(r.status), "iteration_limit");
  StressQp free_run(eq, scale);
  const StressQpResult optimum = free_run.solve();
  EXPECT_EQ(optimum.status, StressQpStatus::Optimal) << optimum.message;
  EXPECT_LT(optimum.objective, r.objective);
}

// give_up_after: far from a tensegrity the QP stops where asked, without the
// polish, and says at which residual; above that residual it runs on, exactly
// as without the option.
TEST(StressQp, GivesUpFarFromATensegrityOnlyAboveTheResidualAsked) {
  constexpr int kLayers = 40;
  const Structure s = testing::gravity_tower_at_equilibrium(kLayers);  // 1 % node noise
  Equilibrium eq(s);
  const ForceScale scale = make_force_scale(s);
  constexpr int kGiveUpAfter = 30;
  constexpr double kTolerance = 1e-8;
  auto residual_of = [&](const Eigen::VectorXd& sigma) {
    return verify(s, s.positions, sigma, kTolerance).relative_residual;
  };
  StressQpOptions early;
  early.give_up_after = kGiveUpAfter;
  const StressQpResult given_up = StressQp(eq, scale, early).solve();
  EXPECT_EQ(given_up.status, StressQpStatus::IterationLimit) << given_up.message;
  const std::string expected = "gave up after " + std::to_string(kGiveUpAfter) + " steps at relative residual ";
  EXPECT_EQ(given_up.message.rfind(expected, 0), 0u) << given_up.message;
  EXPECT_EQ(given_up.iterations, kGiveUpAfter);
  EXPECT_EQ(given_up.polish_steps, 0);
  const double residual = residual_of(given_up.sigma);
  EXPECT_GT(residual, early.give_up_residual);
  constexpr double kSameMeasure = 1e-5;  // relative: the message's digits against model/verify's
  EXPECT_NEAR(std::stod(given_up.message.substr(expected.size())), residual, kSameMeasure * residual)
      << given_up.message;

  StressQpOptions tolerant = early;
  tolerant.give_up_residual = 2.0 * residual;
  const StressQpResult ran_on = StressQp(eq, scale, tolerant).solve();
  const StressQpResult plain = StressQp(eq, scale).solve();
  EXPECT_EQ(ran_on.message, plain.message);
  EXPECT_EQ(ran_on.iterations, plain.iterations);
  EXPECT_EQ((ran_on.sigma - plain.sigma).lpNorm<Eigen::Infinity>(), 0.0);
  EXPECT_NE(plain.message.find("step cap reached (max_iterations 100"), std::string::npos) << plain.message;
  EXPECT_LT(plain.objective, given_up.objective);
  EXPECT_GT(residual_of(plain.sigma), early.give_up_residual);  // giving up was a right call
}

// The driver's check (its interior-point phase first, then a give-up above
// 1e-2) leaves a scene that stands untouched: the 10-layer 8-strut tower's
// equilibrium without gravity, a near-mechanism on which the QP runs past
// the give-up's step, gets the same forces, bit for bit, as the same QP
// without the give-up.
TEST(StressQp, GivingUpLeavesAStandingTowerUntouched) {
  scenes::TowerParameters p;
  p.layers = 10;
  p.cables = 50 * p.layers;
  Structure s = scenes::make_prism_tower(p);
  const SolveResult standing = make_solver("alternating-gn")->Solve(s, SolveOptions{});
  ASSERT_EQ(standing.status, Status::Converged) << standing.message;
  s.positions = standing.positions;
  Equilibrium eq(s);
  const ForceScale scale = make_force_scale(s);
  const StressQpOptions check = standing_check_qp_options();
  EXPECT_TRUE(check.end_interior_point_when_settled);
  StressQpOptions plain = check;
  plain.give_up_after = -1;
  plain.end_interior_point_when_settled = false;
  const StressQpResult checked = StressQp(eq, scale, check).solve();
  const StressQpResult full = StressQp(eq, scale, plain).solve();
  EXPECT_GT(full.iterations, check.give_up_after);  // the case this test is about
  EXPECT_EQ(checked.status, full.status) << checked.message;
  EXPECT_EQ(checked.message, full.message);
  EXPECT_EQ(checked.iterations, full.iterations);
  EXPECT_EQ((checked.sigma - full.sigma).lpNorm<Eigen::Infinity>(), 0.0);
  EXPECT_LE(relative_residual(s, s.positions, checked.sigma), 1e-4);
}

// Past its interior-point phase the check's projected Newton ends once its
// best point has stopped improving (end_when_stalled_after). On the
// as-generated 40-layer tower without gravity, a near-mechanism that does not
// stand and that the QP leaves near an equilibrium, the best point is the
// phase's own: the stall ends the QP that many steps later instead of at its
// step cap, at the step cap's residual, with a fraction of its factorizations.
TEST(StressQp, TheChecksStallEndsTheStepsThatBringNothing) {
  scenes::TowerParameters p;
  p.layers = 40;
  p.cables = 50 * p.layers;
  p.noise = 0.0;  // as `generate tower` writes it
  const Structure s = scenes::make_prism_tower(p);
  Equilibrium eq(s);
  const ForceScale scale = make_force_scale(s);
  const StressQpOptions check = standing_check_qp_options();
  ASSERT_GT(check.end_when_stalled_after, 0);
  StressQpOptions to_the_cap = check;
  to_the_cap.end_when_stalled_after = -1;
  const StressQpResult stalled = StressQp(eq, scale, check).solve();
  const StressQpResult capped = StressQp(eq, scale, to_the_cap).solve();
  EXPECT_EQ(capped.status, StressQpStatus::IterationLimit) << capped.message;
  EXPECT_EQ(capped.iterations, to_the_cap.max_iterations);
  EXPECT_EQ(stalled.status, StressQpStatus::Stalled) << stalled.message;
  EXPECT_FALSE(stalled.gave_up);
  EXPECT_EQ(stalled.iterations, check.end_when_stalled_after);
  // Near an equilibrium, where the check goes on to its polish (below 1e-3).
  const double at_the_cap = relative_residual(s, s.positions, capped.sigma);
  EXPECT_GT(at_the_cap, 1e-5);
  EXPECT_LT(at_the_cap, 1e-3);
  // The 90 further steps lower the objective by a relative 1e-12; the forces
  // move along near-null directions of A meanwhile, and the largest node
  // residual by 3 % (6.46e-5 against 6.25e-5).
  constexpr double kSameResidual = 0.05;  // relative
  EXPECT_NEAR(relative_residual(s, s.positions, stalled.sigma), at_the_cap, kSameResidual * at_the_cap);
  EXPECT_LT(5 * stalled.factorizations, capped.factorizations);  // 54 against 336

  // The check's polish after such a stall starts from the QP's best point
  // without a second interior-point phase (solvers/solve_scene.cpp): on
  // this tower, which does not stand, the phase would cost as many
  // factorizations as the whole polish without it (31 against 32), and the
  // steps after it meet their KKT test at a residual ten times higher
  // (4.7e-4 against 4.9e-5), uncertified: a tiny gradient on a near-mechanism.
  constexpr int kShortPolishSteps = 30;
  auto polish_after_stall = [&](bool second_phase) {
    StressQp qp(eq, scale, check);
    qp.set_polish(true, kShortPolishSteps);
    constexpr int kNoInteriorPoint = -1;  // StressQpOptions::interior_point_after: never
    if (!second_phase) qp.set_interior_point_after(kNoInteriorPoint);
    return qp.solve(stalled.sigma);
  };
  const StressQpResult warm = polish_after_stall(false);
  const StressQpResult again = polish_after_stall(true);
  const double polished = relative_residual(s, s.positions, warm.sigma);
  constexpr double kSameResidualAsBefore = 0.25;  // relative, against the stalled QP's own
  constexpr double kPhaseWorseBy = 5.0;
  EXPECT_GT(polished, 1e-5);
  EXPECT_LE(polished, (1.0 + kSameResidualAsBefore) * at_the_cap);
  EXPECT_GT(relative_residual(s, s.positions, again.sigma), kPhaseWorseBy * polished);
}

// The check gives up on a scene to be solved a few steps past its
// interior-point phase, above the residual it asks, where the whole QP
// confirms that the scene does not stand: the 40-layer gravity tower with
// 1 % node noise. Its phase ends early, once the residual has settled far
// above that (end_interior_point_when_settled), at the whole QP's residual.
TEST(StressQp, TheDriversCheckGivesUpOnANoisyTower) {
  constexpr int kLayers = 40;
  const Structure s = testing::gravity_tower_at_equilibrium(kLayers);  // 1 % node noise
  Equilibrium eq(s);
  const ForceScale scale = make_force_scale(s);
  constexpr double kTolerance = 1e-8;
  auto residual_of = [&](const Eigen::VectorXd& sigma) {
    return verify(s, s.positions, sigma, kTolerance).relative_residual;
  };
  const StressQpOptions check = standing_check_qp_options();
  EXPECT_EQ(check.interior_point_after, 0);
  const StressQpResult given_up = StressQp(eq, scale, check).solve();
  EXPECT_EQ(given_up.status, StressQpStatus::IterationLimit) << given_up.message;
  EXPECT_TRUE(given_up.gave_up);
  EXPECT_EQ(given_up.iterations, check.give_up_after);
  StressQpOptions whole_phase = check;
  whole_phase.end_interior_point_when_settled = false;
  const StressQpResult later = StressQp(eq, scale, whole_phase).solve();
  EXPECT_TRUE(later.gave_up) << later.message;
  EXPECT_EQ(later.iterations, check.give_up_after);
  StressQpOptions whole = whole_phase;
  whole.give_up_after = -1;
  const StressQpResult full = StressQp(eq, scale, whole).solve();
  EXPECT_GT(full.iterations, check.give_up_after);
  // Both give-ups leave the whole QP's residual, far above the one asked.
  constexpr double kSameResidual = 0.01;  // relative
  constexpr double kSettledAbove = 10.0;  // times give_up_residual (StressQpOptions)
  const double optimum = residual_of(full.sigma);
  EXPECT_GT(optimum, kSettledAbove * check.give_up_residual);
  EXPECT_NEAR(residual_of(given_up.sigma), optimum, kSameResidual * optimum);
  EXPECT_NEAR(residual_of(later.sigma), optimum, kSameResidual * optimum);
  // The phase's early end saves a quarter of the factorizations or more (53 to 38).
  EXPECT_LT(4 * given_up.factorizations, 3 * later.factorizations);
}

// The phase ends early only where the settled residual is above ten times
// give_up_residual: below that the solve is the one without
// end_interior_point_when_settled, bit for bit.
TEST(StressQp, EndsTheInteriorPointPhaseEarlyOnlyFarAboveTheResidualAsked) {
  constexpr int kLayers = 40;
  const Structure s = testing::gravity_tower_at_equilibrium(kLayers);  // 1 % node noise
  Equilibrium eq(s);
  const ForceScale scale = make_force_scale(s);
  StressQpOptions check = standing_check_qp_options();
  const StressQpResult early = StressQp(eq, scale, check).solve();
  ASSERT_TRUE(early.gave_up) << early.message;
  constexpr double kBelowTenfold = 0.2;  // give_up_residual as a share of the settled residual
  constexpr double kTolerance = 1e-8;
  check.give_up_residual = kBelowTenfold * verify(s, s.positions, early.sigma, kTolerance).relative_residual;
  StressQpOptions without = check;
  without.end_interior_point_when_settled = false;
  const StressQpResult ran_on = StressQp(eq, scale, check).solve();
  const StressQpResult plain = StressQp(eq, scale, without).solve();
  EXPECT_EQ(ran_on.message, plain.message);
  EXPECT_EQ(ran_on.iterations, plain.iterations);
  EXPECT_EQ(ran_on.factorizations, plain.factorizations);
  EXPECT_EQ((ran_on.sigma - plain.sigma).lpNorm<Eigen::Infinity>(), 0.0);
  EXPECT_TRUE(ran_on.gave_up);  // still given up, past the whole phase
  EXPECT_GT(ran_on.factorizations, early.factorizations);
}

// The early end of the check's interior-point phase is no verdict: the
// phase's iterates can settle far from forces that stand, and the steps after
// the crossover still find them. The stress test's 5-strut gravity prism
// with 0.1 % node noise (seed 1) stands; its phase settles at a relative
// residual above 0.1 and ends early, and the driver returns the scene
// unchanged, as with the whole phase.
TEST(StressQp, TheChecksEarlyEndStillFindsAGravityPrismThatStands) {
  const std::vector<scenes::BaseScene> bases = scenes::base_scenes(std::string(TENSEGRITY_SOURCE_DIR) + "/data");
  const auto base = std::find_if(bases.begin(), bases.end(),
                                 [](const scenes::BaseScene& b) { return b.name == "prism-5-gravity"; });
  ASSERT_NE(base, bases.end());
  constexpr int kOneThousandth = 0;  // the noise family's first level
  constexpr std::uint64_t kStressSeed = 1;
  const Structure s = scenes::make_family_case(base->scene, "noise", kOneThousandth, 0, kStressSeed);
  Equilibrium eq(s);
  const ForceScale scale = make_force_scale(s);
  const StressQpOptions check = standing_check_qp_options();
  StressQpOptions whole_phase = check;
  whole_phase.end_interior_point_when_settled = false;
  const StressQpResult early = StressQp(eq, scale, check).solve();
  const StressQpResult whole = StressQp(eq, scale, whole_phase).solve();
  EXPECT_LT(early.factorizations, whole.factorizations);  // the phase did end early
  EXPECT_FALSE(early.gave_up) << early.message;
  const SolveResult r = make_solver("alternating-gn")->Solve(s, SolveOptions{});
  EXPECT_EQ(r.status, Status::Converged) << r.message;
  EXPECT_EQ(r.stats.geometry_change, 0.0);
  EXPECT_NE(r.message.find("already in equilibrium"), std::string::npos) << r.message;
}

// The driver's check hands the backend nothing, whether it gave up or ran to
// its end: the backend's answer is the one it gives without the check
// (DriverControls{false}), bit for bit. Budgets of iterations (not of time)
// keep the runs comparable.
void expect_answers_without_the_check(const Structure& s, std::initializer_list<const char*> backends) {
  constexpr int kIterations = 5;
  for (const char* backend : backends) {
    const auto solver = make_solver(backend);
    SolveOptions options;
    options.max_iterations = kIterations;
    const SolveResult checked = solver->Solve(s, options);
    const SolveResult alone = solver->Solve(s, options, DriverControls{false});
    EXPECT_EQ(checked.status, alone.status) << backend << ": " << checked.message;
    EXPECT_EQ(checked.message.find("already in equilibrium"), std::string::npos) << backend;  // not the shortcut
    EXPECT_EQ((checked.positions - alone.positions).lpNorm<Eigen::Infinity>(), 0.0) << backend;
    EXPECT_EQ((checked.forces - alone.forces).lpNorm<Eigen::Infinity>(), 0.0) << backend;
  }
}

// A prism a little off its equilibrium, where the check's QP finishes.
constexpr int kFinishedCheckPrismStruts = 8;
constexpr double kFinishedCheckNoise = 0.003;  // of the median element length
constexpr unsigned kFinishedCheckSeed = 5u;

TEST(StressQp, AfterTheChecksGiveUpTheBackendsAnswerIsItsOwn) {
  constexpr int kLayers = 20;
  const Structure s = testing::gravity_tower_at_equilibrium(kLayers);  // 1 % node noise
  Equilibrium eq(s);
  const StressQpResult check = StressQp(eq, make_force_scale(s), standing_check_qp_options()).solve();
  ASSERT_TRUE(check.gave_up) << check.message;  // the case this test is about
  expect_answers_without_the_check(s, {"alternating", "nlopt", "alternating-gn", "eq5-newton"});
}

// A check that runs to its end near a tensegrity: its optimal forces are a
// start as good as any, yet each backend's own start decides its basin.
TEST(StressQp, AfterAFinishedCheckTheBackendsAnswerIsItsOwn) {
  PrismParameters p;
  p.n = kFinishedCheckPrismStruts;
  scenes::NodeNoise noise;
  noise.fraction = kFinishedCheckNoise;
  const Structure s = scenes::with_node_noise(make_regular_prism(p), noise, kFinishedCheckSeed);
  Equilibrium eq(s);
  const StressQpResult check = StressQp(eq, make_force_scale(s), standing_check_qp_options()).solve();
  ASSERT_FALSE(check.gave_up) << check.message;  // the case this test is about
  ASSERT_EQ(check.status, StressQpStatus::Optimal) << check.message;
  ASSERT_GT(verify(s, s.positions, check.sigma, SolveOptions{}.tolerance).relative_residual, SolveOptions{}.tolerance);
  expect_answers_without_the_check(s, {"alternating", "nlopt", "alternating-gn", "eq5-newton", "ipopt"});
}

TEST(StressQp, FailuresAreReportedNotThrown) {
  const Structure s = make_regular_prism({});
  Equilibrium eq(s);
  const ForceScale scale = make_force_scale(s);
  StressQpOptions bad;
  bad.mu = 0.0;
  EXPECT_FALSE(bad.IsValid());
  StressQp invalid(eq, scale, bad);
  const StressQpResult r1 = invalid.solve();
  EXPECT_FALSE(r1.optimal);
  EXPECT_TRUE(r1.sigma.allFinite());

  StressQp qp(eq, scale);
  Eigen::VectorXd start = Eigen::VectorXd::Constant(s.num_elements(), std::nan(""));
  const StressQpResult r2 = qp.solve(start);  // unusable start: cold start instead
  EXPECT_TRUE(r2.optimal);
  EXPECT_TRUE(r2.sigma.allFinite());

  Eigen::Matrix3Xd x = s.positions;
  x(0, 1) = std::nan("");  // Equilibrium flags the element as degenerate
  eq.set_positions(x);
  ASSERT_TRUE(eq.degenerate());
  const StressQpResult r3 = qp.solve(r2.sigma);
  EXPECT_FALSE(r3.optimal);
  EXPECT_TRUE(r3.sigma.allFinite());
  EXPECT_FALSE(std::isnan(r3.kkt_error));
  EXPECT_FALSE(std::isnan(r3.max_node_residual));
}

}  // namespace
}  // namespace tensegrity
