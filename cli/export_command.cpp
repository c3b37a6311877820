// tensegrity export SOLUTION --scene SCENE --format vtk|obj|ply --out FILE
#include <iostream>
#include <memory>

#include "cli/commands.hpp"
#include "cli/exporters.hpp"
#include "model/scene_io.hpp"
#include "model/solution.hpp"

namespace tensegrity::cli {

namespace {
struct ExportArgs {
  std::string solution, scene, format = "vtk", out;
};
}  // namespace

void register_export_command(CLI::App& app, CommandRunner& run) {
  auto args = std::make_shared<ExportArgs>();
  auto* cmd = app.add_subcommand("export", "Write a solution as lines with forces (VTK, OBJ or PLY)");
  cmd->add_option("solution", args->solution, "Solution file (*.solution.json)")->required();
  cmd->add_option("--scene", args->scene, "The scene the solution belongs to")->required();
  cmd->add_option("--format", args->format, "vtk, obj or ply");
  cmd->add_option("--out", args->out, "Output file, - for standard output")->required();
  cmd->callback([args, &run] {
    run = [args] {
      const ExportFormat format = export_format_from_string(args->format);
      const Structure scene = read_scene_file(args->scene);
      const Solution sol = read_solution_file(args->solution, scene);
      write_text_file_atomically(args->out, export_lines(scene, sol.positions, sol.forces, format));
      return 0;
    };
  });
}

}  // namespace tensegrity::cli
