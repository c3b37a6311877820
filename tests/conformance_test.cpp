// The conformance suite: every registered backend on every committed scene of
// tests/reference/scenes/, judged against the reference optima of Eq. 5 in
// tests/reference/optima.json (computed once, independently of this code base,
// by tests/reference/compute_optima.py; see tests/reference/README.md).
// One file past 500 lines: the suites share the reference loader, the
// independent equilibrium and sign checks and the expectation table.
//
// Nothing here calls model/verify: equilibrium, signs and the geometry change
// are recomputed below from the scene file and the returned numbers, and the
// geometry change is compared with the reference optimum, so a backend that
// returns a wrong answer fails even when its own verification passes. Scenes
// that already stand must come back unchanged; run without the driver's
// shortcut, the Eq. 5 solvers must reach the stored Eq. 5 optimum instead.
//
//   conformance_test --dump-scenes DIR   writes scenes::backend_suite_scenes()
//                                        as the scene files the references use
//   conformance_test --change-answers move|scale
//                                        the self-check: every backend's answer
//                                        is changed before it is judged (a free
//                                        node moved, or the forces scaled); exits
//                                        0 only if every judged case then fails
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "model/scene_io.hpp"
#include "scenes/suites.hpp"
#include "solvers/solver.hpp"

namespace tensegrity {
namespace {

const std::string kReferenceDir = std::string(TENSEGRITY_SOURCE_DIR) + "/tests/reference/";

// The self-check (--change-answers): a wrong answer must fail the assertions.
enum class AnswerChange { None, Move, Scale };
AnswerChange g_answer_change = AnswerChange::None;

// The default tolerance for `converged` (docs/FORMATS.md, Solution file) (relative residual).
constexpr double kEquilibriumTolerance = 1e-8;
// Sign margin as a fraction of F0, and the slack allowed on it (rounding).
constexpr double kMarginFraction = 1e-3;
constexpr double kMarginSlack = 1e-9;
// Eq. 5 solved whole (ipopt, nlopt) reaches the reference's local optimum:
// geometry change within this relative difference, every node within this
// fraction of the mean element length, every force within this fraction of
// the largest reference force.
constexpr double kSameOptimumGeometryChange = 1e-4;
constexpr double kSameOptimumPosition = 1e-4;
constexpr double kSameOptimumForce = 1e-3;
// No answer may beat the reference optimum by more than this (relative),
// unless the scene's row in the table below says why.
constexpr double kBeatsOptimumSlack = 1e-6;
// A scene that stands has unique forces; the stress QP's may differ from the
// reference's by this fraction of the largest reference force.
constexpr double kStandingForce = 1e-6;
// A sign bound active at the reference optimum: the backend's force is at the
// margin within this fraction of it.
constexpr double kActiveBound = 1e-3;
// The prestress cap under gravity the reference optima were computed with
// (kappa = 1: mean cable force at most the weight, below the default so that
// the cap binds), and the rounding allowed on a row held there.
constexpr double kPrestressFactor = 1.0;
constexpr double kCapSlack = 1e-6;
// The self-check's changes: one free node moved by this fraction of the mean
// element length (positions and geometry change kept consistent), or every
// force scaled by 1 + this fraction (a sign-correct answer at another level).
constexpr double kChangedAnswerMove = 1e-3;
constexpr double kChangedAnswerScale = 1e-2;
// An alternating scheme held at the cap on a standing scene ends at most this
// many times Eq. 5's optimal change (measured 1.61 and 1.64 on
// prism-6-gravity-noise5-s6, rounded up).
constexpr double kHeldAlternatingRatio = 1.7;

struct Reference {
  std::string name, file;
  bool gravity = false;
  // The scene already stands (Eq. 4 at its geometry): the driver returns it
  // unchanged and the reference forces are the unique sign-correct ones.
  bool stands = false;
  double geometry_change = 0.0;  // m
  Eigen::Matrix3Xd positions;    // m
  Eigen::VectorXd forces;        // N
  // Elements between two fixed nodes: in no part and not in Eq. 5 (sign only).
  std::vector<int> unattached_elements;
  // For a scene that stands: Eq. 5's optimum, what a backend run without the
  // driver's shortcut must reach when it solves Eq. 5 (change 0 otherwise).
  double direct_geometry_change = 0.0;  // m
  Eigen::Matrix3Xd direct_positions;    // m
  Eigen::VectorXd direct_forces;        // N
  std::vector<int> direct_active_bounds;
};

Eigen::Matrix3Xd read_positions(const nlohmann::json& x) {
  Eigen::Matrix3Xd p(3, static_cast<Eigen::Index>(x.size()));
  for (std::size_t i = 0; i < x.size(); ++i)
    for (int k = 0; k < 3; ++k) p(k, static_cast<Eigen::Index>(i)) = x[i][k].get<double>();
  return p;
}

Eigen::VectorXd read_forces(const nlohmann::json& f) {
  Eigen::VectorXd v(static_cast<Eigen::Index>(f.size()));
  for (std::size_t e = 0; e < f.size(); ++e) v[static_cast<Eigen::Index>(e)] = f[e].get<double>();
  return v;
}

std::vector<Reference> load_references() {
  const nlohmann::json j = read_json_file(kReferenceDir + "optima.json");
  std::vector<Reference> refs;
  for (const auto& s : j.at("scenes")) {
    Reference& r = refs.emplace_back();
    r.name = s.at("name").get<std::string>();
    r.file = s.at("file").get<std::string>();
    r.gravity = s.at("gravity").get<bool>();
    r.stands = s.value("stands", false);
    r.unattached_elements = s.value("unattached_elements", std::vector<int>{});
    r.geometry_change = s.at("geometry_change").get<double>();
    r.positions = read_positions(s.at("positions"));
    r.forces = read_forces(s.at("forces"));
    if (s.contains("eq5_without_shortcut")) {
      const auto& d = s.at("eq5_without_shortcut");
      r.direct_geometry_change = d.at("geometry_change").get<double>();
      r.direct_positions = read_positions(d.at("positions"));
      r.direct_forces = read_forces(d.at("forces"));
      r.direct_active_bounds = d.at("active_bounds").get<std::vector<int>>();
    }
  }
  return refs;
}

const std::vector<Reference>& references() {
  static const std::vector<Reference> refs = load_references();
  return refs;
}

// What a backend must reach on a scene. Eq. 5 solvers must reach the reference
// optimum (eq5-newton polishes alternating-gn's answer into one); the
// alternating schemes approximate it, and their ratios of geometry change to
// the reference's are written per scene, measured with
// `conformance_test --gtest_filter='*alternating*'` (printed "ratio"), the
// largest rounded up and, where a scheme ends below the optimum, the smallest
// rounded down.
struct Expectation {
  Status status = Status::Converged;
  bool same_optimum = false;                               // ipopt, nlopt
  double min_ratio_to_reference = 1.0 - kBeatsOptimumSlack;  // geometry change / reference's
  double max_ratio_to_reference = 1.0;
};

// The measured range of one alternating scheme's ratio on one scene.
struct RatioBounds {
  double max = 1.0;
  double min = 1.0 - kBeatsOptimumSlack;
};

struct AlternatingBounds {
  RatioBounds alternating, alternating_gn;
};

// Per scene. Scenes that stand have no ratio (reference change 0): every
// backend must return them unchanged. Under gravity the alternating schemes
// keep the mean cable force at most the part's weight, as Eq. 5 does
// (docs/THEORY-force-scale.md): free first, and held at the cap when their
// free answer lies above it.
const std::map<std::string, AlternatingBounds>& alternating_ratio_bounds() {
  static const std::map<std::string, AlternatingBounds> table = {
      // scene, {alternating, alternating-gn}
      // Gravity: the geometry has a self-stress, so the force level hardly
      // binds; alternating-gn ends at Eq. 5's geometry (within 7e-7 of the
      // mean element length) with mean cable force 0.61 W, its ratio a hair below 1.
      {"octahedron-gravity-noise5-s8", {{1.15}, {1.0001, 0.99999}}},  // measured 1.1422, 0.99999955
      {"octahedron-noise1-s4", {{1.02}, {1.0001}}},  // measured 1.0013, 0.9999998
      {"octahedron-noise5-s3", {{1.09}, {1.0001}}},  // measured 1.0798, 1.0000000
      {"prism-10-twist10", {{1.02}, {1.0001}}},  // measured 1.0070, 1.0000000
      {"prism-12-noise5-s23", {{1.06}, {1.0001}}},  // measured 1.0412, 1.0000000
      {"prism-12-twist10", {{1.02}, {1.0001}}},  // measured 1.0034, 1.0000000
      // Gravity, statically determinate: the geometry fixes the force level.
      // Left free, both schemes end at equilibria above the cap (mean cable
      // force 3.2 W, 1.9 W); held at it, they end at Eq. 5's optimum.
      {"prism-3-gravity-noise1-s5", {{1.01}, {1.0001}}},  // measured 1.0028, 1.0000001
      {"prism-3-noise5-s14", {{1.14}, {1.0001}}},  // measured 1.1294, 1.0000000
      {"prism-3-twist10", {{1.02}, {1.0001}}},  // measured 1.0079, 1.0000000
      {"prism-3-twist15-twice", {{1.03}, {1.0001}}},  // measured 1.0103, 1.0000000
      {"prism-4-noise15-s7", {{1.08}, {1.0001}}},  // measured 1.0641, 1.0000053
      {"prism-4-twist10", {{1.02}, {1.0001}}},  // measured 1.0050, 1.0000000
      {"prism-4-twist10-gravity", {}},  // stands: unchanged by every backend
      {"prism-5-twist10", {{1.03}, {1.0001}}},  // measured 1.0191, 1.0000000
      {"prism-5-twist20", {{1.03}, {1.0001}}},  // measured 1.0145, 1.0000000
      {"prism-6-gravity-noise5-s6", {}},  // stands: unchanged by every backend
      {"prism-6-noise5-s17", {{1.10}, {1.0001}}},  // measured 1.0855, 1.0000000
      {"prism-6-twist10", {{1.02}, {1.0001}}},  // measured 1.0082, 1.0000000
      {"prism-8-twist10", {{1.02}, {1.0001}}},  // measured 1.0088, 1.0000000
  };
  return table;
}

Expectation expectation(const std::string& backend, const std::string& scene) {
  Expectation x;
  if (backend == "ipopt" || backend == "nlopt" || backend == "eq5-newton") {
    x.same_optimum = true;
    x.max_ratio_to_reference = 1.0 + kSameOptimumGeometryChange;
    return x;
  }
  const auto& table = alternating_ratio_bounds();
  const auto it = table.find(scene);
  if (it == table.end()) {
    ADD_FAILURE() << "no expectation for " << backend << " on " << scene;
    return x;
  }
  const RatioBounds& bounds = backend == "alternating" ? it->second.alternating : it->second.alternating_gn;
  x.min_ratio_to_reference = bounds.min;
  x.max_ratio_to_reference = bounds.max;
  return x;
}

// Equilibrium recomputed from the formula of docs/FORMATS.md (Solution file): the largest net force on
// a free node divided by the load scale (largest free-node weight, else the
// largest |force|).
double relative_residual(const Structure& scene, const Eigen::Matrix3Xd& x, const Eigen::VectorXd& forces) {
  const int n = scene.num_nodes();
  Eigen::VectorXd mass = scene.node_mass;
  for (const Element& e : scene.elements) {
    mass[e.a] += 0.5 * e.mass;
    mass[e.b] += 0.5 * e.mass;
  }
  Eigen::Matrix3Xd net = scene.gravity * mass.transpose();
  for (int k = 0; k < scene.num_elements(); ++k) {
    const Element& e = scene.elements[k];
    const Eigen::Vector3d u = (x.col(e.b) - x.col(e.a)).normalized();
    net.col(e.a) += forces[k] * u;
    net.col(e.b) -= forces[k] * u;
  }
  double residual = 0.0, weight = 0.0;
  for (int i = 0; i < n; ++i) {
    if (scene.fixed[i]) continue;
    residual = std::max(residual, net.col(i).norm());
    weight = std::max(weight, mass[i] * scene.gravity.norm());
  }
  const double scale = weight > 0.0 ? weight : forces.cwiseAbs().maxCoeff();
  return residual / scale;
}

// F0 of the force-scale convention for a scene made of equal parts: the
// free-node weight per part with gravity, else 1 N.
double reference_force(const Structure& scene, int parts) {
  if (!scene.has_gravity()) return 1.0;
  Eigen::VectorXd mass = scene.node_mass;
  for (const Element& e : scene.elements) {
    mass[e.a] += 0.5 * e.mass;
    mass[e.b] += 0.5 * e.mass;
  }
  double weight = 0.0;
  for (int i = 0; i < scene.num_nodes(); ++i)
    if (!scene.fixed[i]) weight += mass[i] * scene.gravity.norm();
  return weight / parts;
}

// The mean force over every cable of the scene (N).
double mean_cable_force_of(const Structure& scene, const Eigen::VectorXd& forces) {
  double sum = 0.0;
  int cables = 0;
  for (int e = 0; e < scene.num_elements(); ++e)
    if (scene.elements[e].kind == ElementKind::Cable) sum += forces[e], ++cables;
  return sum / cables;
}

struct Case {
  std::string backend;
  int reference;
};

// A different answer, consistent in itself: the checks below must catch it.
void change_answer(const Structure& scene, SolveResult& r) {
  if (g_answer_change == AnswerChange::Scale) {
    r.forces *= 1.0 + kChangedAnswerScale;
    return;
  }
  for (int i = 0; i < scene.num_nodes(); ++i) {
    if (scene.fixed[i]) continue;
    r.positions(0, i) += kChangedAnswerMove * scene.mean_element_length();
    break;
  }
  r.stats.geometry_change = (r.positions - scene.positions).norm();
}

std::vector<Case> all_cases() {
  std::vector<Case> cases;
  for (const auto& backend : solver_names())
    for (int k = 0; k < static_cast<int>(references().size()); ++k) cases.push_back({backend, k});
  return cases;
}

class Conformance : public ::testing::TestWithParam<Case> {};

TEST_P(Conformance, MatchesTheReferenceOptimum) {
  const Case c = GetParam();
  const Reference& ref = references()[c.reference];
  const Structure scene = read_scene_file(kReferenceDir + "scenes/" + ref.file);
  const Expectation expected = expectation(c.backend, ref.name);
  SolveOptions options;
  options.prestress_factor = kPrestressFactor;  // the references' cap
  options.time_limit_s = 60.0;
  // The references hold the mean cable force at W under gravity; eq5-newton's
  // default, and ipopt's from eq5-newton's answer, only cap it (where the cap
  // does not bind, the forces differ by a self-stress), so it is held here;
  // the cap is tested below.
  if (c.backend == "eq5-newton" || c.backend == "ipopt") options.backend_options = {{"prestress", "equal"}};
  SolveResult r = make_solver(c.backend)->Solve(scene, options);
  if (g_answer_change != AnswerChange::None) {
    if (expected.status != Status::Converged) GTEST_SKIP() << "no answer to change";
    change_answer(scene, r);
  }
  ASSERT_EQ(r.status, expected.status) << r.message;
  ASSERT_EQ(r.positions.cols(), scene.num_nodes());
  ASSERT_EQ(r.forces.size(), scene.num_elements());
  ASSERT_TRUE(r.positions.allFinite() && r.forces.allFinite());
  if (expected.status != Status::Converged) return;

  // (a) Equilibrium, recomputed here.
  EXPECT_LE(relative_residual(scene, r.positions, r.forces), kEquilibriumTolerance);

  // (b) Signs with the margin; fixed nodes copied bit for bit.
  const int parts = ref.name.find("-twice") != std::string::npos ? 2 : 1;
  const double f0 = reference_force(scene, parts);
  const double margin = kMarginFraction * f0 * (1.0 - kMarginSlack);
  for (int e = 0; e < scene.num_elements(); ++e) {
    if (scene.elements[e].kind == ElementKind::Cable) {
      EXPECT_GE(r.forces[e], margin) << "cable " << e;
    } else {
      EXPECT_LE(r.forces[e], -margin) << "strut " << e;
    }
  }
  for (int i = 0; i < scene.num_nodes(); ++i) {
    if (scene.fixed[i]) {
      EXPECT_TRUE(r.positions.col(i) == scene.positions.col(i)) << "fixed node " << i;
    }
  }

  // The force scale: the mean force of the cables in parts is F0 (equal parts)
  // without gravity, and Eq. 5 holds it at the weight W = F0 under gravity.
  std::vector<bool> in_eq5(scene.num_elements(), true);
  for (int e : ref.unattached_elements) in_eq5[e] = false;
  double cable_sum = 0.0;
  int cables = 0;
  for (int e = 0; e < scene.num_elements(); ++e)
    if (in_eq5[e] && scene.elements[e].kind == ElementKind::Cable) cable_sum += r.forces[e], ++cables;
  const double mean_cable_force = cable_sum / cables;
  if (!scene.has_gravity() || (expected.same_optimum && !ref.stands)) {
    EXPECT_NEAR(mean_cable_force, f0, 1e-6 * f0);
  }

  // (c) Geometry change against the reference optimum.
  const double change = (r.positions - scene.positions).norm();
  EXPECT_NEAR(r.stats.geometry_change, change, 1e-12 * (1.0 + change)) << "stats disagree with the positions";
  double force_difference = 0.0;  // largest over the elements of Eq. 5, relative to the largest reference force
  for (int e = 0; e < scene.num_elements(); ++e)
    if (in_eq5[e]) force_difference = std::max(force_difference, std::abs(r.forces[e] - ref.forces[e]));
  force_difference /= ref.forces.cwiseAbs().maxCoeff();
  const double length = scene.mean_element_length();
  const double position_difference = (r.positions - ref.positions).colwise().norm().maxCoeff() / length;
  const double ratio = ref.stands ? 0.0 : change / ref.geometry_change;
  std::printf("%-15s %-30s geometry change %.12g m, reference %.12g m, ratio %.8f, mean cable force / F0 %.6f, "
              "differences: positions %.1e, forces %.1e\n",
              c.backend.c_str(), ref.name.c_str(), change, ref.geometry_change, ratio, mean_cable_force / f0,
              position_difference, force_difference);
  if (ref.stands) {
    // Returned unchanged, with the unique forces that balance the scene.
    EXPECT_EQ(change, 0.0);
    EXPECT_LE(force_difference, kStandingForce);
    return;
  }
  EXPECT_GE(ratio, expected.min_ratio_to_reference) << "better than the reference optimum";
  EXPECT_LE(ratio, expected.max_ratio_to_reference);
  if (expected.same_optimum) {
    EXPECT_LE(position_difference, kSameOptimumPosition);
    EXPECT_LE(force_difference, kSameOptimumForce);
  }
}

std::string case_name(const ::testing::TestParamInfo<Case>& info) {
  std::string s = info.param.backend + "_" + references()[info.param.reference].name;
  for (char& ch : s)
    if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
  return s;
}

INSTANTIATE_TEST_SUITE_P(AllBackends, Conformance, ::testing::ValuesIn(all_cases()), case_name);

std::vector<Case> standing_cases() {
  std::vector<Case> cases;
  for (const Case& c : all_cases())
    if (references()[c.reference].stands) cases.push_back(c);
  return cases;
}

class ConformanceWithoutShortcut : public ::testing::TestWithParam<Case> {};

// A scene that stands, solved without the driver's shortcut: the Eq. 5 solvers
// must reach Eq. 5's optimum, which holds the mean cable force at W and so
// moves the scene. The alternating schemes find the scene balanced at its own
// force level; where that level is above the cap they solve again held at the
// cap, and must then keep the cap without beating the optimum (they do not
// minimise the change); below it they must not move the scene.
TEST_P(ConformanceWithoutShortcut, ReachesEq5OrKeepsTheScene) {
  const Case c = GetParam();
  const Reference& ref = references()[c.reference];
  const Structure scene = read_scene_file(kReferenceDir + "scenes/" + ref.file);
  SolveOptions options;
  options.prestress_factor = kPrestressFactor;  // the references' cap
  options.time_limit_s = 60.0;
  // The reference holds the mean cable force at W: so must ipopt and
  // eq5-newton here (their default only caps it; the next test checks that).
  if (c.backend == "ipopt" || c.backend == "eq5-newton") options.backend_options = {{"prestress", "equal"}};
  const SolveResult r = make_solver(c.backend)->Solve(scene, options, DriverControls{false});
  ASSERT_EQ(r.status, Status::Converged) << r.message;
  ASSERT_TRUE(r.positions.allFinite() && r.forces.allFinite());
  EXPECT_LE(relative_residual(scene, r.positions, r.forces), kEquilibriumTolerance);
  const double f0 = reference_force(scene, 1);
  const double margin = kMarginFraction * f0;
  for (int e = 0; e < scene.num_elements(); ++e) {
    if (scene.elements[e].kind == ElementKind::Cable) {
      EXPECT_GE(r.forces[e], margin * (1.0 - kMarginSlack)) << "cable " << e;
    } else {
      EXPECT_LE(r.forces[e], -margin * (1.0 - kMarginSlack)) << "strut " << e;
    }
  }
  const double change = (r.positions - scene.positions).norm();
  const bool solves_eq5 = expectation(c.backend, ref.name).same_optimum;
  const double own_level = mean_cable_force_of(scene, ref.forces) / f0;
  const bool above_cap = own_level > kPrestressFactor;
  const double expected_change = solves_eq5 || above_cap ? ref.direct_geometry_change : 0.0;
  std::printf("%-15s %-30s without the shortcut: geometry change %.12g m, expected %.12g m (scene's level %.3f W)\n",
              c.backend.c_str(), ref.name.c_str(), change, expected_change, own_level);
  if (!solves_eq5) {
    if (!above_cap) {
      EXPECT_EQ(change, 0.0);
      return;
    }
    EXPECT_LE(mean_cable_force_of(scene, r.forces), f0 * (1.0 + kCapSlack)) << "above the cap";
    EXPECT_GE(change / expected_change, 1.0 - kBeatsOptimumSlack) << "better than the reference optimum";
    EXPECT_LE(change / expected_change, kHeldAlternatingRatio);
    return;
  }
  EXPECT_GE(change / expected_change, 1.0 - kBeatsOptimumSlack) << "better than the reference optimum";
  EXPECT_LE(change / expected_change, 1.0 + kSameOptimumGeometryChange);
  std::vector<bool> in_eq5(scene.num_elements(), true);
  for (int e : ref.unattached_elements) in_eq5[e] = false;
  double cable_sum = 0.0, force_difference = 0.0;
  int cables = 0;
  for (int e = 0; e < scene.num_elements(); ++e) {
    if (!in_eq5[e]) continue;
    force_difference = std::max(force_difference, std::abs(r.forces[e] - ref.direct_forces[e]));
    if (scene.elements[e].kind == ElementKind::Cable) cable_sum += r.forces[e], ++cables;
  }
  force_difference /= ref.direct_forces.cwiseAbs().maxCoeff();
  const double position_difference =
      (r.positions - ref.direct_positions).colwise().norm().maxCoeff() / scene.mean_element_length();
  std::printf("%-15s %-30s without the shortcut: ratio %.8f, differences: positions %.1e, forces %.1e\n",
              c.backend.c_str(), ref.name.c_str(), change / expected_change, position_difference, force_difference);
  EXPECT_LE(force_difference, kSameOptimumForce);
  EXPECT_LE(position_difference, kSameOptimumPosition);
  EXPECT_NEAR(cable_sum / cables, f0, 1e-6 * f0) << "mean cable force";
  // The sign bounds active at the optimum hold their force at the margin.
  for (int e : ref.direct_active_bounds) {
    std::printf("%-15s %-30s without the shortcut: element %d at the margin: force / margin %.9f\n",
                c.backend.c_str(), ref.name.c_str(), e, std::abs(r.forces[e]) / margin);
    EXPECT_NEAR(std::abs(r.forces[e]), margin, kActiveBound * margin) << e;
  }
}

INSTANTIATE_TEST_SUITE_P(StandingScenes, ConformanceWithoutShortcut, ::testing::ValuesIn(standing_cases()),
                         case_name);

// ipopt's and eq5-newton's default caps the mean cable force at W instead of
// holding it there: on a scene that stands it never ends farther than the held
// optimum, and where the scene stands below W (prism-4-twist10-gravity) it
// keeps the scene.
TEST(ConformanceWithoutShortcutPrestressCap, NeverFartherThanTheHeldOptimum) {
  for (const Case& c : standing_cases()) {
    if (c.backend != "ipopt" && c.backend != "eq5-newton") continue;
    const Reference& ref = references()[c.reference];
    const Structure scene = read_scene_file(kReferenceDir + "scenes/" + ref.file);
    SolveOptions options;
    options.prestress_factor = kPrestressFactor;  // the references' cap
    options.time_limit_s = 60.0;
    const SolveResult r = make_solver(c.backend)->Solve(scene, options, DriverControls{false});
    ASSERT_EQ(r.status, Status::Converged) << ref.name << ": " << r.message;
    EXPECT_LE(relative_residual(scene, r.positions, r.forces), kEquilibriumTolerance) << ref.name;
    const double change = (r.positions - scene.positions).norm();
    std::printf("%-10s (cap) %-30s without the shortcut: geometry change %.12g m, held optimum %.12g m\n",
                c.backend.c_str(), ref.name.c_str(), change, ref.direct_geometry_change);
    EXPECT_LE(change, ref.direct_geometry_change * (1.0 + kSameOptimumGeometryChange)) << ref.name;
    double cable_sum = 0.0;
    int cables = 0;
    for (int e = 0; e < scene.num_elements(); ++e)
      if (scene.elements[e].kind == ElementKind::Cable) cable_sum += r.forces[e], ++cables;
    const double f0 = reference_force(scene, 1);
    if (ref.name == "prism-4-twist10-gravity") {
      EXPECT_LT(change, 1e-6 * ref.direct_geometry_change) << ref.name;
    }
    if (ref.unattached_elements.empty()) {
      EXPECT_LE(cable_sum / cables, f0 * (1.0 + 1e-6)) << ref.name;
    }
  }
}

// Under gravity, on the scenes that do not stand, eq5-newton's default (the
// mean cable force at most W) ends no farther than the held reference optimum
// and keeps the cap; where the cap binds it is the held optimum.
TEST(ConformancePrestressCap, Eq5NewtonNeverFartherThanTheHeldOptimum) {
  int compared = 0;
  for (const Reference& ref : references()) {
    const Structure scene = read_scene_file(kReferenceDir + "scenes/" + ref.file);
    if (!scene.has_gravity() || ref.stands) continue;
    SolveOptions options;
    options.prestress_factor = kPrestressFactor;  // the references' cap
    const SolveResult r = make_solver("eq5-newton")->Solve(scene, options);
    ASSERT_EQ(r.status, Status::Converged) << ref.name << ": " << r.message;
    EXPECT_LE(relative_residual(scene, r.positions, r.forces), kEquilibriumTolerance) << ref.name;
    const double change = (r.positions - scene.positions).norm();
    const double level = mean_cable_force_of(scene, r.forces) / reference_force(scene, 1);
    std::printf("eq5-newton (cap) %-30s geometry change %.12g m, held optimum %.12g m, mean cable force / W %.6f\n",
                ref.name.c_str(), change, ref.geometry_change, level);
    EXPECT_LE(change, ref.geometry_change * (1.0 + kSameOptimumGeometryChange)) << ref.name;
    EXPECT_GE(change, ref.geometry_change * (1.0 - kBeatsOptimumSlack)) << ref.name << ": a local optimum below it";
    EXPECT_LE(level, 1.0 + kCapSlack) << ref.name;
    ++compared;
  }
  EXPECT_GT(compared, 0);
}

// The committed scenes are the suite's scenes, bit for bit (a change of a
// generator or of the perturbation must come with new references).
TEST(ConformanceScenes, CommittedScenesAreTheSuiteScenes) {
  const auto suite = scenes::backend_suite_scenes();
  ASSERT_EQ(suite.size(), references().size());
  for (const Structure& s : suite) {
    const auto it = std::find_if(references().begin(), references().end(),
                                 [&](const Reference& r) { return r.name == s.name; });
    ASSERT_NE(it, references().end()) << s.name;
    const Structure committed = read_scene_file(kReferenceDir + "scenes/" + it->file);
    EXPECT_TRUE(committed.positions == s.positions) << s.name;
    EXPECT_EQ(committed.num_elements(), s.num_elements()) << s.name;
  }
}

// Every backend, run without the driver's shortcut, must not move a scene
// that already is a tensegrity.
TEST(ConformanceEquilibrium, SceneAlreadyInEquilibriumIsReturnedUnchanged) {
  for (const auto& name : solver_names()) {
    const auto solver = make_solver(name);
    for (const Structure& scene : {scenes::prism(3), scenes::prism(7), scenes::octahedron()}) {
      const SolveResult r = solver->Solve(scene, SolveOptions{}, DriverControls{false});
      ASSERT_EQ(r.status, Status::Converged) << name << " " << scene.name << ": " << r.message;
      EXPECT_LE((r.positions - scene.positions).norm(), 1e-10 * scene.mean_element_length())
          << name << " " << scene.name;
      EXPECT_LE(relative_residual(scene, r.positions, r.forces), kEquilibriumTolerance) << name << " " << scene.name;
    }
  }
}

int dump_scenes(const std::string& dir) {
  for (const Structure& s : scenes::backend_suite_scenes()) {
    write_scene_file(s, dir + "/" + s.name + ".scene.json");
    std::printf("%s\n", s.name.c_str());
  }
  return 0;
}

// The self-check passes when no judged case passes and at least one failed.
int run_with_changed_answers(const char* mode) {
  if (std::strcmp(mode, "move") == 0) {
    g_answer_change = AnswerChange::Move;
  } else if (std::strcmp(mode, "scale") == 0) {
    g_answer_change = AnswerChange::Scale;
  } else {
    std::fprintf(stderr, "conformance_test: --change-answers %s: expected move or scale\n", mode);
    return 2;
  }
  ::testing::GTEST_FLAG(filter) = "AllBackends/Conformance.*";
  const bool every_case_passed = RUN_ALL_TESTS() == 0;
  const ::testing::UnitTest& run = *::testing::UnitTest::GetInstance();
  std::printf("changed answers (%s): %d judged cases failed, %d passed, %d skipped\n", mode,
              run.failed_test_count(), run.successful_test_count(), run.skipped_test_count());
  return !every_case_passed && run.successful_test_count() == 0 && run.failed_test_count() > 0 ? 0 : 1;
}

}  // namespace
}  // namespace tensegrity

int main(int argc, char** argv) {
  if (argc == 3 && std::strcmp(argv[1], "--dump-scenes") == 0) return tensegrity::dump_scenes(argv[2]);
  ::testing::InitGoogleTest(&argc, argv);
  if (argc == 3 && std::strcmp(argv[1], "--change-answers") == 0)
    return tensegrity::run_with_changed_answers(argv[2]);
  return RUN_ALL_TESTS();
}
