// Every registered backend on every benchmark scene, through the same driver
// as `tensegrity solve` (Solver::Solve, without the equilibrium shortcut
// unless --driver_check=1).
//
//   build/bench/compare_bench --benchmark_out=compare.json --benchmark_out_format=json
//       --benchmark_repetitions=3 --trace_dir=traces      (one command line)
//
// Benchmarks are named compare/<scene>/<backend> (reference, perturbed,
// towers, characters), side-by-side/<scene>/<backend> (the minimal scorpion as
// built and with 2 % node noise, the 80/500 gravity tower with 2 % noise, the
// 2 x 7 octahedron grid as built: the table of docs/figures/side-by-side.md) and scaling/<scene>/<backend> for two parametric
// families: chain-<N> (N face-linked expandable octahedra under gravity,
// model/character.hpp, nodes moved by seeded noise of 2 % of the strut length)
// and tower-layers-<L> (see scaling_tower), and gravity-towers/<scene>/<backend>
// for the gravity tower family tower-<L>-gravity-noise1 (58 L elements,
// scenes/gravity_tower_family.hpp): each built on its first benchmark, outside
// the timing, by an alternating-gn equilibrium solve plus 1 % node noise.
// Besides every registered backend, `ipopt@auto` is Ipopt with
// --option start=auto (docs/BACKENDS.md; the default starts from
// eq5-newton's answer), so that both of Ipopt's starts are timed in the same
// run, and on the gravity tower family `eq5-newton@barrier=monotone` is
// eq5-newton with the monotone barrier rule beside Mehrotra's, its default.
// Scenes are built once, before any timing; success is checked after the
// timing loop by the independent model/verify at --success_tol.
//
// two-cores/mixed/ipopt+alternating-gn+eq5-newton solves a mixed set (the
// compare family's scenes, the side-by-side family's but the grid, and the
// gravity towers of --gravity_tower_layers), each scene by each of those three
// backends, in worker processes as `tensegrity batch --measure-speedup` does
// (workers/solve_jobs.hpp): first with one worker, then with two, the longest
// estimated job first. Its time is the two-worker pass's wall time; its
// counters: jobs, converged (of the two-worker pass), serial_wall_s,
// parallel_wall_s, parallel_cpu_s (every process), measured_speedup
// (serial_wall_s / parallel_wall_s), speedup_estimate (the jobs' own wall
// times over parallel_wall_s), cores (the CPUs this process may use).
//
// Own flags (taken out of argv before Google Benchmark sees it):
//   --trace_dir=DIR        write DIR/<scene>__<backend>.csv, the last run's trace
//   --time_limit=S         wall-clock budget per solve (default 60)
//   --tolerance=T          the backends' target relative residual (default 1e-10,
//                          so that the times to 1e-4 ... 1e-10 all exist when reachable)
//   --success_tol=T        relative residual that counts as success (default 1e-8)
//   --chain_sizes=2,4,...  sizes of the chain family (default 2,4,8,16,32,64,128; empty: none)
//   --tower_layers=2,4,... layers of the tower family (default 2,4,8,16,32; empty: none)
//   --gravity_tower_layers=10,20,...  layers of the gravity tower family
//                          (default 10,20,40; the whole family is 10,20,40,80,160; empty: none)
//   --driver_check=1       solve as `tensegrity solve` does, with the driver's
//                          check whether a scene already stands (default 0: the
//                          backend alone)
//   --extra_backends=L,... more labels backend@key=value beside the default ones,
//                          e.g. ipopt@mumps_pivot_order=5 (docs/figures/ipopt-orderings.md)
//   --write_scenes=DIR     write every scene as built, DIR/<scene>.scene.json, so that
//                          other tools can run the same problems (the gravity towers
//                          when a selected benchmark builds them)
//
// Counters (per benchmark, from the last timed run unless said otherwise):
//   t_1e-4 ... t_1e-10   seconds until the trace first reaches that relative
//                        residual; -1 when never reached
//   iterations, relative_residual (final, verified), geometry_change (m),
//   geometry_change_L (in units of the scene's mean element length),
//   success (1/0: verified), converged (1/0: the backend's status), elements, nodes,
//   seconds_per_iteration (solve seconds / iterations; -1 without iterations),
//   peak_heap_MB         most heap bytes live at once during a solve beyond
//                        those live before it (every malloc of the process,
//                        C++, C and Fortran alike; max over the timed runs),
//   max_rss_MB           the process's resident high-water mark so far (getrusage).
// The geometry change relative to the best successful backend per scene is
// computed by bench/scripts/report.py from the JSON (it needs all backends).
#include <benchmark/benchmark.h>
#include <malloc.h>
#include <nlohmann/json.hpp>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <mutex>
#include <fstream>
#include <memory>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "bench/gravity_tower_family.hpp"
#include "scenes/towers.hpp"
#include "model/character.hpp"
#include "model/scene_io.hpp"
#include "model/verify.hpp"
#include "solvers/solver.hpp"
#include "solvers/trace_csv.hpp"
#include "scenes/suites.hpp"
#include "kernels/blas_threads.hpp"
#include "workers/solve_jobs.hpp"

