#include "cli/stress_cases.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "model/errors.hpp"
#include "model/scene_io.hpp"

namespace tensegrity::cli {

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

StressPlan plan_stress_test(const StressTestOptions& options) {
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
  solve_options.prestress_factor = options.prestress_factor;
  solve_options.backend_options = options.backend_options;
  std::string why;
  if (!solve_options.IsValid(&why)) throw InputError("command line", "options", why);
  for (const std::string& name : solvers) make_solver(name)->ValidateOptions(solve_options);

  // Scenes: names or groups of the built-in set, plus files. Usage errors
  // above come first, so that a bad option gets its one line alone.
  StressPlan plan;
  std::vector<scenes::BaseScene>& all = plan.bases;
  all = scenes::base_scenes(options.data_dir, &plan.skipped);
  for (const scenes::SkippedFile& file : plan.skipped) std::fprintf(stderr, "tensegrity: %s\n", file.reason.c_str());
  std::fflush(stderr);
  for (const std::string& file : options.scene_files) {
    Structure s = read_scene_file(file);
    std::string name = std::filesystem::path(file).filename().string();
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

  for (const scenes::BaseScene* b : scenes)
    for (const std::string& family : families) {
      const auto levels = scenes::family_levels(family);
      for (int l = 0; l < static_cast<int>(levels.size()); ++l)
        for (int t = 0; t < options.trials; ++t) {
          StressCase c;
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
          plan.cases.push_back(std::move(c));
        }
    }

  plan.solvers = std::move(solvers);
  plan.solve_options = std::move(solve_options);
  return plan;
}

}  // namespace tensegrity::cli
