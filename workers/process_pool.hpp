#pragma once
// Independent jobs in forked worker processes (`batch`, `stress-test`,
// compare_bench's two-core family).
//
// Threads of one process would take turns through the process-wide MUMPS lock
// of every Ipopt run (kernels/ipopt_solve.hpp); processes share nothing, so N
// workers run N solves at once. Each worker is forked from the coordinating
// process, which holds every input already, and receives only job numbers; a
// job's result travels back as a string (the caller's serialisation). A worker
// that dies (a crash, the kernel's out-of-memory killer) or overruns its
// deadline ends that job with an outcome, never the run: it is replaced and
// the other jobs go on. SIGINT or SIGTERM stop and reap every worker first,
// then end the program by the same signal.
//
// The coordinating process must be single-threaded when it calls
// run_in_worker_processes (fork copies only the calling thread).
#include <cstddef>
#include <functional>
#include <string>
#include <vector>

namespace tensegrity {

enum class JobEnd {
  Finished,  // the job returned its result
  Crashed,   // the worker died or the job threw; `reason` says how
  Killed,    // still running at its deadline: the worker was killed
};

struct JobOutcome {
  JobEnd end = JobEnd::Crashed;
  std::string result;          // the job's return value when Finished
  std::string reason;          // why it did not finish, in words
  double wall_seconds = 0.0;   // from handing the job out to its end (s)
};

struct ProcessPoolOptions {
  int workers = 1;
  double kill_after_s = 0.0;   // a job's deadline (s); 0: none
  // Called by the coordinating process when a job has ended: its number and outcome.
  std::function<void(std::size_t, const JobOutcome&)> on_job_end;
  // Called by the coordinating process while it waits, at least every
  // tick_interval_s, so that a status line can show the time between job ends.
  std::function<void()> on_tick;
  double tick_interval_s = 0.25;  // s
};

struct ProcessPoolRun {
  std::vector<JobOutcome> outcomes;  // indexed by job number
  double wall_seconds = 0.0;
  double cpu_seconds = 0.0;          // of the workers and the coordinator together
};

// Runs jobs 0..total-1, handed out in `order` (every job number once) to at
// most options.workers processes at a time. `job` runs in a worker.
ProcessPoolRun run_in_worker_processes(std::size_t total, const std::vector<std::size_t>& order,
                                       const std::function<std::string(std::size_t)>& job,
                                       const ProcessPoolOptions& options);

// The cores this process may run on (its CPU affinity mask), at least 1.
int available_cores();

// Job numbers sorted by decreasing estimated cost (ties: the given order), so
// that the longest jobs start first and short ones fill the gaps at the end.
std::vector<std::size_t> longest_first(const std::vector<double>& estimated_cost);

// Relative cost of one solve: element count times a per-backend factor from
// the project's benchmark timings (docs/BENCHMARKS.md); only the order matters.
double estimated_solve_cost(const std::string& backend, int elements);

}  // namespace tensegrity
