#pragma once
// The solves of `tensegrity batch` in worker processes (cli/process_pool.hpp),
// and its report: a text table and one JSON object (format
// "tensegrity-batch-report", docs/FORMATS.md, docs/schemas/batch-report.schema.json).
#include <cstdio>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "cli/process_pool.hpp"
#include "model/structure.hpp"
#include "solvers/solver.hpp"

namespace tensegrity::cli {

// One scene with one backend.
struct SolveJob {
  const Structure* scene = nullptr;
  std::string scene_name;     // the file name without .scene.json
  std::string scene_file;
  std::string solver;
  std::string solution_file;  // written by the worker
  std::string trace_file;     // empty: none
};

struct SolveJobSettings {
  SolveOptions options;
  DriverControls controls;
  int workers = 1;
  double kill_after_s = 0.0;  // a solve still running then is killed (time_limit)
  bool write_files = true;    // false for the serial reference run
};

struct SolveJobResult {
  JobEnd end = JobEnd::Finished;
  Status status = Status::NumericalError;
  int iterations = 0;
  double seconds = 0.0;       // the solver's own stats.seconds
  double wall_seconds = 0.0;  // of the whole job, as the coordinator saw it
  double residual = 0.0, relative_residual = 0.0, geometry_change = 0.0;
  std::string message;
};

struct SolveJobsRun {
  std::vector<SolveJobResult> results;  // in job order
  double wall_seconds = 0.0;
  double cpu_seconds = 0.0;             // every process of the run
  double sum_solve_seconds = 0.0;
  double sum_job_wall_seconds = 0.0;
  std::size_t converged = 0;
};

// Called by the coordinating process during run_solve_jobs: with each job's
// result as it ends, and while waiting (cli/process_pool.hpp, on_tick).
struct SolveJobsObserver {
  std::function<void(const SolveJobResult&)> on_job_end;
  std::function<void()> on_tick;
};

// Solves every job, longest estimated first, on settings.workers processes.
// A job whose worker crashed or was killed gets a solution file all the same
// (the scene's positions, zero forces, status numerical_error or time_limit).
SolveJobsRun run_solve_jobs(const std::vector<SolveJob>& jobs, const SolveJobSettings& settings,
                            const SolveJobsObserver& observer = {});

struct BatchReport {
  const std::vector<SolveJob>* jobs = nullptr;
  const SolveJobsRun* run = nullptr;
  const SolveJobsRun* serial = nullptr;  // the one-worker reference, when measured
  const SolveJobSettings* settings = nullptr;
  int workers = 1;
  std::vector<std::pair<std::string, std::string>> skipped;  // unreadable file, reason
};

// One line per job, then the summary (wall and CPU time, speed-up, counts).
void print_batch_table(const BatchReport& report, std::FILE* out, bool with_solver_column);
nlohmann::json batch_report_to_json(const BatchReport& report);

}  // namespace tensegrity::cli
