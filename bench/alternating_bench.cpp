// Both alternating backends on the perturbed reference structures and on the
// large tower (80 struts / 500 cables), with and without gravity.
//
//   build/bench/alternating_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
//
// Counters: outer iterations, final relative residual, the time at which the
// trace first reaches relative residual 1e-8 (s), the geometry change (units
// of the mean element length) and converged (1/0).
#include <benchmark/benchmark.h>

#include <cmath>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "scenes/towers.hpp"
#include "model/reference_scenes.hpp"
#include "scenes/perturb.hpp"
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
  return true;
}();

}  // namespace
}  // namespace tensegrity

BENCHMARK_MAIN();
