// The faithful scheme (Algorithm 1, backend `alternating`) takes the same
// iterates as the version its speed work started from: on fixed perturbed
// scenes the outer-iteration count, the number of stress solves and the
// status are equal to recorded reference values and the geometry change (and,
// on a run stopped by its budget, Eq. 4's final objective) equal them to 1e-12
// relative. The references were
// recorded from the implementation before its per-iteration costs were cut
// (docs/BACKENDS.md, "Cost of an outer iteration"); a change of the
// arithmetic order anywhere in the outer loop shows up here.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "model/character.hpp"
#include "model/reference_scenes.hpp"
#include "scenes/perturb.hpp"
#include "scenes/suites.hpp"
#include "scenes/towers.hpp"
#include "solvers/alternating/alternating_solver.hpp"
#include "solvers/solver.hpp"

namespace tensegrity {
namespace {

Structure perturbed_prism(int n, double twist_degrees, bool gravity, double noise, unsigned seed) {
  PrismParameters p;
  p.n = n;
  p.twist_offset = twist_degrees * M_PI / 180.0;
  if (gravity) {
    p.gravity = p.fix_bottom = true;
    p.strut_mass = 0.1;
    p.cable_mass = 0.01;
  }
  scenes::NodeNoise n_noise;
  n_noise.fraction = noise;
  n_noise.length = scenes::LengthMeasure::MeanStrut;
  n_noise.shape = scenes::NoiseShape::Cube;
  return scenes::with_node_noise(make_regular_prism(p), n_noise, seed);
}

struct Reference {
  std::string name;
  Structure scene;
  int max_iterations;  // 0: the backend's own budget
  Status status;
  int iterations;
  int stress_solves;
  double geometry_change;  // m
  double objective;        // Eq. 4's objective at the end (N^2)
};

std::vector<Reference> references() {
  const std::string data = std::string(TENSEGRITY_SOURCE_DIR) + "/data";
  const Structure scorpion = build_character_file(data + "/characters/scorpion.character.json").structure;
  return {
      // Crawls (SDC steps from outer iteration 275, as alternating_solver_test checks), then converges.
      {"prism-9 noise 0.15 twist 15", perturbed_prism(9, 15.0, false, 0.15, 9153), 0, Status::Converged, 317, 318,
       0.73666035041146372, 0.0},
      // The scorpion character with 5 % node noise (seed 2), first 40 outer iterations.
      {"scorpion noise 0.05", scenes::perturbed(scorpion, 0.05, 2u), 40, Status::MaxIterations, 40, 41,
       0.00048075655533757848, 5.552005480775806e-05},
      // The 80-strut / 500-cable gravity tower, 2 % noise, first 60 outer iterations.
      {"tower-80s-500c-gravity noise 0.02", scenes::perturbed_tower(data, true), 60, Status::MaxIterations, 60, 61,
       0.092719393052425242, 2.1105960822242484},
  };
}

const AlternatingDetails& details_of(const SolveResult& r) {
  return dynamic_cast<const AlternatingDetails&>(*r.details.at(0));
}

TEST(FaithfulIterates, EqualTheRecordedReferences) {
  for (const Reference& ref : references()) {
    SCOPED_TRACE(ref.name);
    SolveOptions options;
    options.max_iterations = ref.max_iterations;
    options.time_limit_s = 600.0;  // the outer-iteration count, not the clock, ends these runs
    const SolveResult r = make_solver("alternating")->Solve(ref.scene, options, DriverControls{false});
    const double objective = r.trace.empty() ? NAN : r.trace.back().objective;
    std::printf("%s: %s iterations %d stress_solves %d geometry_change %.17g objective %.17g\n", ref.name.c_str(),
                std::string(to_string(r.status)).c_str(), r.stats.iterations, details_of(r).stress_solves, r.stats.geometry_change,
                objective);
    EXPECT_EQ(r.status, ref.status) << r.message;
    EXPECT_EQ(r.stats.iterations, ref.iterations);
    EXPECT_EQ(details_of(r).stress_solves, ref.stress_solves);
    EXPECT_NEAR(r.stats.geometry_change, ref.geometry_change, 1e-12 * ref.geometry_change);
    // A converged run's objective is at rounding level: only a run stopped by
    // its budget has one to compare.
    if (ref.status != Status::Converged) {
      EXPECT_NEAR(objective, ref.objective, 1e-12 * ref.objective);
    }
  }
}

}  // namespace
}  // namespace tensegrity