// ---------------------------------------------------------------------------
// Heap meter: malloc and friends are interposed for the whole process (shared
// libraries included, so Ipopt's MUMPS and NLopt count too) and forwarded to
// glibc; live bytes are counted by malloc_usable_size. Relaxed atomics: the
// solves are single-threaded, and a peak off by one allocation is fine.
extern "C" {
void* __libc_malloc(size_t);
void __libc_free(void*);
void* __libc_calloc(size_t, size_t);
void* __libc_realloc(void*, size_t);
void* __libc_memalign(size_t, size_t);
}

namespace {
std::atomic<long long> g_live_bytes{0};
std::atomic<long long> g_peak_bytes{0};

inline void count_alloc(void* p) {
  if (!p) return;
  const long long now = g_live_bytes.fetch_add(static_cast<long long>(malloc_usable_size(p)),
                                               std::memory_order_relaxed) +
                        static_cast<long long>(malloc_usable_size(p));
  long long peak = g_peak_bytes.load(std::memory_order_relaxed);
  while (now > peak && !g_peak_bytes.compare_exchange_weak(peak, now, std::memory_order_relaxed)) {
  }
}
inline void count_free(void* p) {
  if (p) g_live_bytes.fetch_sub(static_cast<long long>(malloc_usable_size(p)), std::memory_order_relaxed);
}
}  // namespace

extern "C" {
void* malloc(size_t n) {
  void* p = __libc_malloc(n);
  count_alloc(p);
  return p;
}
void free(void* p) {
  count_free(p);
  __libc_free(p);
}
void* calloc(size_t n, size_t size) {
  void* p = __libc_calloc(n, size);
  count_alloc(p);
  return p;
}
void* realloc(void* old, size_t n) {
  const long long before = old ? static_cast<long long>(malloc_usable_size(old)) : 0;
  void* p = __libc_realloc(old, n);
  if (p || n == 0) g_live_bytes.fetch_sub(before, std::memory_order_relaxed);
  count_alloc(p);
  return p;
}
void* memalign(size_t alignment, size_t n) {
  void* p = __libc_memalign(alignment, n);
  count_alloc(p);
  return p;
}
void* aligned_alloc(size_t alignment, size_t n) { return memalign(alignment, n); }
int posix_memalign(void** out, size_t alignment, size_t n) {
  void* p = memalign(alignment, n);
  if (!p) return ENOMEM;
  *out = p;
  return 0;
}
void* valloc(size_t n) { return memalign(static_cast<size_t>(sysconf(_SC_PAGESIZE)), n); }
void* pvalloc(size_t n) {
  const size_t page = static_cast<size_t>(sysconf(_SC_PAGESIZE));
  return memalign(page, (n + page - 1) / page * page);
}
}

