// tensegrity stress-test [--scenes ...] [--solvers ...] [--families ...] [--trials N] [--seed S]
//                        [--jobs J] [--time-limit S] [--tol T] [--prestress-factor K] [--data DIR] [--scene FILE]...
//                        [--no-times] [--measure-speedup] [--quiet] --out|--json REPORT.json
// Seeded families of perturbed benchmark scenes and characters, every chosen
// backend on each, results re-verified and summarised (cli/stress_test.hpp):
// the JSON report to a file (or standard output), a table per backend to
// standard output (standard error when the report goes there). On standard
// error, as for `batch`: a line naming the run, then a status line on a
// terminal (cli/progress.hpp), else a line at every tenth of the trials; none
// with --quiet. Exit status: 0 clean, 1 when a result broke a rule or a data
// file was skipped, 2 bad usage.
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>

#include "cli/commands.hpp"
#include "cli/prestress_factor_option.hpp"
#include "reports/output.hpp"
#include "workers/process_pool.hpp"
#include "cli/progress.hpp"
#include "cli/stress_test.hpp"
#include "model/errors.hpp"
#include "model/json_text.hpp"
#include "model/scene_io.hpp"

namespace tensegrity::cli {

namespace {

struct StressArgs {
  std::vector<std::string> scenes, solvers, families, scene_files, options;
  int trials = 2;
  std::uint64_t seed = 1;
  int jobs = 0;  // 0: every available core
  double time_limit = 20.0;
  double tol = 1e-8;
  double prestress_factor = 0.0;  // set by add_prestress_factor_option
  std::string data;
  std::string out;
  std::string failures_dir;
  bool no_times = false;
  bool quiet = false;
  bool measure_speedup = false;
};

// The data folder: --data, else ./data, else data beside the program's folder.
std::string find_data_dir(const std::string& given) {
  namespace fs = std::filesystem;
  if (!given.empty()) {
    std::error_code ec;
    if (!fs::is_directory(given, ec)) throw InputError(given, "--data", "not a directory");
    return given;
  }
  std::error_code ec;
  if (fs::is_directory("data/characters", ec)) return "data";
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    for (const fs::path& candidate : {exe.parent_path() / "data", exe.parent_path().parent_path() / "data"})
      if (fs::is_directory(candidate / "characters", ec)) return candidate.string();
  }
  return "";
}

// The naming line of each pass, then its status line or tenth lines
// (cli/progress.hpp), as in `batch`.
class StressProgress {
 public:
  StressObserver observer() {
    StressObserver o;
    o.on_pass_start = [this](std::size_t trials, std::size_t not_run, int workers, bool speedup_reference) {
      finish();
      std::string what = std::to_string(trials) + " solves";
      if (not_run > 0) what += " (" + std::to_string(not_run) + " rejected inputs, not run)";
      std::fprintf(stderr, "stress-test: %s, %d job%s%s...\n", what.c_str(), workers, workers == 1 ? "" : "s",
                   speedup_reference ? " (for the speed-up)" : "");
      std::fflush(stderr);
      line_ = std::make_unique<JobsProgress>(true, "stress-test", "not converged or not verified", trials, not_run);
    };
    o.on_trial_end = [this](bool failed) { line_->job_ended(failed); };
    o.on_tick = [this] { line_->tick(); };
    return o;
  }
  // Ends a shown status line, so that the table and summary start lines of their own.
  void finish() {
    if (line_) line_->finish();
  }

 private:
  std::unique_ptr<JobsProgress> line_;
};

}  // namespace

