// tensegrity batch SCENE... [--solver NAME] [--jobs N] --out-dir DIR [--tol T]
//     [--time-limit S] [--max-iterations N] [--no-skip] [--measure-speedup] [--trace]
//
// Solves independent scenes in parallel, one scene per thread at a time, each
// solve single-threaded (OpenBLAS under MUMPS is told to use one thread, so
// N jobs use N cores and no more). Writes DIR/<scene>.solution.json (and
// DIR/<scene>.trace.csv with --trace), prints one line per scene and a summary
// with the wall-clock time, the process CPU time and the speed-up:
// --measure-speedup first solves everything with one job and reports
// serial wall time / parallel wall time; without it the summary gives the sum
// of the solve times over the wall time (an estimate that other load on the machine inflates).
// Exit status: 0 if every scene converged, 1 otherwise, 2 bad input (all scenes
// are read before anything is solved).
#include <dlfcn.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <iostream>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "cli/commands.hpp"
#include "cli/output.hpp"
#include "model/errors.hpp"
#include "model/scene_io.hpp"

namespace tensegrity::cli {

namespace {
struct BatchArgs {
  std::vector<std::string> scenes;
  std::string solver;
  std::string out_dir;
  int jobs = 2;
  double tol = 1e-8;
  int max_iterations = 0;
  double time_limit = 120.0;
  bool no_skip = false;
  bool measure_speedup = false;
  bool trace = false;
};

void one_blas_thread() {
  setenv("OPENBLAS_NUM_THREADS", "1", 1);
  setenv("OMP_NUM_THREADS", "1", 1);
  // The BLAS read its environment when it was loaded; tell it again.
  for (const char* symbol : {"openblas_set_num_threads", "omp_set_num_threads"})
    if (auto* set = reinterpret_cast<void (*)(int)>(dlsym(RTLD_DEFAULT, symbol))) set(1);
}

double process_cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

struct PassResult {
  std::vector<SolveResult> results;
  double wall_s = 0.0;
  double cpu_s = 0.0;
};

PassResult solve_all(const std::vector<Structure>& scenes, const std::string& solver_name,
                     const SolveOptions& options, const DriverControls& controls, int jobs) {
  PassResult pass;
  pass.results.resize(scenes.size());
  std::atomic<std::size_t> next{0};
  auto worker = [&] {
    const auto solver = make_solver(solver_name);  // one instance per thread: no shared state
    for (std::size_t i = next++; i < scenes.size(); i = next++) pass.results[i] = solver->Solve(scenes[i], options, controls);
  };
  const double cpu0 = process_cpu_seconds();
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<std::thread> threads;
  const int n = std::max(1, std::min<int>(jobs, static_cast<int>(scenes.size())));
  for (int k = 0; k < n; ++k) threads.emplace_back(worker);
  for (auto& t : threads) t.join();
  pass.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  pass.cpu_s = process_cpu_seconds() - cpu0;
  return pass;
}

std::string stem(const std::string& path) {
  std::string name = std::filesystem::path(path).filename().string();
  for (const char* suffix : {".scene.json", ".json"}) {
    const std::string s(suffix);
    if (name.size() > s.size() && name.compare(name.size() - s.size(), s.size(), s) == 0) {
      name.resize(name.size() - s.size());
      break;
    }
  }
  return name;
}
}  // namespace

void register_batch_command(CLI::App& app, CommandRunner& run) {
  auto args = std::make_shared<BatchArgs>();
  auto* cmd = app.add_subcommand("batch", "Solve independent scenes in parallel (one thread per job) and report the speed-up");
  cmd->add_option("scenes", args->scenes, "Scene files (*.scene.json)")->required();
  cmd->add_option("--solver", args->solver, "Backend name (see `tensegrity solvers`); default: the recommended one");
  cmd->add_option("--jobs", args->jobs, "Scenes solved at once (threads), 1..256");
  cmd->add_option("--out-dir", args->out_dir, "Folder for the solution files")->required();
  cmd->add_option("--tol", args->tol, "Relative residual for `converged` (finite, > 0)");
  cmd->add_option("--max-iterations", args->max_iterations, max_iterations_help("Backend iteration budget per scene"));
  cmd->add_option("--time-limit", args->time_limit, "Wall-clock budget in seconds per scene");
  cmd->add_flag("--no-skip", args->no_skip, "Do not return early when a scene is already in equilibrium");
  cmd->add_flag("--measure-speedup", args->measure_speedup, "First solve everything with one job, then report serial/parallel wall time");
  cmd->add_flag("--trace", args->trace, "Also write <scene>.trace.csv per scene");
  cmd->callback([args, &run] {
    run = [args] {
      if (args->jobs < 1 || args->jobs > 256) throw InputError("command line", "--jobs", "must be within 1..256");
      SolveOptions options;
      options.tolerance = args->tol;
      options.max_iterations = args->max_iterations;
      options.time_limit_s = args->time_limit;
      DriverControls controls;
      controls.skip_if_in_equilibrium = !args->no_skip;
      const std::string name(checked_solver(args->solver, options)->name());
      std::vector<Structure> scenes;
      std::vector<std::string> stems;
      for (const auto& path : args->scenes) {
        scenes.push_back(read_scene_file(path));
        stems.push_back(stem(path));
        for (std::size_t k = 0; k + 1 < stems.size(); ++k)
          if (stems[k] == stems.back())
            throw InputError(path, "scene", "two scenes would write the same solution file " + stems.back());
      }
      std::filesystem::create_directories(args->out_dir);
      one_blas_thread();

      PassResult serial;
      if (args->measure_speedup && args->jobs > 1) {
        std::cerr << "batch: " << scenes.size() << " scenes with " << name << ", 1 job (for the speed-up)...\n";
        serial = solve_all(scenes, name, options, controls, 1);
      }
      std::cerr << "batch: " << scenes.size() << " scenes with " << name << ", " << args->jobs << " jobs...\n";
      const PassResult parallel = solve_all(scenes, name, options, controls, args->jobs);

      int failures = 0;
      double sum_s = 0.0;
      std::printf("%-28s %-15s %6s %10s %12s %12s\n", "scene", "status", "iters", "seconds", "rel_residual",
                  "geom_change");
      for (std::size_t i = 0; i < scenes.size(); ++i) {
        const SolveResult& r = parallel.results[i];
        sum_s += r.stats.seconds;
        if (r.status != Status::Converged) ++failures;
        write_solution_file(to_solution(r, scenes[i], name), args->out_dir + "/" + stems[i] + ".solution.json");
        if (args->trace) write_trace_csv(args->out_dir + "/" + stems[i] + ".trace.csv", r.trace);
        std::printf("%-28s %-15s %6d %10.4f %12.3g %12.4g\n", stems[i].c_str(), std::string(to_string(r.status)).c_str(),
                    r.stats.iterations, r.stats.seconds, r.stats.relative_residual, r.stats.geometry_change);
      }
      std::printf("jobs %d: wall %.3f s, process CPU %.3f s (%.2f cores busy), sum of solve times %.3f s\n",
                  args->jobs, parallel.wall_s, parallel.cpu_s, parallel.cpu_s / std::max(1e-9, parallel.wall_s), sum_s);
      if (args->measure_speedup && args->jobs > 1)
        std::printf("jobs 1: wall %.3f s, process CPU %.3f s\nmeasured speed-up (serial wall / parallel wall): %.2f\n",
                    serial.wall_s, serial.cpu_s, serial.wall_s / std::max(1e-9, parallel.wall_s));
      else
        std::printf("speed-up estimate (sum of solve times / wall): %.2f\n", sum_s / std::max(1e-9, parallel.wall_s));
      std::printf("converged %zu of %zu\n", scenes.size() - failures, scenes.size());
      return failures == 0 ? 0 : 1;
    };
  });
}

}  // namespace tensegrity::cli