namespace tensegrity {
namespace {

struct Config {
  std::string trace_dir;
  double time_limit_s = 60.0;
  double tolerance = 1e-10;
  double success_tol = 1e-8;
  std::vector<int> chain_sizes{2, 4, 8, 16, 32, 64, 128};
  std::vector<int> tower_layers{2, 4, 8, 16, 32};
  std::vector<int> gravity_tower_layers{10, 20, 40};
  bool driver_check = false;
  std::vector<std::string> extra_backends;  // backend@key=value labels
  std::string scene_dir;                    // --write_scenes
};
Config& config() {
  static Config c;
  return c;
}

constexpr double kGravityTowerEquilibriumLimit = 120.0;  // s, as eq5_newton_bench

// The node noise (share of the longest strut) and seed of the side-by-side
// family's perturbed character.
constexpr double kSideBySideNoise = 0.02;
constexpr unsigned kSideBySideSeed = 1u;
// A benchmarked backend with an option of its own: backend@key=value, or
// backend@value for its start.
constexpr char kOptionSeparator = '@';
constexpr char kOptionValueSeparator = '=';
constexpr const char* kStartOption = "start";
constexpr std::string_view kIpoptAutoStart = "ipopt@auto";
static_assert(kIpoptAutoStart[5] == kOptionSeparator);
constexpr const char* kEq5NewtonMonotone = "eq5-newton@barrier=monotone";

// The two-core family: its backends (one of them Ipopt, whose MUMPS lock
// would serialise threads) and its number of worker processes.
constexpr const char* kTwoCoreBackends[] = {"ipopt", "alternating-gn", "eq5-newton"};
constexpr const char* kTwoCoreName = "two-cores/mixed/ipopt+alternating-gn+eq5-newton";
constexpr int kTwoCoreWorkers = 2;
// The side-by-side scene left out of the two-core set: far from equilibrium,
// Ipopt spends the whole time limit there, and one such job sets both passes' wall time.
constexpr const char* kTwoCoreExcluded = "octahedron-grid-2x7";

struct BenchScene {
  std::string family;  // "compare", "side-by-side" or "scaling"
  Structure structure;
};

Structure character(const std::string& name) {
  Structure s = build_character_file(std::string(TENSEGRITY_SOURCE_DIR) + "/data/characters/" + name +
                                     ".character.json")
                    .structure;
  s.name = name;
  return s;
}

// The chain as built is already in equilibrium (every block is); nodes moved
// by up to 2 % of the longest strut make it a form-finding problem.
Structure chain(int n) {
  Structure s =
      build_character(make_chain_character(n), "chain-" + std::to_string(n), BlockLibrary::standard()).structure;
  s = scenes::perturbed(s, 0.02, 1000u + static_cast<unsigned>(n));
  s.name = "chain-" + std::to_string(n);
  return s;
}

// The second scaling family, a real form-finding problem at every size (the
// chain's blocks each stand on three fixed nodes, so the stress QP alone nearly
// always solves it): L layers of 6-strut prisms joined by two cables per top
// node, every node moved by 2 % of the strut length, no gravity.
Structure scaling_tower(int layers) {
  scenes::TowerParameters p;
  p.layers = layers;
  p.struts_per_layer = 6;
  p.cables = 3 * 6 * layers + 2 * 6 * (layers - 1);
  p.seed = 100u + static_cast<unsigned>(layers);
  Structure s = scenes::make_prism_tower(p);
  s.name = "tower-layers-" + std::to_string(layers);
  return s;
}

Structure tower(bool gravity) {
  return scenes::perturbed_tower(std::string(TENSEGRITY_SOURCE_DIR) + "/data", gravity);
}

std::vector<BenchScene> all_scenes() {
  using namespace tensegrity::scenes;
  std::vector<BenchScene> v;
  auto add = [&](Structure s) { v.push_back({"compare", std::move(s)}); };
  // Reference prisms and octahedron, moved off equilibrium (their own
  // geometry is already a tensegrity and would be nothing to solve).
  add(prism(3, 10.0));
  add(prism(6, 10.0));
  add(prism(12, 10.0));
  add(perturbed(octahedron(), 0.05, 3u));
  // Perturbed versions, with and without gravity.
  add(perturbed(prism(6), 0.05, 17u));
  add(perturbed(prism(4), 0.15, 7u));
  add(perturbed(prism(6, 0.0, true), 0.05, 6u));
  add(perturbed(octahedron(true), 0.05, 8u));
  // Towers (80 struts / 500 cables) and the characters.
  add(tower(false));
  add(tower(true));
  for (const char* name : {"duck", "scorpion", "puppy"}) add(character(name));
  // Side by side, for Eq. 5's accuracy against speed: the scorpion of the
  // minimal block templates (503 elements; the shipped, braced one still
  // stands after node noise) as built, within millimetres of equilibrium, and
  // with 2 % node noise, and the 80/500 gravity tower with 2 % noise (as in
  // the comparison above).
  auto side_by_side = [&](Structure s) { v.push_back({"side-by-side", std::move(s)}); };
  Structure minimal_scorpion = character("minimal/scorpion");
  minimal_scorpion.name = "scorpion-minimal";
  Structure noisy_scorpion = perturbed(minimal_scorpion, kSideBySideNoise, kSideBySideSeed);
  noisy_scorpion.name = "scorpion-minimal-noise2";
  side_by_side(std::move(minimal_scorpion));
  side_by_side(std::move(noisy_scorpion));
  side_by_side(tower(true));
  // And a scene far from equilibrium: 14 expandable octahedra on a 2 x 7
  // grid joined by 8 cables per neighbour pair (572 elements).
  side_by_side(octahedron_grid(OctahedronGridParameters{}));
  for (int n : config().chain_sizes) v.push_back({"scaling", chain(n)});
  for (int layers : config().tower_layers) v.push_back({"scaling", scaling_tower(layers)});
  return v;
}

double first_time_below(const std::vector<TracePoint>& trace, double threshold, const SolveResult& r) {
  for (const TracePoint& p : trace)
    if (std::isfinite(p.relative_residual) && p.relative_residual <= threshold) return p.seconds;
  // A trace without the final point (or a shortcut) still counts the end.
  if (r.stats.relative_residual <= threshold) return r.stats.seconds;
  return -1.0;
}

double max_rss_mb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_maxrss) / 1024.0;
}

