// The `ipopt` backend with the exact Hessian against limited-memory (L-BFGS)
// on reference scenes and the 80-strut / 500-cable tower (bench/large_scenes.hpp).
// Counters: iterations, final relative residual, geometry change (m), converged.
// Each solve is capped at 30 s (time_limit_s).
// Run with
//   build/bench/ipopt_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
// (add --benchmark_out=ipopt.json --benchmark_out_format=json for the JSON).
// Every run prints one progress line to stderr.
#include <benchmark/benchmark.h>

#include <cstdio>
#include <string>
#include <vector>

#include "scenes/towers.hpp"
#include "model/verify.hpp"
#include "solvers/ipopt/ipopt_solver.hpp"
#include "scenes/suites.hpp"

namespace tensegrity {
namespace {

std::vector<Structure> bench_scenes() {
  std::vector<Structure> v;
  v.push_back(scenes::prism(6, 10.0));
  v.push_back(scenes::perturbed(scenes::octahedron(), 0.05, 3u));
  v.push_back(scenes::perturbed(scenes::prism(6, 0.0, true), 0.05, 6u));
  v.push_back(scenes::perturbed(scenes::octahedron(true), 0.05, 8u));
  v.push_back(scenes::perturbed_tower(std::string(TENSEGRITY_SOURCE_DIR) + "/data", false));
  v.push_back(scenes::perturbed_tower(std::string(TENSEGRITY_SOURCE_DIR) + "/data", true));
  return v;
}

void solve_with(benchmark::State& state, const Structure& scene, const std::string& hessian) {
  const IpoptSolver solver;
  SolveOptions options;
  options.time_limit_s = 30.0;  // limited-memory on the tower would take minutes
  options.backend_options["hessian_approximation"] = hessian;
  SolveResult r;
  for (auto _ : state) r = solver.Solve(scene, options, DriverControls{false});
  const Verification v = verify(scene, r.positions, r.forces, options.tolerance);
  state.counters["iterations"] = r.stats.iterations;
  state.counters["relative_residual"] = v.relative_residual;
  state.counters["geometry_change"] = v.geometry_change;
  state.counters["converged"] = r.status == Status::Converged && v.ok ? 1.0 : 0.0;
  std::fprintf(stderr, "[ipopt %s] %s: %s in %.3f s, %d iterations, rr %.2e, change %.6g\n", hessian.c_str(),
               scene.name.c_str(), std::string(to_string(r.status)).c_str(), r.stats.seconds,
               r.stats.iterations, v.relative_residual, v.geometry_change);
}

const bool kRegistered = [] {
  for (const Structure& scene : bench_scenes()) {
    for (const std::string hessian : {"exact", "limited-memory"}) {
      benchmark::RegisterBenchmark(("ipopt/" + hessian + "/" + scene.name).c_str(),
                                   [scene, hessian](benchmark::State& st) { solve_with(st, scene, hessian); })
          ->Unit(benchmark::kMillisecond)
          ->MeasureProcessCPUTime()
          ->UseRealTime();
    }
  }
  return true;
}();

}  // namespace
}  // namespace tensegrity

BENCHMARK_MAIN();
