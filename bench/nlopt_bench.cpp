// The NLopt algorithms of the `nlopt` backend on reference scenes and the
// 80-strut / 500-cable tower. Counters: evaluations, final relative residual,
// geometry change (m), its ratio to Ipopt's on the same scene (when the ipopt
// backend is registered and converges), and converged (1/0). Run with
//   build/bench/nlopt_bench --benchmark_out=nlopt.json --benchmark_out_format=json
// Repetitions give medians (`_median` rows); every run prints progress.
//
// Side by side (benchmarks side-by-side/<scene>/<variant>): ipopt and the
// nlopt backend's variants (formulation=full; formulation=varpro with SLSQP,
// with the multiplier method around truncated Newton, and by default, the
// multiplier method around L-BFGS) on the reference scenes of data/reference,
// the conformance suite's scenes of tests/reference/scenes, and the scorpion
// characters (data/characters/scorpion and the one of the minimal blocks),
// each as built and with 2 % node noise (scenes::perturbed, seed 1), all
// without the driver's equilibrium shortcut. Own flags (taken out of argv first):
//   --table=FILE       write the medians over the repetitions of the solver's
//                      own seconds and the geometry change as a Markdown table
//   --time_limit=S     wall-clock budget per side-by-side solve (default 30)
// e.g. build/bench/nlopt_bench --benchmark_filter=^side-by-side/ --benchmark_repetitions=3 --table=t.md
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "model/character.hpp"
#include "model/scene_io.hpp"
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

// ---------------------------------------------------------------------------
// Side by side.

double g_side_time_limit = 30.0;

struct Variant {
  const char* name;
  const char* solver;
  OptionPairs options;
};

const std::vector<Variant>& variants() {
  static const std::vector<Variant> v = {
      {"ipopt", "ipopt", {}},
      {"nlopt-full", "nlopt", {{"formulation", "full"}}},
      {"varpro-slsqp", "nlopt", {{"varpro_algorithm", "slsqp"}}},
      {"varpro-al-tnewton", "nlopt", {{"varpro_algorithm", "al-tnewton"}}},
      {"nlopt-varpro", "nlopt", {{"formulation", "varpro"}}},
  };
  return v;
}

std::vector<Structure> scene_files(const std::string& dir) {
  std::vector<std::string> paths;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    const std::string path = entry.path().string();
    if (path.size() > 11 && path.compare(path.size() - 11, 11, ".scene.json") == 0) paths.push_back(path);
  }
  std::sort(paths.begin(), paths.end());
  std::vector<Structure> v;
  for (const auto& path : paths) v.push_back(read_scene_file(path));
  return v;
}

std::vector<Structure> side_by_side_scenes() {
  const std::string root = TENSEGRITY_SOURCE_DIR;
  std::vector<Structure> v = scene_files(root + "/data/reference");
  for (Structure& s : scene_files(root + "/tests/reference/scenes")) v.push_back(std::move(s));
  Structure scorpion = build_character_file(root + "/data/characters/scorpion.character.json").structure;
  scorpion.name = "scorpion";
  v.push_back(scorpion);
  v.push_back(scenes::perturbed(scorpion, 0.02, 1u));
  // Within a tenth of a millimetre of an optimum of Eq. 5 that moves it, as
  // built; the scorpion above balances at Eq. 5's force level as built.
  Structure minimal =
      build_character_file(root + "/data/characters/minimal/scorpion.character.json").structure;
  minimal.name = "scorpion-minimal";
  v.push_back(minimal);
  v.push_back(scenes::perturbed(minimal, 0.02, 1u));
  return v;
}

struct SideRun {
  double seconds = 0.0;
  double geometry_change = 0.0;
  Status status = Status::NumericalError;
};

// Per scene (in order) and variant, every repetition.
std::vector<std::string> g_scene_order;
std::map<std::string, std::map<std::string, std::vector<SideRun>>> g_side_runs;
std::map<std::string, int> g_scene_elements;

