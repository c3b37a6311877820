// tensegrity import FILE --out SCENE [--format ntrt-yaml] [--length-scale S] [--fix-lowest K]
#include <algorithm>
#include <memory>
#include <numeric>

#include "reports/canvas.hpp"
#include "cli/commands.hpp"
#include "cli/ntrt_yaml.hpp"
#include "model/errors.hpp"
#include "model/scene_io.hpp"

namespace tensegrity::cli {

namespace {
struct ImportArgs {
  std::string input, out, format;
  double length_scale = 1.0;
  int fix_lowest = 0;
};
}  // namespace

void register_import_command(CLI::App& app, CommandRunner& run) {
  auto args = std::make_shared<ImportArgs>();
  auto* cmd = app.add_subcommand("import", "Read another tool's structure file (NTRT YAML) into a scene");
  cmd->add_option("input", args->input, "Structure file (.yaml / .yml: NTRT YAML)")->required();
  cmd->add_option("--out", args->out, "Scene file to write, - for standard output")->required();
  cmd->add_option("--format", args->format, "ntrt-yaml (default: from the extension)");
  cmd->add_option("--length-scale", args->length_scale, "Metres per file length unit (default 1)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--fix-lowest", args->fix_lowest,
                  "Also mark the K lowest nodes fixed (NTRT files carry no supports)")
      ->check(CLI::NonNegativeNumber);
  cmd->callback([args, &run] {
    run = [args] {
      const bool yaml_name = reports::ends_with(args->input, ".yaml") || reports::ends_with(args->input, ".yml");
      const bool yaml = args->format == "ntrt-yaml" || (args->format.empty() && yaml_name);
      if (!args->format.empty() && args->format != "ntrt-yaml")
        throw InputError("command line", "--format", "must be ntrt-yaml (got '" + args->format + "')");
      if (!yaml) throw InputError("command line", args->input, "unknown extension (.yaml); name the format with --format");
      Structure s = read_ntrt_yaml(args->input, args->length_scale);
      std::vector<int> order(s.num_nodes());
      std::iota(order.begin(), order.end(), 0);
      std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return s.positions(2, a) < s.positions(2, b); });
      for (int k = 0; k < std::min(args->fix_lowest, s.num_nodes()); ++k) s.fixed[order[k]] = true;
      validate(s, args->input);
      write_scene_file(s, args->out);
      return 0;
    };
  });
}

}  // namespace tensegrity::cli
