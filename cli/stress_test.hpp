#pragma once
// The numerical stress test behind `tensegrity stress-test` (docs/ROBUSTNESS.md):
// seeded families of perturbed scenes built from every benchmark scene and
// character, solved by every chosen backend on a pool of threads, each result
// re-checked independently with model/verify, and summarised per backend and
// family (and per level of the family's perturbation).
//
// Families (levels in brackets; L = median element length of the base scene):
//   noise          free nodes moved uniformly in a ball of radius level * L
//                  [0.001 0.003 0.01 0.03 0.1 0.3]
//   twist          nodes above the median height turned about the vertical
//                  axis through their centroid by level degrees [1 5 15 30]
//   scale          the whole scene scaled by level, then 1 % noise
//                  [1e-4 1e-2 1e2 1e4]
//   length-ratio   heights (z) multiplied by level, so element lengths differ
//                  by up to that ratio, then 1 % noise [10 100 1e3 1e4]
//   near-coincident  1 % noise, then one free node put at distance level * L
//                  from another node [1e-2 1e-4 1e-6 1e-9]
//   near-parallel  1 % noise, then one element turned about its shared node
//                  until it makes an angle of level radians with a neighbour
//                  [1e-2 1e-4 1e-6]
//   mass           gravity -z, every free node of mass level kg (element
//                  masses kept, all masses removed at level 0), the 3 lowest
//                  nodes fixed when none is, 1 % noise [0 1e-6 1e-2 1 1e2 1e4 1e6]
//   gravity-direction  |g| = 9.81 along +-x, +-y, +-z or a random direction;
//                  existing masses (else 0.01 kg per node), the 3 lowest nodes
//                  along g fixed when none is, 1 % noise
// Every trial's perturbation comes from its own generator seeded by (seed,
// scene, family, level, trial), so results do not depend on the thread count
// or the order in which trials run.
#include <cstdint>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "model/structure.hpp"
#include "solvers/solver.hpp"

namespace tensegrity::cli {

struct StressBaseScene {
  std::string name;
  std::string group;  // "reference", "tower" or "character"
  Structure scene;
};

// Every benchmark scene (the reference prisms and octahedra, plain and with
// gravity; the 80-strut tower's stored equilibria `data_dir`/bench/tower-80s-500c*.scene.json,
// plain and with gravity) and every character of
// `data_dir`/characters. InputError when a character file is bad.
std::vector<StressBaseScene> stress_base_scenes(const std::string& data_dir);

std::vector<std::string> stress_family_names();

struct StressLevel {
  double value = 0.0;
  std::string label;
};
// The levels of a family (InputError for an unknown family).
std::vector<StressLevel> stress_family_levels(const std::string& family);

// The perturbed scene of one trial; deterministic in its arguments.
Structure make_stress_case(const Structure& base, const std::string& family, int level_index, int trial,
                           std::uint64_t seed);

struct StressTestOptions {
  std::vector<std::string> scenes;    // names or groups; empty = all
  std::vector<std::string> solvers;   // empty = every registered backend
  std::vector<std::string> families;  // empty = all
  int trials = 2;                     // per scene, family and level
  std::uint64_t seed = 1;
  int jobs = 2;
  double time_limit_s = 20.0;         // per solve
  double tolerance = 1e-8;
  // Backend options (`--option key=value`) given to every solver of the run;
  // each solver must accept them all (InputError otherwise).
  std::map<std::string, std::string> backend_options;
  std::string data_dir;               // holds characters/
  bool with_times = true;             // false: the report holds no timings (bit-identical runs)
  std::vector<std::string> scene_files;  // extra scenes read from files
  // When set, the perturbed scene of every trial that did not converge and
  // verify is written there as <scene>_<family>_<level>_t<trial>_<solver>.scene.json
  // (to reproduce it with `tensegrity solve`).
  std::string failures_dir;
  // Called from the coordinating thread: trials done, total, failures so far.
  std::function<void(int, int, int)> progress;
};

struct StressTrial {
  std::string scene, family, level, solver;
  int trial = 0;
  bool rejected = false;       // the perturbed scene broke a rule of the model (not run)
  Status status = Status::NumericalError;
  bool verified = false;       // independent re-check with model/verify passes
  bool finite = true;          // no non-finite number in positions, forces, stats or trace
  double relative_residual = 0.0;
  double seconds = 0.0;
  bool overran = false;        // took longer than twice the time limit plus 5 s
  std::uint64_t digest = 0;    // of status, positions and forces (bits)
  std::string message;
};

struct StressReport {
  StressTestOptions options;
  std::vector<StressTrial> trials;  // in a fixed order (scene, family, level, trial, solver)
  double wall_seconds = 0.0;
};

// Throws InputError for unknown scene, family or solver names.
StressReport run_stress_test(const StressTestOptions& options);

// The report file; with options.with_times false it holds no timing and is
// bit-identical for the same options whatever the thread count.
nlohmann::json stress_report_to_json(const StressReport& report);

}  // namespace tensegrity::cli
