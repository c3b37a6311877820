#pragma once
// The perturbed scenes of `tensegrity stress-test` (cli/stress_test.hpp): the
// chosen base scenes, each perturbed by every chosen family, level and trial
// (scenes/families.hpp), and the backends and solve options of the run.
#include <string>
#include <vector>

#include "cli/stress_test.hpp"
#include "model/structure.hpp"
#include "scenes/families.hpp"
#include "solvers/solver.hpp"

namespace tensegrity::cli {

// The names in comma-separated items, empty ones left out.
std::vector<std::string> split_names(const std::vector<std::string>& items);

// One perturbed scene: base scene, family, level and trial.
struct StressCase {
  const scenes::BaseScene* base = nullptr;  // in StressPlan::bases
  std::string family, level;
  int trial = 0;
  Structure scene;
  bool rejected = false;  // the perturbed scene broke a rule of the model (not run)
  std::string rejection;
};

// Cases point into `bases`: a plan is moved, never copied.
struct StressPlan {
  StressPlan() = default;
  StressPlan(StressPlan&&) = default;
  StressPlan& operator=(StressPlan&&) = default;
  StressPlan(const StressPlan&) = delete;
  StressPlan& operator=(const StressPlan&) = delete;

  std::vector<scenes::BaseScene> bases;
  std::vector<StressCase> cases;  // in a fixed order: scene, family, level, trial
  std::vector<std::string> solvers;
  SolveOptions solve_options;
  std::vector<scenes::SkippedFile> skipped;  // bad files of the data folder, left out
};

// Checks the options (InputError for a bad value, an unknown name or a bad
// --scene file), reads the base scenes and builds every case. A bad file of
// the data folder is named on standard error in one line and left out.
StressPlan plan_stress_test(const StressTestOptions& options);

}  // namespace tensegrity::cli
