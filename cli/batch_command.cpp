// tensegrity batch SCENE|DIR... --out-dir DIR [--solver NAME[,NAME...]] [--jobs N] [--tol T]
//     [--time-limit S] [--prestress-factor K] [--kill-after S] [--max-iterations N] [--no-skip] [--measure-speedup]
//     [--trace] [--json FILE|-] [--quiet]
//
// Solves independent (scene, backend) jobs in forked worker processes, the
// longest estimated first, each solve single-threaded (one BLAS thread), so N
// workers use N cores, Ipopt included (workers/process_pool.hpp). A worker writes
// its solution file with the same functions as `solve`, so the files are the
// ones `solve` writes. Prints one line per job and a summary with the wall
// time, the CPU time of every process and the speed-up (sum of the jobs' wall
// times over the total wall time; with --measure-speedup also the wall time of
// one worker alone). On standard error, as for `simulate`: a status line on a
// terminal (cli/progress.hpp), else a line at every tenth of the jobs; none
// with --quiet. Exit status: 0 every job converged, 1 otherwise (also
// when some scene files could not be read: each is named on stderr and
// skipped, the others are solved and written, so the run has output), 2 bad
// usage before anything runs.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "cli/commands.hpp"
#include "reports/output.hpp"
#include "cli/batch_jobs.hpp"
#include "cli/prestress_factor_option.hpp"
#include "workers/process_pool.hpp"
#include "cli/progress.hpp"
#include "model/errors.hpp"
#include "model/json_text.hpp"
#include "model/scene_io.hpp"

