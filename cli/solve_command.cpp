// tensegrity solve SCENE [--solver NAME] [--out FILE] [--tol T] [--option k=v]... [--trace FILE]
//                       [--out-scene FILE]
#include <iostream>
#include <memory>
#include <string>

#include "cli/commands.hpp"
#include "cli/output.hpp"
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
  bool verbose = false;
  bool no_skip = false;
  std::vector<std::string> options;
};
}  // namespace

void register_solve_command(CLI::App& app, CommandRunner& run) {
  auto args = std::make_shared<SolveArgs>();
  auto* cmd = app.add_subcommand("solve", "Form-find a scene with one backend; write its solution");
  cmd->add_option("scene", args->scene, "Scene file (*.scene.json)")->required();
  cmd->add_option("--solver", args->solver, "Backend name (see `tensegrity solvers`); default: the recommended one");
  cmd->add_option("--out", args->out, "Solution file, - for standard output");
  cmd->add_option("--tol", args->tol, "Relative residual for `converged` (finite, > 0)");
  cmd->add_option("--max-iterations", args->max_iterations, max_iterations_help("Backend iteration budget"));
  cmd->add_option("--time-limit", args->time_limit, "Wall-clock budget in seconds");
  cmd->add_option("--option", args->options, "Backend option key=value (repeatable)");
  cmd->add_option("--trace", args->trace, "Write the per-iteration record as CSV");
  cmd->add_option("--out-scene", args->out_scene,
                  "Also write the scene at the solved geometry (only when converged)");
  cmd->add_flag("--verbose", args->verbose, "Let the backend print its own log to stderr");
  cmd->add_flag("--no-skip", args->no_skip, "Do not return early when the scene is already in equilibrium");
  cmd->callback([args, &run] {
    run = [args] {
      SolveOptions options;
      options.tolerance = args->tol;
      options.max_iterations = args->max_iterations;
      options.time_limit_s = args->time_limit;
      options.verbose = args->verbose;
      DriverControls controls;
      controls.skip_if_in_equilibrium = !args->no_skip;
      options.backend_options = parse_key_values(args->options);
      const auto solver = checked_solver(args->solver, options);
      const std::string name(solver->name());
      const Structure scene = read_scene_file(args->scene);
      const SolveResult r = solver->Solve(scene, options, controls);
      write_solution_file(to_solution(r, scene, name), args->out);
      if (!args->trace.empty()) write_trace_csv(args->trace, r.trace);
      // The solved geometry as a new scene (a start for further design), only
      // for a verified equilibrium: anything else would look like one.
      if (!args->out_scene.empty() && r.status == Status::Converged) {
        Structure solved = scene;
        solved.positions = r.positions;
        write_scene_file(solved, args->out_scene);
      }
      std::cerr << summary_line(scene, name, r) << "\n";
      return exit_status(r.status);
    };
  });
}

}  // namespace tensegrity::cli
