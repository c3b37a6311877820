// tensegrity forces SCENE [--out FILE] [--tol T]: the stress QP (Eq. 4) at the
// scene's own geometry.
#include <iostream>
#include <memory>

#include "cli/commands.hpp"
#include "reports/output.hpp"
#include "model/errors.hpp"
#include "model/scene_io.hpp"

namespace tensegrity::cli {

void register_forces_command(CLI::App& app, CommandRunner& run) {
  struct Args {
    std::string scene, out = "-";
    double tol = 1e-8;
  };
  auto args = std::make_shared<Args>();
  auto* cmd = app.add_subcommand("forces", "Solve the stress QP (Eq. 4) at the scene geometry");
  cmd->add_option("scene", args->scene, "Scene file")->required();
  cmd->add_option("--out", args->out, "Solution file, - for standard output");
  cmd->add_option("--tol", args->tol, "Relative residual for `converged` (finite, > 0)");
  cmd->callback([args, &run] {
    run = [args] {
      SolveOptions options;
      options.tolerance = args->tol;
      std::string why;
      if (!options.IsValid(&why)) throw InputError("command line", "--tol", why);
      const Structure scene = read_scene_file(args->scene);
      const SolveResult r = solve_forces_only(scene, options);
      write_solution_file(to_solution(r, scene, "stress-qp"), args->out);
      std::cerr << reports::summary_line(scene, "stress-qp", r) << "\n";
      return reports::exit_status(r.status);
    };
  });
}

}  // namespace tensegrity::cli