// The benchmarked backends: every registered one, and Ipopt started from
// alternating-gn's equilibrium and the scene (`ipopt@auto`: backend@start).
std::vector<std::string> bench_backends() {
  std::vector<std::string> names = solver_names();
  names.emplace_back(kIpoptAutoStart);
  names.insert(names.end(), config().extra_backends.begin(), config().extra_backends.end());
  return names;
}

// ... and on the gravity tower family also eq5-newton's other barrier rule.
std::vector<std::string> gravity_tower_backends() {
  std::vector<std::string> names = bench_backends();
  names.emplace_back(kEq5NewtonMonotone);
  return names;
}

// The backend option a label's suffix names (backend@key=value, backend@start).
OptionPairs label_options(const std::string& label) {
  const std::size_t at = label.find(kOptionSeparator);
  if (at == std::string::npos) return {};
  const std::string option = label.substr(at + 1);
  const std::size_t equals = option.find(kOptionValueSeparator);
  if (equals == std::string::npos) return {{kStartOption, option}};
  return {{option.substr(0, equals), option.substr(equals + 1)}};
}

void run(benchmark::State& state, const std::string& label, const Structure& scene) {
  const std::string backend = label.substr(0, label.find(kOptionSeparator));
  const auto solver = make_solver(backend);
  SolveOptions options;
  options.backend_options = label_options(label);
  options.tolerance = config().tolerance;
  options.time_limit_s = config().time_limit_s;
  SolveResult r;
  long long peak_heap = 0;
  for (auto _ : state) {
    const long long base = g_live_bytes.load(std::memory_order_relaxed);
    g_peak_bytes.store(base, std::memory_order_relaxed);
    r = solver->Solve(scene, options, DriverControls{config().driver_check});
    benchmark::DoNotOptimize(r.forces.data());
    peak_heap = std::max(peak_heap, g_peak_bytes.load(std::memory_order_relaxed) - base);
  }
  const Verification v = verify(scene, r.positions, r.forces, config().success_tol);
  const bool success = v.ok;
  state.counters["success"] = success ? 1.0 : 0.0;
  state.counters["converged"] = r.status == Status::Converged ? 1.0 : 0.0;
  state.counters["seconds_per_iteration"] =
      r.stats.iterations > 0 ? r.stats.seconds / r.stats.iterations : -1.0;
  state.counters["iterations"] = r.stats.iterations;
  state.counters["relative_residual"] = v.relative_residual;
  state.counters["geometry_change"] = v.geometry_change;
  state.counters["geometry_change_L"] = v.geometry_change / scene.mean_element_length();
  state.counters["solve_seconds"] = r.stats.seconds;
  state.counters["elements"] = scene.num_elements();
  state.counters["nodes"] = scene.num_nodes();
  for (int k : {4, 6, 8, 10}) {
    const double t = first_time_below(r.trace, std::pow(10.0, -k), r);
    state.counters["t_1e-" + std::to_string(k)] = t;
  }
  state.counters["peak_heap_MB"] = static_cast<double>(peak_heap) / (1024.0 * 1024.0);
  state.counters["max_rss_MB"] = max_rss_mb();
  state.SetLabel(std::string(to_string(r.status)) + (success ? "" : " (not verified)"));
  if (!config().trace_dir.empty())
    write_trace_csv(config().trace_dir + "/" + scene.name + "__" + label + ".csv", r.trace);
  // One progress line per benchmark (Google Benchmark calls this function
  // again for each trial iteration count and repetition).
  static std::set<std::string> reported;
  if (!reported.insert(scene.name + "/" + label).second) return;
  std::fprintf(stderr, "run  %-28s %-15s %-15s %8.3f s  %5d it  rr %.1e  change %.4g m  heap %.1f MB\n",
               scene.name.c_str(), label.c_str(), std::string(to_string(r.status)).c_str(),
               r.stats.seconds, r.stats.iterations, v.relative_residual, v.geometry_change,
               static_cast<double>(peak_heap) / (1024.0 * 1024.0));
}

