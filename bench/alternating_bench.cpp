// Both alternating backends on the perturbed reference structures and on the
// large tower (80 struts / 500 cables), with and without gravity.
//
//   build/bench/alternating_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
//
// Counters: outer iterations, final relative residual, the time at which the
// trace first reaches relative residual 1e-8 (s), the geometry change (units
// of the mean element length) and converged (1/0).
//
// The cost of one outer iteration of the faithful scheme (Algorithm 1 with its
// default options), without the driver's equilibrium shortcut, on the first
// 2000 outer iterations of the 80-strut / 500-cable gravity tower with 2 %
// node noise and of the scorpion character with 5 % node noise (seed 2); with
// 2 % noise the scorpion is a tensegrity at its input geometry (one stress
// solve, no outer iteration), which the third case shows (docs/BACKENDS.md,
// "Cost of an outer iteration"):
//
//   build/bench/alternating_bench --benchmark_filter='^faithful-outer-iteration/'
//       --benchmark_repetitions=3 --benchmark_report_aggregates_only=true   (one line)
//
// Counters: seconds_per_outer_iteration (the solve's CPU time over its outer
// iterations), and outer_iterations, stress_solves and geometry_change_m,
// which are the same from one build to the next when the iterates are.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "model/character.hpp"
#include "model/reference_scenes.hpp"
#include "scenes/perturb.hpp"
#include "scenes/suites.hpp"
#include "scenes/towers.hpp"
#include "solvers/alternating/alternating_solver.hpp"

namespace tensegrity {
namespace {

// Free nodes moved by up to `noise` times the first element's length (a strut
// in these scenes), componentwise uniform.
Structure perturbed(Structure s, double noise, unsigned seed) {
  scenes::NodeNoise n;
  n.fraction = noise;
  n.length = scenes::LengthMeasure::FirstElement;
  n.shape = scenes::NoiseShape::Cube;
  return scenes::with_node_noise(std::move(s), n, seed);
}

Structure prism_scene(int n, bool gravity) {
  PrismParameters p;
  p.n = n;
  p.twist_offset = 10.0 * M_PI / 180.0;
  if (gravity) {
    p.gravity = p.fix_bottom = true;
    p.strut_mass = 0.1;
    p.cable_mass = 0.01;
  }
  Structure s = perturbed(make_regular_prism(p), 0.05, 17 * n);
  s.name += gravity ? "-gravity" : "";
  return s;
}

Structure octahedron_scene(bool gravity) {
  OctahedronParameters p;
  if (gravity) {
    p.gravity = p.fix_bottom = true;
    p.strut_mass = 0.1;
    p.cable_mass = 0.01;
  }
  Structure s = perturbed(make_expandable_octahedron(p), 0.05, 23);
  s.name += gravity ? "-gravity" : "";
  return s;
}

Structure tower_scene(bool gravity) {
  return scenes::perturbed_tower(std::string(TENSEGRITY_SOURCE_DIR) + "/data", gravity);
}

void run(benchmark::State& state, bool gauss_newton, const Structure& scene) {
  const auto solver = make_solver(gauss_newton ? "alternating-gn" : "alternating");
  SolveOptions options;
  if (!gauss_newton && scene.num_elements() > 100) options.time_limit_s = 30.0;
  SolveResult r;
  for (auto _ : state) {
    r = solver->Solve(scene, options, DriverControls{false});
    benchmark::DoNotOptimize(r.forces.data());
  }
  double time_to_tolerance = NAN;
  for (const TracePoint& p : r.trace)
    if (p.relative_residual <= 1e-8) {
      time_to_tolerance = p.seconds;
      break;
    }
  state.counters["outer_iterations"] = r.stats.iterations;
  state.counters["relative_residual"] = r.stats.relative_residual;
  state.counters["time_to_1e-8_s"] = time_to_tolerance;
  state.counters["geometry_change_L"] = r.stats.geometry_change / scene.mean_element_length();
  state.counters["converged"] = r.status == Status::Converged ? 1.0 : 0.0;
  state.SetLabel(std::string(to_string(r.status)));
}

// A whole faithful solve per benchmark iteration, capped at state.range(0)
// outer iterations (0: the backend's own budget).
void run_faithful_outer_iterations(benchmark::State& state, const Structure& scene) {
  const auto solver = make_solver("alternating");
  SolveOptions options;
  options.max_iterations = static_cast<int>(state.range(0));
  options.time_limit_s = 600.0;  // the run ends on its own or at the cap, never on the clock
  SolveResult r;
  for (auto _ : state) {
    r = solver->Solve(scene, options, DriverControls{false});
    benchmark::DoNotOptimize(r.forces.data());
  }
  int stress_solves = 0;
  for (const auto& d : r.details)
    if (const auto* a = dynamic_cast<const AlternatingDetails*>(d.get())) stress_solves += a->stress_solves;
  state.counters["seconds_per_outer_iteration"] = benchmark::Counter(
      static_cast<double>(std::max(1, r.stats.iterations)),
      benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
  state.counters["outer_iterations"] = r.stats.iterations;
  state.counters["stress_solves"] = stress_solves;
  state.counters["geometry_change_m"] = r.stats.geometry_change;
  state.SetLabel(std::string(to_string(r.status)));
}

// The scenes of the faithful cost benchmark and their outer-iteration caps.
const std::vector<std::pair<Structure, int>>& faithful_scenes() {
  static const std::vector<std::pair<Structure, int>> all = [] {
    const std::string data = std::string(TENSEGRITY_SOURCE_DIR) + "/data";
    Structure scorpion = build_character_file(data + "/characters/scorpion.character.json").structure;
    scorpion.name = "scorpion";
    Structure tower = scenes::perturbed_tower(data, true);
    tower.name = "tower-80s-500c-gravity-noise2-s1";
    constexpr int kCap = 2000;
    return std::vector<std::pair<Structure, int>>{
        {tower, kCap}, {scenes::perturbed(scorpion, 0.05, 2u), kCap}, {scenes::perturbed(scorpion, 0.02, 1u), 0}};
  }();
  return all;
}

const std::vector<Structure>& scenes() {
  static const std::vector<Structure> all = [] {
    std::vector<Structure> s;
    for (int n : {3, 6, 12}) s.push_back(prism_scene(n, false));
    s.push_back(prism_scene(6, true));
    s.push_back(octahedron_scene(false));
    s.push_back(octahedron_scene(true));
    s.push_back(tower_scene(false));
    s.push_back(tower_scene(true));
    return s;
  }();
  return all;
}

const bool registered = [] {
  for (const Structure& scene : scenes())
    for (bool gn : {true, false}) {
      const std::string name = std::string(gn ? "alternating-gn/" : "alternating/") + scene.name;
      auto* b = benchmark::RegisterBenchmark(name.c_str(), [gn, &scene](benchmark::State& state) {
        run(state, gn, scene);
      });
      b->Unit(benchmark::kMillisecond);
      if (!gn && scene.num_elements() > 100) b->Iterations(1);  // the faithful scheme is slow there
    }
  for (const auto& [scene, cap] : faithful_scenes()) {
    const std::string name = "faithful-outer-iteration/" + scene.name;
    benchmark::RegisterBenchmark(name.c_str(), [&scene = scene](benchmark::State& state) {
      run_faithful_outer_iterations(state, scene);
    })->Arg(cap)->Unit(benchmark::kMillisecond)->Iterations(1);
  }
  return true;
}();

}  // namespace
}  // namespace tensegrity

BENCHMARK_MAIN();