void solve_side_by_side(benchmark::State& state, const Structure& scene, const Variant& variant) {
  const auto solver = make_solver(variant.solver);
  SolveOptions options;
  options.time_limit_s = g_side_time_limit;
  options.backend_options = variant.options;
  SolveResult r;
  for (auto _ : state) r = solver->Solve(scene, options, DriverControls{false});
  SideRun run;
  run.seconds = r.stats.seconds;
  run.geometry_change = r.stats.geometry_change;
  run.status = r.status;
  g_side_runs[scene.name][variant.name].push_back(run);
  g_scene_elements[scene.name] = scene.num_elements();
  state.counters["solver_seconds"] = r.stats.seconds;
  state.counters["geometry_change"] = r.stats.geometry_change;
  state.counters["converged"] = r.status == Status::Converged ? 1.0 : 0.0;
  std::fprintf(stderr, "[%s] %s: %s in %.4f s, geometry change %.9g\n", variant.name, scene.name.c_str(),
               std::string(to_string(r.status)).c_str(), r.stats.seconds, r.stats.geometry_change);
}

int register_side_by_side() {
  static const std::vector<Structure> scenes = side_by_side_scenes();
  for (const Structure& scene : scenes) {
    g_scene_order.push_back(scene.name);
    for (const Variant& variant : variants()) {
      auto* b = benchmark::RegisterBenchmark(
          ("side-by-side/" + scene.name + "/" + variant.name).c_str(),
          [&scene, &variant](benchmark::State& st) { solve_side_by_side(st, scene, variant); });
      b->Unit(benchmark::kMillisecond)->Iterations(1);
    }
  }
  return 0;
}

const int registered_side_by_side = register_side_by_side();

template <class T>
T median(std::vector<T> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

std::string format(const char* pattern, double value) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, pattern, value);
  return buffer;
}

// Markdown: per scene, per variant the median solver seconds and geometry
// change over the repetitions ("-" where a repetition did not converge: its
// status is named instead).
void write_side_by_side_table(const std::string& path) {
  std::ofstream out(path);
  out << "| scene | elements |";
  for (const Variant& v : variants()) out << " " << v.name << " s | " << v.name << " change (m) |";
  out << "\n|---|---:|";
  for (std::size_t k = 0; k < variants().size(); ++k) out << "---:|---:|";
  out << "\n";
  for (const std::string& scene : g_scene_order) {
    const auto it = g_side_runs.find(scene);
    if (it == g_side_runs.end()) continue;
    out << "| " << scene << " | " << g_scene_elements[scene] << " |";
    for (const Variant& v : variants()) {
      const auto runs_it = it->second.find(v.name);
      if (runs_it == it->second.end()) {
        out << " | |";
        continue;
      }
      const auto& runs = runs_it->second;
      std::vector<double> seconds, changes;
      std::string failure;
      for (const SideRun& r : runs) {
        seconds.push_back(r.seconds);
        changes.push_back(r.geometry_change);
        if (r.status != Status::Converged) failure = std::string(to_string(r.status));
      }
      out << " " << format("%.3g", median(seconds)) << " | "
          << (failure.empty() ? format("%.6g", median(changes)) : failure + " (" + format("%.3g", median(changes)) + ")")
          << " |";
    }
    out << "\n";
  }
}

}  // namespace
}  // namespace tensegrity

int main(int argc, char** argv) {
  std::string table;
  int kept = 1;
  for (int i = 1; i < argc; ++i) {
    if (std::strncmp(argv[i], "--table=", 8) == 0) {
      table = argv[i] + 8;
    } else if (std::strncmp(argv[i], "--time_limit=", 13) == 0) {
      tensegrity::g_side_time_limit = std::atof(argv[i] + 13);
    } else {
      argv[kept++] = argv[i];
    }
  }
  argc = kept;
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  if (!table.empty()) tensegrity::write_side_by_side_table(table);
  return 0;
}