// With --write_scenes, the scene as built into that folder. Two different
// scenes of one name would leave only the last one's file, so that is an
// error; the same scene in two families is written once. Exits 2 on either
// error, as on a bad flag.
void write_scene_if_asked(const Structure& s) {
  if (config().scene_dir.empty()) return;
  static std::mutex mutex;
  static std::map<std::string, nlohmann::json> written;
  std::lock_guard<std::mutex> lock(mutex);
  try {
    nlohmann::json scene = scene_to_json(s);
    if (auto it = written.find(s.name); it != written.end()) {
      if (it->second == scene) return;
      throw std::runtime_error("two different scenes are named " + s.name);
    }
    write_scene_file(s, (std::filesystem::path(config().scene_dir) / (s.name + ".scene.json")).string());
    written.emplace(s.name, std::move(scene));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "compare_bench: --write_scenes: %s\n", e.what());
    std::exit(2);
  }
}

// The gravity tower of `layers` layers, built on first use: its equilibrium
// solve takes long at the larger sizes, and a filtered run may not need it.
const Structure* gravity_tower_scene(int layers) {
  static std::mutex mutex;
  static std::map<int, std::unique_ptr<Structure>> built;
  static std::map<int, std::string> failed;
  std::lock_guard<std::mutex> lock(mutex);
  if (auto it = built.find(layers); it != built.end()) return it->second.get();
  if (failed.count(layers)) return nullptr;
  try {
    // The equilibrium gets the largest budget any benchmarked solve gets.
    const double budget = std::max(config().time_limit_s, kGravityTowerEquilibriumLimit);
    built[layers] = std::make_unique<Structure>(bench::gravity_tower(layers, budget));
  } catch (const std::exception& e) {
    failed[layers] = e.what();
    std::fprintf(stderr, "%s\n", e.what());
    return nullptr;
  }
  write_scene_if_asked(*built[layers]);
  return built[layers].get();
}

