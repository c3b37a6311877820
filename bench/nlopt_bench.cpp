// The NLopt algorithms of the `nlopt` backend on reference scenes and the
// 80-strut / 500-cable tower. Counters: evaluations, final relative residual,
// geometry change (m), its ratio to Ipopt's on the same scene (when the ipopt
// backend is registered and converges), and converged (1/0). Run with
//   build/bench/nlopt_bench --benchmark_out=nlopt.json --benchmark_out_format=json
// Repetitions give medians (`_median` rows); every run prints progress.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "scenes/towers.hpp"
#include "model/verify.hpp"
#include "solvers/nlopt/nlopt_solver.hpp"
#include "solvers/solver.hpp"
#include "scenes/suites.hpp"

namespace tensegrity {
namespace {

std::vector<Structure> bench_scenes() {
  std::vector<Structure> v;
  v.push_back(scenes::prism(6, 10.0));
  v.push_back(scenes::perturbed(scenes::prism(12), 0.05, 23u));
  v.push_back(scenes::perturbed(scenes::octahedron(), 0.05, 3u));
  v.push_back(scenes::perturbed(scenes::prism(6, 0.0, true), 0.05, 6u));
  v.push_back(scenes::perturbed(scenes::octahedron(true), 0.05, 8u));
  v.push_back(scenes::perturbed_tower(std::string(TENSEGRITY_SOURCE_DIR) + "/data", false));
  v.push_back(scenes::perturbed_tower(std::string(TENSEGRITY_SOURCE_DIR) + "/data", true));
  return v;
}

bool is_large(const Structure& s) { return s.num_elements() > 200; }

// Ipopt's geometry change per scene (0 when unavailable), computed once.
double ipopt_geometry_change(const Structure& scene) {
  static std::map<std::string, double> cache;
  auto it = cache.find(scene.name);
  if (it != cache.end()) return it->second;
  double change = 0.0;
  const auto names = solver_names();
  if (std::find(names.begin(), names.end(), "ipopt") != names.end()) {
    SolveOptions o;
    o.time_limit_s = 300.0;
    const SolveResult r = solve_scene(*make_solver("ipopt"), scene, o);
    if (r.status == Status::Converged) change = r.stats.geometry_change;
    std::fprintf(stderr, "[ipopt] %s: %s, geometry change %.9g\n", scene.name.c_str(),
                 std::string(to_string(r.status)).c_str(), r.stats.geometry_change);
  }
  cache[scene.name] = change;
  return change;
}

void solve_with(benchmark::State& state, const Structure& scene, const std::string& algorithm) {
  const NloptSolver solver;
  SolveOptions options;
  options.time_limit_s = is_large(scene) ? 60.0 : 30.0;
  options.backend_options["algorithm"] = algorithm;
  const double reference = ipopt_geometry_change(scene);
  SolveResult r;
  for (auto _ : state) r = solve_scene(solver, scene, options);
  const Verification v = verify(scene, r.positions, r.forces, options.tolerance);
  const int evaluations = r.trace.empty() ? 0 : r.trace.back().evaluations;
  state.counters["evaluations"] = evaluations;
  state.counters["relative_residual"] = v.relative_residual;
  state.counters["geometry_change"] = v.geometry_change;
  state.counters["ratio_to_ipopt"] = reference > 0.0 ? v.geometry_change / reference : 0.0;
  state.counters["converged"] = r.status == Status::Converged ? 1.0 : 0.0;
  std::fprintf(stderr, "[nlopt %s] %s: %s in %.3f s, %d evaluations, rr %.2e, change %.6g\n",
               algorithm.c_str(), scene.name.c_str(), std::string(to_string(r.status)).c_str(),
               r.stats.seconds, evaluations, v.relative_residual, v.geometry_change);
}

const std::vector<std::string> kAlgorithms = {"al-lbfgs",  "penalty-lbfgs", "al-tnewton",
                                              "auglag-eq-lbfgs", "slsqp", "al-mma", "al-ccsaq"};

// The slow variants (al-tnewton, al-mma, al-ccsaq) skip the tower.
bool runs_on_large(const std::string& algorithm) {
  return algorithm == "al-lbfgs" || algorithm == "penalty-lbfgs" || algorithm == "auglag-eq-lbfgs" ||
         algorithm == "slsqp";
}

int register_all() {
  static const std::vector<Structure> scenes = bench_scenes();
  for (const auto& algorithm : kAlgorithms) {
    for (const Structure& scene : scenes) {
      if (is_large(scene) && !runs_on_large(algorithm)) continue;
      auto* b = benchmark::RegisterBenchmark(
          ("nlopt/" + algorithm + "/" + scene.name).c_str(),
          [&scene, algorithm](benchmark::State& st) { solve_with(st, scene, algorithm); });
      b->Unit(benchmark::kMillisecond)->Iterations(1)->Repetitions(is_large(scene) ? 1 : 3);
      b->ReportAggregatesOnly(!is_large(scene));
    }
  }
  return 0;
}

const int registered = register_all();

}  // namespace
}  // namespace tensegrity

BENCHMARK_MAIN();
