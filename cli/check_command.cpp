// tensegrity check SCENE SOLUTION [--tol T] [--stability]: independent
// re-verification, optionally with the stability of the equilibrium.
//
// Exit status: 0 verified (and with --stability: stable); 1 does not verify;
// 2 bad input; 3 (--stability only) verified but marginal or unstable, so that
// a script can tell "not an equilibrium" from "an equilibrium that will not hold".
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>

#include "cli/commands.hpp"
#include "model/errors.hpp"
#include "model/scene_io.hpp"
#include "model/solution.hpp"
#include "model/verify.hpp"
#include "model/design.hpp"
#include "simulation/stability.hpp"

namespace tensegrity::cli {

namespace {
constexpr int kExitVerifiedNotStable = 3;
}  // namespace

void register_check_command(CLI::App& app, CommandRunner& run) {
  struct Args {
    std::string scene, solution;
    double tol = 1e-8;
    bool stability = false;     // --stability: tangent-stiffness test (simulation/stability.hpp)
    std::string design;         // material model for it; else linear cords
    double cable_strain = 0.1;  // strain of those linear cords under their force
    bool json = false;          // --json: one JSON object on standard output instead of the text
  };
  auto args = std::make_shared<Args>();
  auto* cmd = app.add_subcommand("check", "Re-verify a solution against its scene (exit 0 only if it verifies)");
  cmd->add_option("scene", args->scene, "Scene file")->required();
  cmd->add_option("solution", args->solution, "Solution file")->required();
  cmd->add_option("--tol", args->tol, "Relative residual tolerance (finite, > 0)");
  cmd->add_flag("--stability", args->stability,
                "Also test stability: smallest tangent-stiffness eigenvalues, prestress stability (exit 0 stable, 3 "
                "verified but marginal or unstable, 1 not verified)");
  cmd->add_option("--design", args->design, "With --stability: take cable materials and rest lengths from this design");
  cmd->add_flag("--json", args->json, "Print the verification as one JSON object (without --stability)");
  cmd->add_option("--cable-strain", args->cable_strain,
                  "With --stability and no --design: cables as linear cords at this strain (default 0.1)");
  cmd->callback([args, &run] {
    run = [args] {
      if (!(std::isfinite(args->tol) && args->tol > 0))
        throw InputError("command line", "--tol", "must be a finite number > 0");
      const Structure scene = read_scene_file(args->scene);
      const Solution sol = read_solution_file(args->solution, scene);
      const Verification v = verify(scene, sol.positions, sol.forces, args->tol);
      if (args->json) {
        if (args->stability) throw InputError("command line", "--json", "not with --stability");
        const nlohmann::json j = {{"format", "tensegrity-check"},
                                  {"version", 1},
                                  {"verified", v.ok},
                                  {"residual", v.residual},
                                  {"relative_residual", v.relative_residual},
                                  {"load_scale", v.load_scale},
                                  {"tolerance", args->tol},
                                  {"wrong_signs", v.wrong_signs},
                                  {"moved_fixed_nodes", v.moved_fixed_nodes},
                                  {"all_finite", v.all_finite},
                                  {"geometry_change", v.geometry_change},
                                  {"status_claimed", std::string(to_string(sol.status))},
                                  {"problems", v.problems}};
        std::printf("%s\n", j.dump(2).c_str());
        return v.ok ? 0 : 1;
      }
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
      if (!args->stability) return v.ok ? 0 : 1;
      if (!(std::isfinite(args->cable_strain) && args->cable_strain > 0))
        throw InputError("command line", "--cable-strain", "must be a finite number > 0");
      const ElasticModel model = args->design.empty()
                                     ? make_linear_elastic_model(scene, sol.positions, sol.forces, args->cable_strain)
                                     : make_elastic_model(read_design_file(args->design));
      if (model.structure.num_nodes() != scene.num_nodes() || model.structure.num_elements() != scene.num_elements())
        throw InputError(args->design, "", "the design does not match the scene's nodes and elements");
      const StabilityReport st = analyze_stability(ElasticEnergy(model, scene.gravity), sol.positions);
      std::printf("stability         %s (%s; %s, %d coordinates, %d rigid modes removed)\n", to_string(st.verdict),
                  st.message.c_str(), st.method.c_str(), st.dofs, st.rigid_modes_removed);
      std::printf("eigenvalues       ");
      for (double l : st.eigenvalues) std::printf(" %.6g", l);
      std::printf(" N/m\n");
      const PrestressReport ps = prestress_stability(scene, sol.positions, sol.forces);
      std::printf("prestress         %s, %s (%s)\n", ps.prestress_stable ? "prestress stable" : "not prestress stable",
                  ps.super_stable ? "super stable" : "not super stable", ps.message.c_str());
      if (!v.ok) return 1;
      return st.verdict == Stability::Stable ? 0 : kExitVerifiedNotStable;
    };
  });
}

}  // namespace tensegrity::cli