// Both passes of the two-core family over `jobs`; the benchmark's time is the
// two-worker pass's wall time.
void run_two_cores(benchmark::State& state, const std::vector<SolveJob>& jobs) {
  SolveJobSettings parallel_settings;
  parallel_settings.options.tolerance = config().tolerance;
  parallel_settings.options.time_limit_s = config().time_limit_s;
  parallel_settings.controls = DriverControls{config().driver_check};
  parallel_settings.kill_after_s = default_kill_after(config().time_limit_s);
  parallel_settings.write_files = false;
  parallel_settings.workers = kTwoCoreWorkers;
  SolveJobSettings serial_settings = parallel_settings;
  serial_settings.workers = 1;
  SolveJobsRun serial, parallel;
  for (auto _ : state) {
    serial = run_solve_jobs(jobs, serial_settings);
    parallel = run_solve_jobs(jobs, parallel_settings);
    state.SetIterationTime(parallel.wall_seconds);
  }
  const double wall = std::max(parallel.wall_seconds, std::numeric_limits<double>::min());
  state.counters["jobs"] = static_cast<double>(jobs.size());
  state.counters["converged"] = static_cast<double>(parallel.converged);
  state.counters["serial_wall_s"] = serial.wall_seconds;
  state.counters["parallel_wall_s"] = parallel.wall_seconds;
  state.counters["parallel_cpu_s"] = parallel.cpu_seconds;
  state.counters["measured_speedup"] = serial.wall_seconds / wall;
  state.counters["speedup_estimate"] = parallel.sum_job_wall_seconds / wall;
  state.counters["cores"] = available_cores();
  std::fprintf(stderr, "run  %-28s %zu jobs, %zu converged: one worker %.2f s, two %.2f s (CPU %.2f s), speed-up %.2f\n",
               "two-cores", jobs.size(), parallel.converged, serial.wall_seconds, parallel.wall_seconds,
               parallel.cpu_seconds, serial.wall_seconds / wall);
}

void register_two_cores(const std::vector<BenchScene>& scenes) {
  benchmark::RegisterBenchmark(kTwoCoreName,
                               [&scenes](benchmark::State& st) {
                                 std::vector<const Structure*> set;
                                 for (const BenchScene& s : scenes)
                                   if ((s.family == "compare" || s.family == "side-by-side") &&
                                       s.structure.name != kTwoCoreExcluded)
                                     set.push_back(&s.structure);
                                 for (int layers : config().gravity_tower_layers)
                                   if (const Structure* tower = gravity_tower_scene(layers)) set.push_back(tower);
                                 std::vector<SolveJob> jobs;
                                 for (const Structure* scene : set)
                                   for (const char* backend : kTwoCoreBackends)
                                     jobs.push_back({scene, scene->name, "", backend, "", ""});
                                 run_two_cores(st, jobs);
                               })
      ->Unit(benchmark::kSecond)
      ->Iterations(1)
      ->UseManualTime();
}

void register_all() {
  for (int layers : config().gravity_tower_layers)
    for (const std::string& backend : gravity_tower_backends()) {
      const std::string name = "gravity-towers/" + scenes::gravity_tower_name(layers) + "/" + backend;
      benchmark::RegisterBenchmark(name.c_str(),
                                   [backend, layers](benchmark::State& st) {
                                     const Structure* scene = gravity_tower_scene(layers);
                                     if (!scene) {
                                       st.SkipWithError("no equilibrium of the unperturbed tower");
                                       for (auto _ : st) {
                                       }
                                       return;
                                     }
                                     run(st, backend, *scene);
                                   })
          ->Unit(benchmark::kMillisecond)
          ->Iterations(1)
          ->MeasureProcessCPUTime()
          ->UseRealTime();
    }
  static const std::vector<BenchScene> scenes = all_scenes();
  for (const BenchScene& s : scenes) write_scene_if_asked(s.structure);
  register_two_cores(scenes);
  for (const BenchScene& s : scenes)
    for (const std::string& backend : bench_backends()) {
      const std::string name = s.family + "/" + s.structure.name + "/" + backend;
      benchmark::RegisterBenchmark(name.c_str(), [backend, &s](benchmark::State& st) { run(st, backend, s.structure); })
          ->Unit(benchmark::kMillisecond)
          ->MeasureProcessCPUTime()
          ->UseRealTime();
    }
}

