#include "workers/solve_jobs.hpp"

#include <nlohmann/json.hpp>
#include <utility>

#include "kernels/blas_threads.hpp"
#include "model/solution.hpp"
#include "model/verify.hpp"
#include "solvers/trace_csv.hpp"

namespace tensegrity {

namespace {

using nlohmann::json;

// What a worker sends back: the numbers of the report, exactly (nlohmann
// writes doubles in their shortest round-trip form).
std::string solve_in_worker(const SolveJob& job, const SolveJobSettings& settings) {
  const auto solver = make_solver(job.solver);
  const SolveResult r = solver->Solve(*job.scene, settings.options, settings.controls);
  if (settings.write_files) {
    write_solution_file(to_solution(r, *job.scene, job.solver), job.solution_file);
    if (!job.trace_file.empty()) write_trace_csv(job.trace_file, r.trace);
  }
  json j = json::object();
  j["status"] = to_string(r.status);
  j["iterations"] = r.stats.iterations;
  j["seconds"] = r.stats.seconds;
  j["residual"] = r.stats.residual;
  j["relative_residual"] = r.stats.relative_residual;
  j["geometry_change"] = r.stats.geometry_change;
  j["message"] = r.message;
  return j.dump();
}

SolveJobResult from_worker(const std::string& text) {
  const json j = json::parse(text);
  SolveJobResult r;
  r.status = status_from_string(j.at("status").get<std::string>()).value_or(Status::NumericalError);
  r.iterations = j.at("iterations").get<int>();
  r.seconds = j.at("seconds").get<double>();
  r.residual = j.at("residual").get<double>();
  r.relative_residual = j.at("relative_residual").get<double>();
  r.geometry_change = j.at("geometry_change").get<double>();
  r.message = j.at("message").get<std::string>();
  return r;
}

// A job without a result from its worker: the scene unchanged, no forces,
// and a status that says why (written like any other solution).
SolveJobResult without_worker_result(const SolveJob& job, const JobOutcome& outcome, const SolveJobSettings& settings) {
  SolveResult r;
  r.status = outcome.end == JobEnd::Killed ? Status::TimeLimit : Status::NumericalError;
  r.message = outcome.reason;
  r.positions = job.scene->positions;
  r.forces = Eigen::VectorXd::Zero(job.scene->num_elements());
  const Verification v = verify(*job.scene, r.positions, r.forces, settings.options.tolerance);
  r.stats.seconds = outcome.wall_seconds;
  r.stats.residual = v.residual;
  r.stats.relative_residual = v.relative_residual;
  r.stats.geometry_change = 0.0;
  if (settings.write_files) write_solution_file(to_solution(r, *job.scene, job.solver), job.solution_file);
  SolveJobResult out;
  out.status = r.status;
  out.seconds = r.stats.seconds;
  out.residual = r.stats.residual;
  out.relative_residual = r.stats.relative_residual;
  out.message = r.message;
  return out;
}

// A worker's deadline beyond twice the time limit (s).
constexpr double kKillMargin = 5.0;

}  // namespace

double default_kill_after(double time_limit_s) { return 2.0 * time_limit_s + kKillMargin; }

SolveJobsRun run_solve_jobs(const std::vector<SolveJob>& jobs, const SolveJobSettings& settings,
                            const SolveJobsObserver& observer) {
  use_one_blas_thread();
  std::vector<double> cost;
  for (const SolveJob& job : jobs) cost.push_back(estimated_solve_cost(job.solver, job.scene->num_elements()));
  SolveJobsRun run;
  run.results.resize(jobs.size());
  ProcessPoolOptions pool;
  pool.workers = settings.workers;
  pool.kill_after_s = settings.kill_after_s;
  pool.on_job_end = [&](std::size_t i, const JobOutcome& o) {
    SolveJobResult r = o.end == JobEnd::Finished ? from_worker(o.result) : without_worker_result(jobs[i], o, settings);
    r.end = o.end;
    r.wall_seconds = o.wall_seconds;
    if (observer.on_job_end) observer.on_job_end(r);
    run.results[i] = std::move(r);
  };
  pool.on_tick = observer.on_tick;
  const ProcessPoolRun done = run_in_worker_processes(
      jobs.size(), longest_first(cost), [&](std::size_t i) { return solve_in_worker(jobs[i], settings); }, pool);

  run.wall_seconds = done.wall_seconds;
  run.cpu_seconds = done.cpu_seconds;
  for (const SolveJobResult& r : run.results) {
    run.sum_solve_seconds += r.seconds;
    run.sum_job_wall_seconds += r.wall_seconds;
    if (r.status == Status::Converged) ++run.converged;
  }
  return run;
}

}  // namespace tensegrity