void register_stress_test_command(CLI::App& app, CommandRunner& run) {
  auto args = std::make_shared<StressArgs>();
  auto* cmd = app.add_subcommand("stress-test", "Solve seeded families of perturbed scenes with every backend");
  cmd->add_option("--scenes", args->scenes,
                  "Scene names or groups (reference, tower, character), comma-separated; default all");
  cmd->add_option("--scene", args->scene_files, "Also stress this scene file (repeatable)");
  cmd->add_option("--solvers", args->solvers, "Backends, comma-separated; default every registered one");
  cmd->add_option("--families", args->families,
                  "Perturbation families, comma-separated; default all (noise, twist, scale, length-ratio, "
                  "near-coincident, near-parallel, mass, gravity-direction)");
  cmd->add_option("--trials", args->trials, "Trials per scene, family and level")->check(CLI::Range(1, 100000));
  cmd->add_option("--seed", args->seed, "Seed of every perturbation");
  cmd->add_option("--jobs", args->jobs, "Worker processes solving in parallel (default: the available cores)")
      ->check(CLI::Range(1, 256));
  cmd->add_option("--time-limit", args->time_limit, "Wall-clock budget per solve (s)");
  cmd->add_option("--tol", args->tol, "Relative residual for `converged`");
  add_prestress_factor_option(*cmd, &args->prestress_factor);
  cmd->add_option("--option", args->options,
                  "Backend option key=value for every solver of the run (repeatable; each must accept it)");
  cmd->add_option("--data", args->data, "Data folder holding characters/ (default ./data or beside the program)");
  cmd->add_option("--save-failures", args->failures_dir,
                  "Write the scene of every failed trial into this (existing) folder, to reproduce it");
  cmd->add_flag("--no-times", args->no_times, "Leave timings out, so equal options give a bit-identical report");
  cmd->add_flag("--quiet", args->quiet,
                "No progress on stderr and no summary unless the run failed; with --out - also no table then "
                "(errors still print)");
  cmd->add_flag("--measure-speedup", args->measure_speedup,
                "First solve everything with one worker, then report serial/parallel wall time");
  cmd->add_option("--out,--json", args->out,
                  "Report file (JSON), - for standard output (the table then goes to standard error)")
      ->required();
  cmd->callback([args, &run] {
    run = [args] {
      StressTestOptions o;
      o.scenes = args->scenes;
      o.scene_files = args->scene_files;
      o.solvers = args->solvers;
      o.families = args->families;
      o.trials = args->trials;
      o.seed = args->seed;
      o.jobs = args->jobs > 0 ? args->jobs : available_cores();
      o.measure_speedup = args->measure_speedup;
      o.time_limit_s = args->time_limit;
      o.tolerance = args->tol;
      o.prestress_factor = reports::checked_prestress_factor(args->prestress_factor);
      o.backend_options = reports::parse_key_values(args->options);
      o.data_dir = find_data_dir(args->data);
      o.with_times = !args->no_times;
      if (!args->failures_dir.empty()) {
        std::error_code ec;
        if (!std::filesystem::is_directory(args->failures_dir, ec))
          throw InputError(args->failures_dir, "--save-failures", "not a directory");
        o.failures_dir = args->failures_dir;
      }
      StressProgress progress;
      if (!args->quiet) o.observer = progress.observer();
      const StressReport report = run_stress_test(o);
      progress.finish();
      write_text_file_atomically(args->out, to_json_text(stress_report_to_json(report)) + "\n");
      int bad = 0;
      for (const StressTrial& t : report.trials)
        if (!t.rejected && (!t.finite || t.overran || t.crashed || (t.status == Status::Converged && !t.verified)))
          ++bad;
      const bool clean = bad == 0 && report.skipped.empty();
      // As in `batch`: with --quiet the table on standard error (--out -) and the summary only for a run that failed.
      if (args->out != "-" || !args->quiet || !clean) print_stress_table(report, args->out == "-" ? stderr : stdout);
      if (!args->quiet || !clean)
        std::cerr << "stress-test: " << report.trials.size() << " solves; " << bad
                  << " with a non-finite number, an overrun, a crashed worker or a converged result that does not "
                     "verify\n";
      // As in `batch`: skipped files make the run incomplete, but it has output, so 1 and not 2.
      return clean ? 0 : 1;
    };
  });
}

}  // namespace tensegrity::cli
