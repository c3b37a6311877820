// tensegrity solve SCENE [--solver NAME] [--out FILE] [--tol T] [--prestress-factor K] [--option k=v]... [--trace FILE]
//                       [--out-scene FILE] [--verbose | --quiet]
//
// On a terminal, a solve that runs longer than a moment shows its iteration,
// relative residual and time on one line of standard error (cli/progress.hpp).
#include <array>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <string>

#include "cli/commands.hpp"
#include "cli/prestress_factor_option.hpp"
#include "reports/output.hpp"
#include "cli/progress.hpp"
#include "model/errors.hpp"
#include "model/scene_io.hpp"

namespace tensegrity::cli {

namespace {
struct SolveArgs {
  std::string scene;
  std::string solver;
  std::string out = "-";
  std::string trace;
  std::string out_scene;
  double tol = 1e-8;
  int max_iterations = 0;
  double time_limit = 120.0;
  double prestress_factor = 0.0;  // set by add_prestress_factor_option
  bool verbose = false;
  bool quiet = false;
  bool no_skip = false;
  std::vector<std::string> options;
};

// The status line of a running solve: the latest backend record, drawn when
// the line is due (formatting costs nothing on the other iterations).
class SolveProgress {
 public:
  explicit SolveProgress(bool enabled) : line_(enabled) {}
  void record(const TracePoint& p, int part, int num_parts) {
    last_ = p;
    part_ = part;
    num_parts_ = num_parts;
    if (line_.due()) line_.show(text().data());
  }
  // The last record, then a newline (nothing when no line was shown).
  void finish() {
    if (line_.shown()) line_.finish(text().data());
  }

 private:
  std::array<char, 160> text() const {
    std::array<char, 160> t{};
    char part[32] = "";
    if (num_parts_ > 1) std::snprintf(part, sizeof part, "part %d/%d, ", part_ + 1, num_parts_);
    std::snprintf(t.data(), t.size(), "solve: %siteration %d, relative residual %.3e, %.1f s", part,
                  last_.iteration, last_.relative_residual, last_.seconds);
    return t;
  }
  ProgressLine line_;
  TracePoint last_;
  int part_ = 0, num_parts_ = 1;
};
}  // namespace

void register_solve_command(CLI::App& app, CommandRunner& run) {
  auto args = std::make_shared<SolveArgs>();
  auto* cmd = app.add_subcommand("solve", "Form-find a scene with one backend; write its solution");
  cmd->add_option("scene", args->scene, "Scene file (*.scene.json)")->required();
  cmd->add_option("--solver", args->solver,
                  "Backend name (see `tensegrity solvers`); default: " + reports::default_solver_help());
  cmd->add_option("--out", args->out, "Solution file, - for standard output");
  cmd->add_option("--tol", args->tol, "Relative residual for `converged` (finite, > 0)");
  cmd->add_option("--max-iterations", args->max_iterations, reports::max_iterations_help("Backend iteration budget"));
  cmd->add_option("--time-limit", args->time_limit, "Wall-clock budget in seconds");
  add_prestress_factor_option(*cmd, &args->prestress_factor);
  cmd->add_option("--option", args->options, "Backend option key=value (repeatable)");
  cmd->add_option("--trace", args->trace, "Write the per-iteration record as CSV");
  cmd->add_option("--out-scene", args->out_scene,
                  "Also write the scene at the solved geometry (only when converged)");
  auto* verbose = cmd->add_flag("--verbose", args->verbose,
                                "Log every iteration to stderr (Ipopt: its own log; the others: one line each)");
  cmd->add_flag("--quiet", args->quiet, "No progress line and no summary on stderr unless the solve fails (errors still print)")
      ->excludes(verbose);
  cmd->add_flag("--no-skip", args->no_skip, "Do not return early when the scene is already in equilibrium");
  cmd->callback([args, &run] {
    run = [args] {
      SolveOptions options;
      options.tolerance = args->tol;
      options.max_iterations = args->max_iterations;
      options.time_limit_s = args->time_limit;
      options.prestress_factor = reports::checked_prestress_factor(args->prestress_factor);
      options.verbose = args->verbose;
      DriverControls controls;
      controls.skip_if_in_equilibrium = !args->no_skip;
      options.backend_options = reports::parse_key_values(args->options);
      const auto solver = reports::checked_solver(args->solver, options);
      const std::string name(solver->name());
      const Structure scene = read_scene_file(args->scene);
      // A line rewritten in place would garble the --verbose log.
      SolveProgress progress(stderr_is_terminal() && !args->quiet && !args->verbose);
      controls.on_iteration = [&progress](const TracePoint& p, int part, int num_parts) {
        progress.record(p, part, num_parts);
      };
      const SolveResult r = solver->Solve(scene, options, controls);
      progress.finish();
      write_solution_file(to_solution(r, scene, name), args->out);
      if (!args->trace.empty()) write_trace_csv(args->trace, r.trace);
      // The solved geometry as a new scene (a start for further design), only
      // for a verified equilibrium: anything else would look like one.
      if (!args->out_scene.empty() && r.status == Status::Converged) {
        Structure solved = scene;
        solved.positions = r.positions;
        write_scene_file(solved, args->out_scene);
      }
      // --quiet keeps the summary of a failed solve: it says why.
      if (!args->quiet || r.status != Status::Converged) std::cerr << reports::summary_line(scene, name, r) << "\n";
      return reports::exit_status(r.status);
    };
  });
}

}  // namespace tensegrity::cli
