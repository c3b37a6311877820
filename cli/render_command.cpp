// tensegrity render SCENE [--solution SOLUTION] --out FILE.png|.svg [--view front|side|top|iso]
#include <memory>
#include <optional>

#include "cli/commands.hpp"
#include "cli/renderer.hpp"
#include "model/scene_io.hpp"
#include "model/solution.hpp"

namespace tensegrity::cli {

namespace {
struct RenderArgs {
  std::string scene, solution, out;
  RenderOptions options;
};
}  // namespace

void register_render_command(CLI::App& app, CommandRunner& run) {
  auto args = std::make_shared<RenderArgs>();
  auto* cmd = app.add_subcommand("render", "Draw a scene (or a solution of it) to PNG or SVG");
  cmd->add_option("scene", args->scene, "Scene file (*.scene.json)")->required();
  cmd->add_option("--solution", args->solution, "Draw this solution's positions, coloured by its forces");
  cmd->add_option("--out", args->out, "Picture file (.png or .svg)")->required();
  cmd->add_option("--view", args->options.view, "front, side, top or iso");
  cmd->add_option("--width", args->options.width, "Width in pixels")->check(CLI::Range(64, 8192));
  cmd->add_option("--height", args->options.height, "Height in pixels")->check(CLI::Range(64, 8192));
  cmd->add_option("--title", args->options.title, "Caption in the top-left corner");
  cmd->callback([args, &run] {
    run = [args] {
      const Structure scene = read_scene_file(args->scene);
      if (args->solution.empty()) {
        render_scene(scene, scene.positions, std::nullopt, args->options, args->out);
      } else {
        const Solution sol = read_solution_file(args->solution, scene);
        render_scene(scene, sol.positions, sol.forces, args->options, args->out);
      }
      return 0;
    };
  });
}

}  // namespace tensegrity::cli