namespace tensegrity::cli {

namespace {

struct BatchArgs {
  std::vector<std::string> scenes;
  std::vector<std::string> solvers;
  std::string out_dir;
  std::string json;
  int jobs = 0;  // 0: every available core
  double tol = 1e-8;
  int max_iterations = 0;
  double time_limit = 120.0;
  double kill_after = 0.0;  // 0: 2 * time_limit + 5
  double prestress_factor = 0.0;  // set by add_prestress_factor_option
  bool no_skip = false;
  bool measure_speedup = false;
  bool trace = false;
  bool quiet = false;
};

std::string scene_stem(const std::string& path) {
  std::string name = std::filesystem::path(path).filename().string();
  for (const char* suffix : {".scene.json", ".json"}) {
    const std::string s(suffix);
    if (name.size() > s.size() && name.compare(name.size() - s.size(), s.size(), s) == 0) {
      name.resize(name.size() - s.size());
      break;
    }
  }
  return name;
}

// The scene files named on the command line: a folder stands for its
// *.scene.json files (sorted); anything else is taken as a file.
std::vector<std::string> expand_scene_arguments(const std::vector<std::string>& items) {
  namespace fs = std::filesystem;
  std::vector<std::string> files;
  for (const std::string& item : items) {
    std::error_code ec;
    if (!fs::is_directory(item, ec)) {
      files.push_back(item);
      continue;
    }
    std::vector<std::string> found;
    for (const auto& entry : fs::directory_iterator(item, ec)) {
      const std::string name = entry.path().filename().string();
      if (name.size() > 11 && name.ends_with(".scene.json")) found.push_back(entry.path().string());
    }
    if (ec || found.empty()) {
      files.push_back(item);  // reading it fails and names the folder
      continue;
    }
    std::sort(found.begin(), found.end());
    files.insert(files.end(), found.begin(), found.end());
  }
  return files;
}

struct ReadableScenes {
  std::vector<std::string> paths, stems;
  std::vector<Structure> scenes;
  std::vector<std::pair<std::string, std::string>> skipped;  // file, reason
};

// Reads every scene; one that cannot be read is named on stderr and skipped.
ReadableScenes read_scenes(const std::vector<std::string>& files) {
  ReadableScenes r;
  for (const std::string& path : files) {
    try {
      Structure s = read_scene_file(path);
      r.scenes.push_back(std::move(s));
    } catch (const InputError& e) {
      std::cerr << "tensegrity: " << e.what() << "\n";
      r.skipped.emplace_back(path, e.what());
      continue;
    }
    r.paths.push_back(path);
    r.stems.push_back(scene_stem(path));
    for (std::size_t k = 0; k + 1 < r.stems.size(); ++k)
      if (r.stems[k] == r.stems.back())
        throw InputError(path, "scene", "two scenes would write the same solution file " + r.stems.back());
  }
  return r;
}

// The status line or tenth lines of one run (cli/progress.hpp), fed by the worker pool.
SolveJobsObserver batch_progress_observer(JobsProgress& progress) {
  SolveJobsObserver o;
  o.on_job_end = [&progress](const SolveJobResult& r) { progress.job_ended(r.status != Status::Converged); };
  o.on_tick = [&progress] { progress.tick(); };
  return o;
}

}  // namespace

void register_batch_command(CLI::App& app, CommandRunner& run) {
  auto args = std::make_shared<BatchArgs>();
  auto* cmd = app.add_subcommand(
      "batch", "Solve independent scenes in parallel worker processes and report the speed-up");
  cmd->add_option("scenes", args->scenes, "Scene files (*.scene.json), or folders of them")->required();
  cmd->add_option("--solver", args->solvers,
                  "Backend names, comma-separated or repeated: every scene with each (see `tensegrity solvers`); "
                  "default: " +
                      reports::default_solver_help())
      ->delimiter(',');
  cmd->add_option("--jobs", args->jobs, "Worker processes, 1..256 (default: the available cores)");
  cmd->add_option("--out-dir", args->out_dir,
                  "Folder for the solution files (one subfolder per backend when several are given)")
      ->required();
  cmd->add_option("--tol", args->tol, "Relative residual for `converged` (finite, > 0)");
  cmd->add_option("--max-iterations", args->max_iterations,
                  reports::max_iterations_help("Backend iteration budget per scene"));
  cmd->add_option("--time-limit", args->time_limit, "Wall-clock budget in seconds per scene");
  add_prestress_factor_option(*cmd, &args->prestress_factor);
  cmd->add_option("--kill-after", args->kill_after,
                  "A solve still running after this many seconds is killed and reported as time_limit "
                  "(default: twice --time-limit plus 5)");
  cmd->add_flag("--no-skip", args->no_skip, "Do not return early when a scene is already in equilibrium");
  cmd->add_flag("--measure-speedup", args->measure_speedup,
                "First solve everything with one worker, then report serial/parallel wall time");
  cmd->add_flag("--trace", args->trace, "Also write <scene>.trace.csv per scene");
  cmd->add_option("--json", args->json,
                  "Also write the whole report as one JSON object to this file (- : standard output, and the "
                  "table goes to standard error)");
  cmd->add_flag("--quiet", args->quiet,
                "No progress on stderr; with --json - also no table unless a job failed (errors still print)");
  cmd->callback([args, &run] {
    run = [args] {
      if (args->jobs == 0) args->jobs = available_cores();
      if (args->jobs < 1 || args->jobs > 256) throw InputError("command line", "--jobs", "must be within 1..256");
      SolveJobSettings settings;
      settings.options.tolerance = args->tol;
      settings.options.max_iterations = args->max_iterations;
      settings.options.time_limit_s = args->time_limit;
      settings.options.prestress_factor = reports::checked_prestress_factor(args->prestress_factor);
      settings.controls.skip_if_in_equilibrium = !args->no_skip;
      settings.kill_after_s = args->kill_after > 0.0 ? args->kill_after : default_kill_after(args->time_limit);
      if (!(args->kill_after >= 0.0)) throw InputError("command line", "--kill-after", "must be a number >= 0");
      std::vector<std::string> solver_names = args->solvers;
      if (solver_names.empty()) solver_names.push_back("");
      for (std::string& name : solver_names)
        name = std::string(reports::checked_solver(name, settings.options)->name());
      for (std::size_t k = solver_names.size(); k-- > 1;)  // each backend once, in the given order
        if (std::find(solver_names.begin(), solver_names.begin() + static_cast<std::ptrdiff_t>(k), solver_names[k]) !=
            solver_names.begin() + static_cast<std::ptrdiff_t>(k))
          solver_names.erase(solver_names.begin() + static_cast<std::ptrdiff_t>(k));

      ReadableScenes input = read_scenes(expand_scene_arguments(args->scenes));
      if (input.scenes.empty()) {
        if (input.skipped.empty()) throw InputError("command line", "scenes", "no *.scene.json file given");
        return 2;
      }
      const bool per_solver_folder = solver_names.size() > 1;
      std::vector<SolveJob> jobs;
      for (std::size_t i = 0; i < input.scenes.size(); ++i)
        for (const std::string& solver : solver_names) {
          SolveJob job;
          job.scene = &input.scenes[i];
          job.scene_name = input.stems[i];
          job.scene_file = input.paths[i];
          job.solver = solver;
          const std::string folder = per_solver_folder ? args->out_dir + "/" + solver : args->out_dir;
          job.solution_file = folder + "/" + input.stems[i] + ".solution.json";
          if (args->trace) job.trace_file = folder + "/" + input.stems[i] + ".trace.csv";
          jobs.push_back(std::move(job));
        }
      std::filesystem::create_directories(args->out_dir);
      if (per_solver_folder)
        for (const std::string& solver : solver_names) std::filesystem::create_directories(args->out_dir + "/" + solver);

      settings.workers = args->jobs;
      const std::string what = solver_names.size() == 1
                                   ? std::to_string(jobs.size()) + " scenes with " + solver_names.front()
                                   : std::to_string(jobs.size()) + " solves (" + std::to_string(input.scenes.size()) +
                                         " scenes x " + std::to_string(solver_names.size()) + " backends)";
      SolveJobsRun serial;
      const bool measure = args->measure_speedup && args->jobs > 1;
      if (measure) {
        if (!args->quiet) std::cerr << "batch: " << what << ", 1 job (for the speed-up)...\n";
        SolveJobSettings one = settings;
        one.workers = 1;
        one.write_files = false;
        JobsProgress progress(!args->quiet, "batch", "failed", jobs.size());
        serial = run_solve_jobs(jobs, one, batch_progress_observer(progress));
        progress.finish();
      }
      if (!args->quiet) std::cerr << "batch: " << what << ", " << args->jobs << " jobs...\n";
      JobsProgress progress(!args->quiet, "batch", "failed", jobs.size());
      const SolveJobsRun parallel = run_solve_jobs(jobs, settings, batch_progress_observer(progress));
      progress.finish();

      BatchReport report;
      report.jobs = &jobs;
      report.run = &parallel;
      report.serial = measure ? &serial : nullptr;
      report.workers = args->jobs;
      report.skipped = input.skipped;
      report.settings = &settings;
      const bool json_to_stdout = args->json == "-";
      const bool all_converged = input.skipped.empty() && parallel.converged == jobs.size();
      // --quiet keeps a table bound for standard error only when the run failed: it says which jobs did.
      if (!(args->quiet && json_to_stdout && all_converged))
        print_batch_table(report, json_to_stdout ? stderr : stdout, solver_names.size() > 1);
      if (!args->json.empty())
        write_text_file_atomically(args->json, to_json_text(batch_report_to_json(report)) + "\n");
      return all_converged ? 0 : 1;
    };
  });
}

}  // namespace tensegrity::cli