std::vector<int> parse_int_list(const std::string& text) {
  std::vector<int> v;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');)
    if (!item.empty()) v.push_back(std::stoi(item));
  return v;
}

// Labels backend@key=value naming a registered backend, a key and a value;
// throws on any other, and on a label given twice or already benchmarked
// (two benchmarks of one name).
std::vector<std::string> parse_backend_labels(const std::string& text) {
  std::vector<std::string> labels;
  const std::vector<std::string> known = solver_names();
  std::set<std::string> taken{std::string(kIpoptAutoStart), kEq5NewtonMonotone};
  std::stringstream in(text);
  for (std::string label; std::getline(in, label, ',');) {
    const std::size_t at = label.find(kOptionSeparator);
    const std::size_t equals = at == std::string::npos ? at : label.find(kOptionValueSeparator, at);
    const bool well_formed = equals != std::string::npos && equals > at + 1 && equals + 1 < label.size();
    if (!well_formed || std::find(known.begin(), known.end(), label.substr(0, at)) == known.end() ||
        !taken.insert(label).second)
      throw std::invalid_argument(label);
    labels.push_back(label);
  }
  return labels;
}

bool take_flag(const char* arg, const char* prefix, std::string* value) {
  const size_t n = std::strlen(prefix);
  if (std::strncmp(arg, prefix, n) != 0) return false;
  *value = arg + n;
  return true;
}

// Removes our own flags from argv; exits with status 2 on a malformed value.
void parse_own_flags(int* argc, char** argv) {
  int out = 1;
  for (int i = 1; i < *argc; ++i) {
    std::string value;
    try {
      if (take_flag(argv[i], "--trace_dir=", &value)) {
        config().trace_dir = value;
        std::filesystem::create_directories(value);
      } else if (take_flag(argv[i], "--time_limit=", &value)) {
        config().time_limit_s = std::stod(value);
      } else if (take_flag(argv[i], "--tolerance=", &value)) {
        config().tolerance = std::stod(value);
      } else if (take_flag(argv[i], "--success_tol=", &value)) {
        config().success_tol = std::stod(value);
      } else if (take_flag(argv[i], "--chain_sizes=", &value)) {
        config().chain_sizes = parse_int_list(value);
      } else if (take_flag(argv[i], "--tower_layers=", &value)) {
        config().tower_layers = parse_int_list(value);
      } else if (take_flag(argv[i], "--gravity_tower_layers=", &value)) {
        config().gravity_tower_layers = parse_int_list(value);
      } else if (take_flag(argv[i], "--write_scenes=", &value)) {
        if (value.empty()) throw std::invalid_argument(value);
        config().scene_dir = value;
        std::filesystem::create_directories(value);
      } else if (take_flag(argv[i], "--extra_backends=", &value)) {
        config().extra_backends = parse_backend_labels(value);
      } else if (take_flag(argv[i], "--driver_check=", &value)) {
        if (value != "0" && value != "1") throw std::invalid_argument(value);
        config().driver_check = value == "1";
      } else {
        argv[out++] = argv[i];
      }
    } catch (const std::exception&) {
      std::fprintf(stderr, "compare_bench: bad value in %s\n", argv[i]);
      std::exit(2);
    }
  }
  *argc = out;
}

}  // namespace
}  // namespace tensegrity

int main(int argc, char** argv) {
  tensegrity::end_blas_thread_pool();  // one solve, one core, no idle pool spinning on the other
  tensegrity::parse_own_flags(&argc, argv);
  tensegrity::register_all();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
