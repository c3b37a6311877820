#include "cli/stress_test.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <random>
#include <set>

#include "cli/process_pool.hpp"
#include "model/errors.hpp"
#include "model/scene_io.hpp"
#include "model/verify.hpp"
#include "kernels/blas_threads.hpp"

namespace tensegrity::cli {

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

using Digest = scenes::StableDigest;

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

std::vector<std::string> split_names(const std::vector<std::string>& items) {
  std::vector<std::string> out;
  for (const std::string& item : items) {
    std::size_t start = 0;
    while (start <= item.size()) {
      const std::size_t comma = item.find(',', start);
      const std::string name = item.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
      if (!name.empty()) out.push_back(name);
      if (comma == std::string::npos) break;
      start = comma + 1;
    }
  }
  return out;
}

struct Case {
  const scenes::BaseScene* base = nullptr;
  std::string family, level;
  int trial = 0;
  Structure scene;
  bool rejected = false;
  std::string rejection;
};

}  // namespace

StressReport run_stress_test(const StressTestOptions& options) {
  const auto t0 = Clock::now();
  if (options.trials < 1) throw InputError("command line", "--trials", "must be at least 1");
  if (options.jobs < 1) throw InputError("command line", "--jobs", "must be at least 1");
  if (!(options.time_limit_s > 0.0) || !std::isfinite(options.time_limit_s))
    throw InputError("command line", "--time-limit", "must be a finite number > 0");

  std::vector<std::string> families = split_names(options.families);
  if (families.empty()) families = scenes::family_names();
  for (const std::string& f : families) scenes::family_levels(f);  // rejects unknown names
  std::vector<std::string> solvers = split_names(options.solvers);
  if (solvers.empty()) solvers = solver_names();
  SolveOptions solve_options;
  solve_options.tolerance = options.tolerance;
  solve_options.time_limit_s = options.time_limit_s;
  solve_options.backend_options = options.backend_options;
  std::string why;
  if (!solve_options.IsValid(&why)) throw InputError("command line", "options", why);
  for (const std::string& name : solvers) make_solver(name)->ValidateOptions(solve_options);

  // Scenes: names or groups of the built-in set, plus files. Usage errors
  // above come first, so that a bad option gets its one line alone.
  std::vector<scenes::SkippedFile> skipped;
  std::vector<scenes::BaseScene> all = scenes::base_scenes(options.data_dir, &skipped);
  for (const scenes::SkippedFile& file : skipped) std::fprintf(stderr, "tensegrity: %s\n", file.reason.c_str());
  std::fflush(stderr);
  for (const std::string& file : options.scene_files) {
    Structure s = read_scene_file(file);
    std::string name = fs::path(file).filename().string();
    if (name.ends_with(".scene.json")) name.erase(name.size() - std::string(".scene.json").size());
    if (s.name.empty()) s.name = name;
    all.push_back({name, "file", std::move(s)});
  }
  std::vector<const scenes::BaseScene*> scenes;
  const std::vector<std::string> wanted = split_names(options.scenes);
  for (const scenes::BaseScene& b : all) {
    bool chosen = wanted.empty() || b.group == "file";
    for (const std::string& w : wanted) chosen = chosen || w == b.name || w == b.group || w == "all";
    if (chosen) scenes.push_back(&b);
  }
  for (const std::string& w : wanted) {
    const bool known = w == "all" || std::any_of(all.begin(), all.end(), [&](const scenes::BaseScene& b) {
                         return w == b.name || w == b.group;
                       });
    if (!known) {
      std::string names;
      for (const scenes::BaseScene& b : all) names += (names.empty() ? "" : ", ") + b.name;
      throw InputError("command line", "--scenes " + w,
                       "unknown scene (known: groups reference, tower, character; " + names + ")");
    }
  }

  std::vector<Case> cases;
  for (const scenes::BaseScene* b : scenes)
    for (const std::string& family : families) {
      const auto levels = scenes::family_levels(family);
      for (int l = 0; l < static_cast<int>(levels.size()); ++l)
        for (int t = 0; t < options.trials; ++t) {
          Case c;
          c.base = b;
          c.family = family;
          c.level = levels[l].label;
          c.trial = t;
          c.scene = scenes::make_family_case(b->scene, family, l, t, options.seed);
          try {
            validate(c.scene, c.scene.name);
          } catch (const InputError& e) {
            c.rejected = true;
            c.rejection = e.what();
          }
          cases.push_back(std::move(c));
        }
    }

  StressReport report;
  report.options = options;
  report.skipped = std::move(skipped);
  const std::size_t total = cases.size() * solvers.size();
  report.trials.resize(total);
  const double overrun_s = 2.0 * options.time_limit_s + 5.0;
  std::vector<std::size_t> job_trial;  // the trial of each job (rejected cases are not run)
  std::vector<double> cost;
  for (std::size_t k = 0; k < total; ++k) {
    const Case& c = cases[k / solvers.size()];
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
    const Case& c = cases[k / solvers.size()];
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
    Digest d;
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

  // Fills a trial from its worker's answer, or from how the worker ended.
  auto record = [&](std::size_t job, const JobOutcome& o) {
    const std::size_t k = job_trial[job];
    const Case& c = cases[k / solvers.size()];
    StressTrial& t = report.trials[k];
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
      Digest d;
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
  if (options.measure_speedup && options.jobs > 1) {
    ProcessPoolOptions one = pool;
    one.workers = 1;
    report.serial_wall_seconds = run_in_worker_processes(job_trial.size(), order, solve_trial, one).wall_seconds;
  }
  int ended = static_cast<int>(total - job_trial.size()), failures = 0;
  pool.on_job_end = [&](std::size_t job, const JobOutcome& o) {
    record(job, o);
    const StressTrial& t = report.trials[job_trial[job]];
    if (t.status != Status::Converged || !t.verified || !t.finite) ++failures;
    ++ended;
    if (options.progress) options.progress(ended, static_cast<int>(total), failures);
  };
  if (options.progress) options.progress(ended, static_cast<int>(total), failures);
  const ProcessPoolRun run = run_in_worker_processes(job_trial.size(), order, solve_trial, pool);
  report.cpu_seconds = run.cpu_seconds;
  for (const JobOutcome& o : run.outcomes) report.sum_job_wall_seconds += o.wall_seconds;
  report.wall_seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  report.pool_wall_seconds = run.wall_seconds;
  return report;
}

namespace {

using nlohmann::json;

// A JSON number, or null for a non-finite value (which the cell also counts).
json number_or_null(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

struct Cell {
  int trials = 0, rejected = 0, converged = 0, verified = 0, false_converged = 0, non_finite = 0;
  int overran = 0, escaped = 0, crashed = 0;
  double worst_converged_residual = 0.0;
  std::vector<double> seconds;
  std::map<std::string, int> statuses;
  Digest digest;

  void add(const StressTrial& t) {
    digest.integer(t.digest);
    if (t.rejected) {
      ++rejected;
      return;
    }
    ++trials;
    ++statuses[std::string(to_string(t.status))];
    if (!t.finite) ++non_finite;
    if (t.overran) ++overran;
    if (t.crashed) ++crashed;
    if (t.message.rfind("exception escaped", 0) == 0) ++escaped;
    if (t.status == Status::Converged) {
      ++converged;
      if (t.verified)
        ++verified;
      else
        ++false_converged;
      worst_converged_residual = std::max(worst_converged_residual,
                                          std::isfinite(t.relative_residual) ? t.relative_residual : INFINITY);
    }
    seconds.push_back(t.seconds);
  }

  json to_json(bool with_times) {
    json j = json::object();
    j["trials"] = trials;
    j["rejected_inputs"] = rejected;
    j["converged"] = converged;
    j["success_rate"] = trials > 0 ? static_cast<double>(converged) / trials : 0.0;
    j["verified"] = verified;
    j["verified_rate"] = converged > 0 ? static_cast<double>(verified) / converged : 1.0;
    j["false_converged"] = false_converged;
    j["worst_relative_residual"] = number_or_null(worst_converged_residual);
    j["non_finite"] = non_finite;
    j["exceptions"] = escaped;
    j["crashed"] = crashed;
    j["statuses"] = statuses;
    if (with_times) {
      std::vector<double> s = seconds;
      std::sort(s.begin(), s.end());
      j["median_seconds"] = s.empty() ? 0.0 : s[s.size() / 2];
      j["worst_seconds"] = s.empty() ? 0.0 : s.back();
      j["overran"] = overran;
    }
    char hex[20];
    std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(digest.h));
    j["digest"] = hex;
    return j;
  }
};

bool noise_up_to_10_percent(const StressTrial& t) {
  return t.family == "noise" && std::atof(t.level.c_str()) <= 0.1 + 1e-12;
}

}  // namespace

json stress_report_to_json(const StressReport& report) {
  const StressTestOptions& o = report.options;
  const bool times = o.with_times;
  json j = json::object();
  j["format"] = "tensegrity-stress-report";
  j["version"] = 1;
  json opts = json::object();
  opts["scenes"] = split_names(o.scenes);
  opts["scene_files"] = o.scene_files;
  opts["solvers"] = split_names(o.solvers);
  opts["families"] = split_names(o.families);
  opts["trials"] = o.trials;
  opts["seed"] = o.seed;
  opts["time_limit_s"] = o.time_limit_s;
  opts["tolerance"] = o.tolerance;
  if (!o.backend_options.empty()) opts["backend_options"] = o.backend_options;
  if (times) opts["jobs"] = o.jobs;
  j["options"] = opts;

  // Ordered maps keyed by the names, so the output order is fixed.
  std::map<std::string, std::map<std::string, Cell>> by_family;
  std::map<std::string, std::map<std::string, std::map<std::string, Cell>>> by_level;
  std::map<std::string, std::map<std::string, Cell>> noise_by_scene;
  std::map<std::string, Cell> noise_total, overall;
  std::set<std::string> scene_names;
  for (const StressTrial& t : report.trials) {
    by_family[t.solver][t.family].add(t);
    by_level[t.solver][t.family][t.level].add(t);
    overall[t.solver].add(t);
    scene_names.insert(t.scene);
    if (noise_up_to_10_percent(t)) {
      noise_total[t.solver].add(t);
      noise_by_scene[t.solver][t.scene].add(t);
    }
  }
  j["scenes"] = scene_names;
  json solvers = json::object();
  for (auto& [solver, families] : by_family) {
    json s = json::object();
    s["overall"] = overall[solver].to_json(times);
    if (noise_total.count(solver)) {
      json n = noise_total[solver].to_json(times);
      json per_scene = json::object();
      for (auto& [scene, cell] : noise_by_scene[solver]) {
        json c = json::object();
        c["trials"] = cell.trials;
        c["converged"] = cell.converged;
        c["verified"] = cell.verified;
        per_scene[scene] = c;
      }
      n["by_scene"] = per_scene;
      s["noise_up_to_10_percent"] = n;
    }
    json fam = json::object();
    for (auto& [family, cell] : families) {
      json f = cell.to_json(times);
      json levels = json::object();
      for (auto& [level, lc] : by_level[solver][family]) levels[level] = lc.to_json(times);
      f["by_level"] = levels;
      fam[family] = f;
    }
    s["families"] = fam;
    solvers[solver] = s;
  }
  j["solvers"] = solvers;

  json failures = json::array();
  for (const StressTrial& t : report.trials) {
    if (t.rejected || (t.status == Status::Converged && t.verified && t.finite)) continue;
    json f = json::object();
    f["solver"] = t.solver;
    f["scene"] = t.scene;
    f["family"] = t.family;
    f["level"] = t.level;
    f["trial"] = t.trial;
    f["status"] = to_string(t.status);
    f["verified"] = t.verified;
    f["finite"] = t.finite;
    f["relative_residual"] = number_or_null(t.relative_residual);
    // Messages may quote remaining time budgets: only with timings.
    if (times) {
      f["seconds"] = t.seconds;
      f["message"] = t.message.size() > 300 ? t.message.substr(0, 297) + "..." : t.message;
    }
    failures.push_back(f);
  }
  j["failures"] = failures;
  json rejected = json::array();
  std::set<std::string> seen;
  for (const StressTrial& t : report.trials)
    if (t.rejected && seen.insert(t.scene + "/" + t.family + "/" + t.level + "/" + std::to_string(t.trial)).second)
      rejected.push_back(t.scene + "/" + t.family + "/" + t.level + "/" + std::to_string(t.trial) + ": " +
                         t.message);
  j["rejected_inputs"] = rejected;
  json skipped = json::array();
  for (const scenes::SkippedFile& file : report.skipped) skipped.push_back({{"file", file.file}, {"reason", file.reason}});
  j["skipped"] = skipped;

  // Every solve, in the report's fixed order.
  json trials = json::array();
  std::map<std::string, int> statuses;
  int solved = 0, converged = 0, crashed = 0;
  for (const StressTrial& t : report.trials) {
    if (t.rejected) continue;
    json e = json::object();
    e["scene"] = t.scene;
    e["family"] = t.family;
    e["level"] = t.level;
    e["trial"] = t.trial;
    e["solver"] = t.solver;
    e["status"] = to_string(t.status);
    e["iterations"] = t.iterations;
    if (times) {
      e["seconds"] = t.seconds;
      e["wall_seconds"] = t.wall_seconds;
    }
    e["geometry_change"] = number_or_null(t.geometry_change);
    e["relative_residual"] = number_or_null(t.relative_residual);
    e["verified"] = t.verified;
    if (t.crashed) e["crashed"] = true;
    trials.push_back(e);
    ++solved;
    ++statuses[std::string(to_string(t.status))];
    if (t.status == Status::Converged) ++converged;
    if (t.crashed) ++crashed;
  }
  j["trials"] = trials;
  json totals = json::object();
  totals["solves"] = solved;
  totals["rejected_inputs"] = static_cast<int>(report.trials.size()) - solved;
  totals["converged"] = converged;
  totals["crashed"] = crashed;
  totals["statuses"] = statuses;
  totals["skipped_files"] = report.skipped.size();
  if (times) {
    totals["wall_seconds"] = report.pool_wall_seconds;
    totals["cpu_seconds"] = report.cpu_seconds;
    totals["sum_job_wall_seconds"] = report.sum_job_wall_seconds;
    json speedup = json::object();
    speedup["workers"] = o.jobs;
    speedup["estimate"] = report.sum_job_wall_seconds / std::max(1e-9, report.pool_wall_seconds);
    if (report.serial_wall_seconds > 0.0) {
      speedup["serial_wall_seconds"] = report.serial_wall_seconds;
      speedup["measured"] = report.serial_wall_seconds / std::max(1e-9, report.pool_wall_seconds);
    }
    j["speedup"] = speedup;
  }
  j["totals"] = totals;
  if (times) j["wall_seconds"] = report.wall_seconds;
  return j;
}

void print_stress_table(const StressReport& report, std::FILE* out) {
  // Statuses in the order of the contract, then the rest of the row.
  const Status columns[] = {Status::Converged, Status::Stalled, Status::MaxIterations, Status::TimeLimit,
                            Status::NumericalError, Status::Infeasible};
  struct Row {
    int trials = 0, rejected = 0, crashed = 0;
    std::map<Status, int> counts;
    std::vector<double> seconds;
  };
  std::map<std::string, Row> rows;
  for (const StressTrial& t : report.trials) {
    Row& r = rows[t.solver];
    if (t.rejected) {
      ++r.rejected;
      continue;
    }
    ++r.trials;
    ++r.counts[t.status];
    if (t.crashed) ++r.crashed;
    r.seconds.push_back(t.seconds);
  }
  std::fprintf(out, "%-16s %6s", "backend", "trials");
  for (const Status s : columns) std::fprintf(out, " %15s", std::string(to_string(s)).c_str());
  std::fprintf(out, " %8s %7s %10s\n", "rejected", "crashed", "median_s");
  for (auto& [solver, r] : rows) {
    std::fprintf(out, "%-16s %6d", solver.c_str(), r.trials);
    for (const Status s : columns) std::fprintf(out, " %15d", r.counts[s]);
    std::sort(r.seconds.begin(), r.seconds.end());
    double median = 0.0;
    if (!r.seconds.empty()) {
      const std::size_t n = r.seconds.size();
      median = n % 2 == 1 ? r.seconds[n / 2] : 0.5 * (r.seconds[n / 2 - 1] + r.seconds[n / 2]);
    }
    std::fprintf(out, " %8d %7d %10.4f\n", r.rejected, r.crashed, median);
  }
  std::fprintf(out, "jobs %d: wall %.3f s, process CPU %.3f s (%.2f cores busy), sum of job wall times %.3f s\n",
               report.options.jobs, report.pool_wall_seconds, report.cpu_seconds,
               report.cpu_seconds / std::max(1e-9, report.pool_wall_seconds), report.sum_job_wall_seconds);
  if (report.serial_wall_seconds > 0.0)
    std::fprintf(out, "jobs 1: wall %.3f s\nmeasured speed-up (serial wall / parallel wall): %.2f\n",
                 report.serial_wall_seconds, report.serial_wall_seconds / std::max(1e-9, report.pool_wall_seconds));
  std::fprintf(out, "speed-up estimate (sum of job wall times / wall): %.2f\n",
               report.sum_job_wall_seconds / std::max(1e-9, report.pool_wall_seconds));
  if (!report.skipped.empty()) std::fprintf(out, "skipped %zu unreadable data files\n", report.skipped.size());
  std::fflush(out);
}

}  // namespace tensegrity::cli
