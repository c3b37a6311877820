// tensegrity check SCENE SOLUTION [--tol T]: independent re-verification.
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>

#include "cli/commands.hpp"
#include "model/errors.hpp"
#include "model/scene_io.hpp"
#include "model/solution.hpp"
#include "model/verify.hpp"

namespace tensegrity::cli {

void register_check_command(CLI::App& app, CommandRunner& run) {
  struct Args {
    std::string scene, solution;
    double tol = 1e-8;
  };
  auto args = std::make_shared<Args>();
  auto* cmd = app.add_subcommand("check", "Re-verify a solution against its scene (exit 0 only if it verifies)");
  cmd->add_option("scene", args->scene, "Scene file")->required();
  cmd->add_option("solution", args->solution, "Solution file")->required();
  cmd->add_option("--tol", args->tol, "Relative residual tolerance (finite, > 0)");
  cmd->callback([args, &run] {
    run = [args] {
      if (!(std::isfinite(args->tol) && args->tol > 0))
        throw InputError("command line", "--tol", "must be a finite number > 0");
      const Structure scene = read_scene_file(args->scene);
      const Solution sol = read_solution_file(args->solution, scene);
      const Verification v = verify(scene, sol.positions, sol.forces, args->tol);
      std::printf("residual          %.6g N\n", v.residual);
      std::printf("relative_residual %.6g (load scale %.6g N, tolerance %.3g)\n", v.relative_residual,
                  v.load_scale, args->tol);
      std::printf("wrong_signs       %d\n", v.wrong_signs);
      std::printf("moved_fixed_nodes %d\n", v.moved_fixed_nodes);
      std::printf("all_finite        %s\n", v.all_finite ? "yes" : "no");
      std::printf("geometry_change   %.6g m\n", v.geometry_change);
      std::printf("status_claimed    %s\n", std::string(to_string(sol.status)).c_str());
      for (const auto& p : v.problems) std::printf("problem: %s\n", p.c_str());
      std::printf("%s\n", v.ok ? "verified" : "NOT verified");
      return v.ok ? 0 : 1;
    };
  });
}

}  // namespace tensegrity::cli
