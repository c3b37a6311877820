#include "cli/stress_test.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <set>

#include "cli/stress_cases.hpp"

namespace tensegrity::cli {

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
  scenes::StableDigest digest;

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
  opts["prestress_factor"] = o.prestress_factor;
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

}  // namespace tensegrity::cli
