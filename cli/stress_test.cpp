#include "cli/stress_test.hpp"

#include <chrono>
#include <cmath>
#include <exception>

#include "cli/stress_cases.hpp"
#include "kernels/blas_threads.hpp"
#include "model/scene_io.hpp"
#include "model/verify.hpp"
#include "workers/solve_jobs.hpp"

namespace tensegrity::cli {

namespace {

using Clock = std::chrono::steady_clock;

bool finite_result(const SolveResult& r) {
  if (!r.positions.allFinite() || !r.forces.allFinite()) return false;
  const SolutionStats& st = r.stats;
  for (double v : {st.seconds, st.residual, st.relative_residual, st.geometry_change})
    if (!std::isfinite(v)) return false;
  for (const TracePoint& p : r.trace)
    for (double v : {p.seconds, p.residual, p.relative_residual, p.geometry_change, p.objective})
      if (!std::isfinite(v)) return false;
  return true;
}

}  // namespace

StressReport run_stress_test(const StressTestOptions& options) {
  const auto t0 = Clock::now();
  StressPlan plan = plan_stress_test(options);
  const std::vector<StressCase>& cases = plan.cases;
  const std::vector<std::string>& solvers = plan.solvers;
  const SolveOptions& solve_options = plan.solve_options;

  StressReport report;
  report.options = options;
  report.skipped = std::move(plan.skipped);
  const std::size_t total = cases.size() * solvers.size();
  report.trials.resize(total);
  const double overrun_s = default_kill_after(options.time_limit_s);
  std::vector<std::size_t> job_trial;  // the trial of each job (rejected cases are not run)
  std::vector<double> cost;
  for (std::size_t k = 0; k < total; ++k) {
    const StressCase& c = cases[k / solvers.size()];
    StressTrial& t = report.trials[k];
    t.scene = c.base->name;
    t.family = c.family;
    t.level = c.level;
    t.trial = c.trial;
    t.solver = solvers[k % solvers.size()];
    if (c.rejected) {
      t.rejected = true;
      t.message = c.rejection;
      continue;
    }
    job_trial.push_back(k);
    cost.push_back(estimated_solve_cost(t.solver, c.scene.num_elements()));
  }

  // Runs in a worker process: the fields of the trial that the solve decides.
  auto solve_trial = [&](std::size_t job) {
    const std::size_t k = job_trial[job];
    const StressCase& c = cases[k / solvers.size()];
    const std::string& solver_name = solvers[k % solvers.size()];
    const auto solver = make_solver(solver_name);
    const auto start = Clock::now();
    SolveResult r;
    try {
      r = solve_scene(*solver, c.scene, solve_options);
    } catch (const std::exception& e) {
      r = SolveResult{};
      r.status = Status::NumericalError;
      r.message = std::string("exception escaped the driver: ") + e.what();
      r.positions = c.scene.positions;
      r.forces = Eigen::VectorXd::Zero(c.scene.num_elements());
    }
    const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
    const Verification v = verify(c.scene, r.positions, r.forces, options.tolerance);
    scenes::StableDigest d;
    d.integer(static_cast<std::uint64_t>(r.status));
    d.bytes(r.positions.data(), sizeof(double) * r.positions.size());
    d.bytes(r.forces.data(), sizeof(double) * r.forces.size());
    const bool finite = finite_result(r);
    std::string message = r.message;
    if ((r.status != Status::Converged || !v.ok || !finite) && !options.failures_dir.empty()) {
      const StressTrial& t = report.trials[k];
      try {
        write_scene_file(c.scene, options.failures_dir + "/" + t.scene + "_" + t.family + "_" + t.level + "_t" +
                                      std::to_string(t.trial) + "_" + t.solver + ".scene.json");
      } catch (const std::exception& e) {
        message += std::string(" (scene not saved: ") + e.what() + ")";
      }
    }
    nlohmann::json j = nlohmann::json::object();
    j["status"] = to_string(r.status);
    j["seconds"] = seconds;
    j["iterations"] = r.stats.iterations;
    j["geometry_change"] = r.stats.geometry_change;
    // Not finite: JSON has no such number; the flag below says so.
    j["relative_residual"] = std::isfinite(v.relative_residual) ? nlohmann::json(v.relative_residual) : nlohmann::json();
    j["verified"] = v.ok;
    j["finite"] = finite;
    j["digest"] = d.h;
    j["message"] = message;
    return j.dump();
  };

  // Fills trial `t` of `job` from its worker's answer, or from how the worker ended.
  auto record = [&](std::size_t job, const JobOutcome& o, StressTrial& t) {
    const std::size_t k = job_trial[job];
    const StressCase& c = cases[k / solvers.size()];
    t.wall_seconds = o.wall_seconds;
    if (o.end == JobEnd::Finished) {
      const nlohmann::json j = nlohmann::json::parse(o.result);
      t.status = status_from_string(j.at("status").get<std::string>()).value_or(Status::NumericalError);
      t.seconds = j.at("seconds").get<double>();
      t.iterations = j.at("iterations").get<int>();
      t.geometry_change = j.at("geometry_change").get<double>();
      t.relative_residual = j.at("relative_residual").is_null() ? NAN : j.at("relative_residual").get<double>();
      t.verified = j.at("verified").get<bool>();
      t.finite = j.at("finite").get<bool>();
      t.digest = j.at("digest").get<std::uint64_t>();
      t.message = j.at("message").get<std::string>();
    } else {
      t.status = o.end == JobEnd::Killed ? Status::TimeLimit : Status::NumericalError;
      t.seconds = o.wall_seconds;
      t.crashed = o.end == JobEnd::Crashed;
      t.verified = false;
      t.relative_residual = verify(c.scene, c.scene.positions, Eigen::VectorXd::Zero(c.scene.num_elements()),
                                   options.tolerance).relative_residual;
      t.message = o.reason;
      scenes::StableDigest d;
      d.integer(static_cast<std::uint64_t>(t.status));
      t.digest = d.h;
    }
    t.overran = o.end == JobEnd::Killed || t.seconds > overrun_s;
  };

  use_one_blas_thread();
  ProcessPoolOptions pool;
  pool.workers = options.jobs;
  pool.kill_after_s = overrun_s;
  const std::vector<std::size_t> order = longest_first(cost);
  const StressObserver& observer = options.observer;
  pool.on_tick = observer.on_tick;
  auto failed = [](const StressTrial& t) { return t.status != Status::Converged || !t.verified || !t.finite; };
  if (options.measure_speedup && options.jobs > 1) {
    ProcessPoolOptions one = pool;
    one.workers = 1;
    // The trials' numbers come from the parallel pass; this one only counts failures for the display.
    one.on_job_end = [&](std::size_t job, const JobOutcome& o) {
      StressTrial t = report.trials[job_trial[job]];
      record(job, o, t);
      if (observer.on_trial_end) observer.on_trial_end(failed(t));
    };
    if (observer.on_pass_start) observer.on_pass_start(total, total - job_trial.size(), 1, true);
    report.serial_wall_seconds = run_in_worker_processes(job_trial.size(), order, solve_trial, one).wall_seconds;
  }
  pool.on_job_end = [&](std::size_t job, const JobOutcome& o) {
    StressTrial& t = report.trials[job_trial[job]];
    record(job, o, t);
    if (observer.on_trial_end) observer.on_trial_end(failed(t));
  };
  if (observer.on_pass_start) observer.on_pass_start(total, total - job_trial.size(), options.jobs, false);
  const ProcessPoolRun run = run_in_worker_processes(job_trial.size(), order, solve_trial, pool);
  report.cpu_seconds = run.cpu_seconds;
  for (const JobOutcome& o : run.outcomes) report.sum_job_wall_seconds += o.wall_seconds;
  report.wall_seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  report.pool_wall_seconds = run.wall_seconds;
  return report;
}

}  // namespace tensegrity::cli
