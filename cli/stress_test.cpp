#include "cli/stress_test.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <mutex>
#include <random>
#include <set>
#include <thread>

#include "model/errors.hpp"
#include "model/scene_io.hpp"
#include "model/verify.hpp"

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

  // Scenes: names or groups of the built-in set, plus files.
  std::vector<scenes::BaseScene> all = scenes::base_scenes(options.data_dir);
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
  const int total = static_cast<int>(cases.size() * solvers.size());
  report.trials.resize(total);
  std::atomic<int> next{0}, done{0}, failures{0};
  const double overrun_s = 2.0 * options.time_limit_s + 5.0;

  auto work = [&] {
    std::map<std::string, std::unique_ptr<Solver>> instances;
    for (;;) {
      const int k = next.fetch_add(1);
      if (k >= total) return;
      const Case& c = cases[k / solvers.size()];
      const std::string& solver_name = solvers[k % solvers.size()];
      StressTrial& t = report.trials[k];
      t.scene = c.base->name;
      t.family = c.family;
      t.level = c.level;
      t.trial = c.trial;
      t.solver = solver_name;
      if (c.rejected) {
        t.rejected = true;
        t.message = c.rejection;
        done.fetch_add(1);
        continue;
      }
      auto& solver = instances[solver_name];
      if (!solver) solver = make_solver(solver_name);
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
      t.seconds = std::chrono::duration<double>(Clock::now() - start).count();
      t.overran = t.seconds > overrun_s;
      t.status = r.status;
      t.finite = finite_result(r);
      const Verification v = verify(c.scene, r.positions, r.forces, options.tolerance);
      t.verified = v.ok;
      t.relative_residual = v.relative_residual;
      t.message = r.message;
      Digest d;
      d.integer(static_cast<std::uint64_t>(r.status));
      d.bytes(r.positions.data(), sizeof(double) * r.positions.size());
      d.bytes(r.forces.data(), sizeof(double) * r.forces.size());
      t.digest = d.h;
      if (r.status != Status::Converged || !t.verified || !t.finite) {
        failures.fetch_add(1);
        if (!options.failures_dir.empty()) {
          try {
            write_scene_file(c.scene, options.failures_dir + "/" + t.scene + "_" + t.family + "_" + t.level +
                                          "_t" + std::to_string(t.trial) + "_" + t.solver + ".scene.json");
          } catch (const std::exception& e) {
            t.message += std::string(" (scene not saved: ") + e.what() + ")";
          }
        }
      }
      done.fetch_add(1);
    }
  };

  std::vector<std::thread> pool;
  for (int j = 0; j < std::min(options.jobs, std::max(1, total)); ++j) pool.emplace_back(work);
  while (done.load() < total) {
    if (options.progress) options.progress(done.load(), total, failures.load());
    std::this_thread::sleep_for(std::chrono::milliseconds(250));
  }
  for (std::thread& th : pool) th.join();
  if (options.progress) options.progress(done.load(), total, failures.load());
  report.wall_seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  return report;
}

namespace {

using nlohmann::json;

// A JSON number, or null for a non-finite value (which the cell also counts).
json number_or_null(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

struct Cell {
  int trials = 0, rejected = 0, converged = 0, verified = 0, false_converged = 0, non_finite = 0;
  int overran = 0, escaped = 0;
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
  if (times) j["wall_seconds"] = report.wall_seconds;
  return j;
}

}  // namespace tensegrity::cli
