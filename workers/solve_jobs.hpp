#pragma once
// Independent solves, one (scene, backend) job each, in forked worker
// processes (workers/process_pool.hpp), the longest estimated first: what
// `tensegrity batch` runs and what compare_bench's two-core family measures.
#include <functional>
#include <string>
#include <vector>

#include "model/structure.hpp"
#include "solvers/solver.hpp"
#include "workers/process_pool.hpp"

namespace tensegrity {

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

// The deadline after which a worker still on a solve with this time limit (s)
// is killed: twice the limit and a margin, since a backend checks its limit
// only between iterations.
double default_kill_after(double time_limit_s);

// Solves every job, longest estimated first, on settings.workers processes.
// A job whose worker crashed or was killed gets a solution file all the same
// (the scene's positions, zero forces, status numerical_error or time_limit).
SolveJobsRun run_solve_jobs(const std::vector<SolveJob>& jobs, const SolveJobSettings& settings,
                            const SolveJobsObserver& observer = {});

}  // namespace tensegrity
