// `eq5-newton` side by side with `alternating-gn` and `ipopt` (`ipopt-warm`
// from alternating-gn's equilibrium, `ipopt-auto` with start=auto; both with the default
// prestress=cap, as eq5-newton: the same Eq. 5, the mean cable force at most
// kappa W) on the gravity tower family and the 80-strut / 500-cable gravity tower.
//
// Tower family, L layers: `generate tower --layers L --struts-per-layer 8
// --cables 50L --gravity`, solved to equilibrium by alternating-gn, then 1 %
// node noise (scenes/gravity_tower_family.hpp, solved as compare_bench does
// by bench/gravity_tower_family.hpp). The 80/500 gravity tower:
// data/bench/tower-80s-500c-gravity with 2 % noise (scenes::perturbed_tower).
// Counters: geometry change (m), converged (verified), iterations, Newton
// iterations (eq5-newton), elements.
// Run with
//   build/bench/eq5_newton_bench --benchmark_repetitions=3 --benchmark_report_aggregates_only=true
//   build/bench/eq5_newton_bench --tower_layers=10,20,40,80,160 --benchmark_filter='eq5-newton|alternating-gn/'
// (--eq5_options=key=value,... sets eq5-newton's options).
// Every run prints one line to stderr.
#include <benchmark/benchmark.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <memory>
#include <stdexcept>
#include <sstream>
#include <string>
#include <vector>

#include "bench/gravity_tower_family.hpp"
#include "model/verify.hpp"
#include "scenes/towers.hpp"
#include "solvers/eq5_newton/eq5_newton_solver.hpp"
#include "solvers/solver.hpp"

namespace tensegrity {
namespace {

constexpr double kTimeLimit = 120.0;
constexpr double kStoredTowerNoise = 0.02;

// `--eq5_options=key=value,...`: options of the eq5-newton runs.
OptionPairs& eq5_options() {
  static OptionPairs pairs;
  return pairs;
}

std::vector<int>& tower_layers() {
  static std::vector<int> layers{10, 20, 40};
  return layers;
}

// The L-layer member of the gravity tower family (scenes/gravity_tower_family.hpp).
Structure family_tower(int layers) {
  try {
    return bench::gravity_tower(layers, kTimeLimit);
  } catch (const std::runtime_error& e) {
    std::fprintf(stderr, "%s\n", e.what());
    std::exit(1);
  }
}

struct Backend {
  std::string label, solver;
  OptionPairs options;
};

const std::vector<Backend>& backends() {
  static const std::vector<Backend> b = {
      {"alternating-gn", "alternating-gn", {}},
      {"eq5-newton", "eq5-newton", {}},
      // Ipopt on the same Eq. 5 (the mean cable force at most kappa W).
      {"ipopt-warm", "ipopt", {{"start", "alternating-gn"}}},
      {"ipopt-auto", "ipopt", {{"start", "auto"}}},
  };
  return b;
}

void solve_with(benchmark::State& state, const std::shared_ptr<Structure>& scene, const Backend& backend) {
  const auto solver = make_solver(backend.solver);
  SolveOptions options;
  options.time_limit_s = kTimeLimit;
  options.backend_options = backend.options;
  if (backend.solver == "eq5-newton") options.backend_options = eq5_options();
  SolveResult r;
  for (auto _ : state) r = solver->Solve(*scene, options, DriverControls{false});
  const Verification v = verify(*scene, r.positions, r.forces, options.tolerance);
  int newton = 0;
  std::string polish;
  if (backend.solver == "eq5-newton" && !r.details.empty() && r.details[0]) {
    const auto& d = dynamic_cast<const Eq5NewtonDetails&>(*r.details[0]);
    newton = d.newton_iterations;
    polish = ", polish " + d.polish;
    state.counters["polish_kept"] = d.polish == "kept" ? 1.0 : 0.0;
  }
  state.counters["geometry_change"] = v.geometry_change;
  state.counters["converged"] = r.status == Status::Converged && v.ok ? 1.0 : 0.0;
  state.counters["iterations"] = r.stats.iterations;
  state.counters["newton_iterations"] = newton;
  state.counters["elements"] = scene->num_elements();
  std::fprintf(stderr, "[%s] %s: %s in %.3f s, %d iterations (%d Newton%s), rr %.2e, change %.8g\n",
               backend.label.c_str(), scene->name.c_str(), std::string(to_string(r.status)).c_str(),
               r.stats.seconds, r.stats.iterations, newton, polish.c_str(), v.relative_residual, v.geometry_change);
  if (!polish.empty()) std::fprintf(stderr, "  %s\n", r.message.c_str());
}

void register_all() {
  std::vector<std::shared_ptr<Structure>> scenes;
  for (int layers : tower_layers()) scenes.push_back(std::make_shared<Structure>(family_tower(layers)));
  auto stored = std::make_shared<Structure>(
      scenes::perturbed_tower(std::string(TENSEGRITY_SOURCE_DIR) + "/data", true, kStoredTowerNoise));
  stored->name = "tower-80s-500c-gravity-noise2";
  scenes.push_back(stored);
  for (const auto& scene : scenes)
    for (const Backend& backend : backends())
      benchmark::RegisterBenchmark((backend.label + "/" + scene->name).c_str(),
                                   [scene, backend](benchmark::State& st) { solve_with(st, scene, backend); })
          ->Unit(benchmark::kMillisecond)
          ->Iterations(1)
          ->MeasureProcessCPUTime()
          ->UseRealTime();
}

std::vector<int> parse_int_list(const char* text) {
  std::vector<int> v;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ','))
    if (!item.empty()) v.push_back(std::atoi(item.c_str()));
  return v;
}

}  // namespace
}  // namespace tensegrity

int main(int argc, char** argv) {
  std::vector<char*> rest;
  for (int i = 0; i < argc; ++i) {
    constexpr const char* kFlag = "--tower_layers=";
    constexpr const char* kOptions = "--eq5_options=";
    if (std::strncmp(argv[i], kFlag, std::strlen(kFlag)) == 0) {
      tensegrity::tower_layers() = tensegrity::parse_int_list(argv[i] + std::strlen(kFlag));
    } else if (std::strncmp(argv[i], kOptions, std::strlen(kOptions)) == 0) {
      std::stringstream ss(argv[i] + std::strlen(kOptions));
      std::string pair;
      while (std::getline(ss, pair, ','))
        if (const auto eq = pair.find('='); eq != std::string::npos)
          tensegrity::eq5_options()[pair.substr(0, eq)] = pair.substr(eq + 1);
    } else {
      rest.push_back(argv[i]);
    }
  }
  int rest_argc = static_cast<int>(rest.size());
  benchmark::Initialize(&rest_argc, rest.data());
  tensegrity::register_all();
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
