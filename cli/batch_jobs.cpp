#include "cli/batch_jobs.hpp"

#include <algorithm>
#include <map>

namespace tensegrity::cli {

namespace {

using nlohmann::json;

const char* end_name(JobEnd end) {
  switch (end) {
    case JobEnd::Finished: return "finished";
    case JobEnd::Crashed: return "crashed";
    case JobEnd::Killed: return "killed";
  }
  return "crashed";
}

}  // namespace

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
