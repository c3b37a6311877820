#include "cli/batch_jobs.hpp"

#include <algorithm>
#include <map>

#include "model/solution.hpp"
#include "model/verify.hpp"
#include "solvers/trace_csv.hpp"
#include "kernels/blas_threads.hpp"

namespace tensegrity::cli {

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

const char* end_name(JobEnd end) {
  switch (end) {
    case JobEnd::Finished: return "finished";
    case JobEnd::Crashed: return "crashed";
    case JobEnd::Killed: return "killed";
  }
  return "crashed";
}

}  // namespace

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

void print_batch_table(const BatchReport& report, std::FILE* out, bool with_solver_column) {
  const std::vector<SolveJob>& jobs = *report.jobs;
  const SolveJobsRun& run = *report.run;
  std::fprintf(out, "%-28s %-15s %6s %10s %12s %12s%s\n", "scene", "status", "iters", "seconds", "rel_residual",
               "geom_change", with_solver_column ? "  solver" : "");
  for (std::size_t i = 0; i < jobs.size(); ++i) {
    const SolveJobResult& r = run.results[i];
    std::fprintf(out, "%-28s %-15s %6d %10.4f %12.3g %12.4g%s%s\n", jobs[i].scene_name.c_str(),
                 std::string(to_string(r.status)).c_str(), r.iterations, r.seconds, r.relative_residual,
                 r.geometry_change, with_solver_column ? "  " : "", with_solver_column ? jobs[i].solver.c_str() : "");
  }
  std::fprintf(out, "jobs %d: wall %.3f s, process CPU %.3f s (%.2f cores busy), sum of solve times %.3f s\n",
               report.workers, run.wall_seconds, run.cpu_seconds, run.cpu_seconds / std::max(1e-9, run.wall_seconds),
               run.sum_solve_seconds);
  if (report.serial)
    std::fprintf(out, "jobs 1: wall %.3f s, process CPU %.3f s\nmeasured speed-up (serial wall / parallel wall): %.2f\n",
                 report.serial->wall_seconds, report.serial->cpu_seconds,
                 report.serial->wall_seconds / std::max(1e-9, run.wall_seconds));
  std::fprintf(out, "speed-up estimate (sum of job wall times / wall): %.2f\n",
               run.sum_job_wall_seconds / std::max(1e-9, run.wall_seconds));
  std::fprintf(out, "converged %zu of %zu\n", run.converged, jobs.size());
  if (!report.skipped.empty()) std::fprintf(out, "skipped %zu unreadable scene files\n", report.skipped.size());
  std::fflush(out);
}

json batch_report_to_json(const BatchReport& report) {
  const std::vector<SolveJob>& jobs = *report.jobs;
  const SolveJobsRun& run = *report.run;
  const SolveJobSettings& settings = *report.settings;
  json j = json::object();
  j["format"] = "tensegrity-batch-report";
  j["version"] = 1;
  json options = json::object();
  std::vector<std::string> solvers;
  for (const SolveJob& job : jobs)
    if (std::find(solvers.begin(), solvers.end(), job.solver) == solvers.end()) solvers.push_back(job.solver);
  options["solvers"] = solvers;
  options["jobs"] = report.workers;
  options["tolerance"] = settings.options.tolerance;
  options["max_iterations"] = settings.options.max_iterations;
  options["time_limit_s"] = settings.options.time_limit_s;
  options["prestress_factor"] = settings.options.prestress_factor;
  options["kill_after_s"] = settings.kill_after_s;
  options["skip_if_in_equilibrium"] = settings.controls.skip_if_in_equilibrium;
  j["options"] = options;

  json list = json::array();
  std::map<std::string, int> statuses;
  for (std::size_t i = 0; i < jobs.size(); ++i) {
    const SolveJobResult& r = run.results[i];
    json e = json::object();
    e["scene"] = jobs[i].scene_name;
    e["file"] = jobs[i].scene_file;
    e["solver"] = jobs[i].solver;
    e["status"] = to_string(r.status);
    e["iterations"] = r.iterations;
    e["seconds"] = r.seconds;
    e["wall_seconds"] = r.wall_seconds;
    e["residual"] = r.residual;
    e["relative_residual"] = r.relative_residual;
    e["geometry_change"] = r.geometry_change;
    e["worker"] = end_name(r.end);
    e["solution"] = jobs[i].solution_file;
    if (!r.message.empty()) e["message"] = r.message;
    list.push_back(e);
    ++statuses[std::string(to_string(r.status))];
  }
  j["jobs"] = list;

  json skipped = json::array();
  for (const auto& [file, reason] : report.skipped) skipped.push_back({{"file", file}, {"reason", reason}});
  j["skipped"] = skipped;

  json totals = json::object();
  totals["jobs"] = jobs.size();
  totals["converged"] = run.converged;
  totals["statuses"] = statuses;
  totals["skipped_files"] = report.skipped.size();
  totals["wall_seconds"] = run.wall_seconds;
  totals["cpu_seconds"] = run.cpu_seconds;
  totals["sum_solve_seconds"] = run.sum_solve_seconds;
  totals["sum_job_wall_seconds"] = run.sum_job_wall_seconds;
  j["totals"] = totals;

  json speedup = json::object();
  speedup["workers"] = report.workers;
  speedup["estimate"] = run.sum_job_wall_seconds / std::max(1e-9, run.wall_seconds);
  if (report.serial) {
    speedup["serial_wall_seconds"] = report.serial->wall_seconds;
    speedup["measured"] = report.serial->wall_seconds / std::max(1e-9, run.wall_seconds);
  }
  j["speedup"] = speedup;
  return j;
}

}  // namespace tensegrity::cli
