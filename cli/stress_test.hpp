#pragma once
// The numerical stress test behind `tensegrity stress-test` (docs/ROBUSTNESS.md):
// seeded families of perturbed scenes built from every benchmark scene and
// character, solved by every chosen backend in worker processes
// (workers/process_pool.hpp), the longest estimated first, each result
// re-checked independently with model/verify, and summarised per backend and
// family (and per level of the family's perturbation).
//
// The scene families are scenes/families.hpp.
#include <cstdint>
#include <cstdio>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "formulations/force_scale.hpp"
#include "model/structure.hpp"
#include "scenes/families.hpp"
#include "solvers/solver.hpp"

namespace tensegrity::cli {

// What the coordinating process tells while trials run.
struct StressObserver {
  // Before each pass over the trials: trials in all, how many of them are
  // not run (rejected inputs), worker processes, and whether this is the
  // one-worker pass that measure_speedup runs first.
  std::function<void(std::size_t trials, std::size_t not_run, int workers, bool speedup_reference)> on_pass_start;
  // A trial ended; `failed`: it did not converge, verify or stay finite.
  std::function<void(bool failed)> on_trial_end;
  // While waiting for trials, a few times per second.
  std::function<void()> on_tick;
};

struct StressTestOptions {
  std::vector<std::string> scenes;    // names or groups; empty = all
  std::vector<std::string> solvers;   // empty = every registered backend
  std::vector<std::string> families;  // empty = all
  int trials = 2;                     // per scene, family and level
  std::uint64_t seed = 1;
  int jobs = 2;                       // worker processes
  double time_limit_s = 20.0;         // per solve
  bool measure_speedup = false;       // first run everything on one worker, for the serial wall time
  double tolerance = 1e-8;
  double prestress_factor = kDefaultPrestressFactor;  // kappa of Eq. 5 under gravity
  // Backend options (`--option key=value`) given to every solver of the run;
  // each solver must accept them all (InputError otherwise).
  std::map<std::string, std::string> backend_options;
  std::string data_dir;               // holds characters/
  bool with_times = true;             // false: the report holds no timings (bit-identical runs)
  std::vector<std::string> scene_files;  // extra scenes read from files
  // When set, the perturbed scene of every trial that did not converge and
  // verify is written there as <scene>_<family>_<level>_t<trial>_<solver>.scene.json
  // (to reproduce it with `tensegrity solve`).
  std::string failures_dir;
  // Called by the coordinating process, for a progress display.
  StressObserver observer;
};

struct StressTrial {
  std::string scene, family, level, solver;
  int trial = 0;
  bool rejected = false;       // the perturbed scene broke a rule of the model (not run)
  Status status = Status::NumericalError;
  bool verified = false;       // independent re-check with model/verify passes
  bool finite = true;          // no non-finite number in positions, forces, stats or trace
  double relative_residual = 0.0;
  double seconds = 0.0;        // of the solve, measured in its worker
  double wall_seconds = 0.0;   // of the job, as the coordinating process saw it
  int iterations = 0;
  double geometry_change = 0.0;  // m
  bool overran = false;        // took longer than twice the time limit plus 5 s (its worker is killed then)
  bool crashed = false;        // its worker process died (the status is numerical_error)
  std::uint64_t digest = 0;    // of status, positions and forces (bits)
  std::string message;
};

struct StressReport {
  StressTestOptions options;
  std::vector<StressTrial> trials;  // in a fixed order (scene, family, level, trial, solver)
  double wall_seconds = 0.0;        // the whole run, building the scenes included
  double pool_wall_seconds = 0.0;   // the solves
  double cpu_seconds = 0.0;         // of every process, during the solves
  double sum_job_wall_seconds = 0.0;
  double serial_wall_seconds = 0.0;  // of the solves on one worker, when measured (else 0)
  std::vector<scenes::SkippedFile> skipped;  // bad files of the data folder, left out
};

// Throws InputError for unknown scene, family or solver names and for a bad
// --scene file. A bad file of the data folder is named on standard error in
// one line (`tensegrity: FILE: ITEM: REASON`), left out and listed in
// StressReport::skipped.
StressReport run_stress_test(const StressTestOptions& options);

// The report file; with options.with_times false it holds no timing and is
// bit-identical for the same options whatever the number of worker processes.
nlohmann::json stress_report_to_json(const StressReport& report);

// Per backend: trials, the count of each status, rejected inputs, crashed
// workers and the median seconds of a solve; then the speed-up.
void print_stress_table(const StressReport& report, std::FILE* out);

}  // namespace tensegrity::cli
