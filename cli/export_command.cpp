// tensegrity export INPUT [--scene SCENE] --out FILE [--format vtk|obj|ply|ntrt-yaml|mjcf] [--length-scale S]
// INPUT is a scene, a solution (with --scene) or a design file.
#include <iostream>
#include <memory>

#include "cli/commands.hpp"
#include "reports/exporters.hpp"
#include "cli/mjcf.hpp"
#include "cli/ntrt_yaml.hpp"
#include "model/design.hpp"
#include "model/errors.hpp"
#include "model/scene_io.hpp"
#include "model/solution.hpp"

namespace tensegrity::cli {

namespace {

struct ExportArgs {
  std::string input, scene, format, out;
  double length_scale = 1.0;
};

// What an export draws from: the structure, positions, forces and, for designs, the design.
struct ExportSource {
  Structure scene;
  Eigen::Matrix3Xd positions;
  Eigen::VectorXd forces;
  std::optional<Design> design;
};

ExportSource read_export_source(const ExportArgs& a) {
  const nlohmann::json j = read_json_file(a.input);
  const std::string format = j.is_object() && j.contains("format") && j["format"].is_string()
                                 ? j["format"].get<std::string>()
                                 : std::string();
  ExportSource src;
  if (format == "tensegrity-design") {
    src.design = design_from_json(j, a.input);
    src.scene = src.design->structure;
    src.positions = src.design->solution.positions;
    src.forces = src.design->solution.forces;
  } else if (format == "tensegrity-solution") {
    if (a.scene.empty()) throw InputError("command line", "--scene", "a solution needs the scene it belongs to");
    src.scene = read_scene_file(a.scene);
    const Solution sol = read_solution_file(a.input, src.scene);
    src.positions = sol.positions;
    src.forces = sol.forces;
  } else if (format == "tensegrity-scene") {
    src.scene = scene_from_json(j, a.input);
    src.positions = src.scene.positions;
    src.forces = Eigen::VectorXd::Zero(src.scene.num_elements());
  } else {
    throw InputError(a.input, "format", "expected a tensegrity-scene, tensegrity-solution or tensegrity-design file");
  }
  return src;
}

}  // namespace

void register_export_command(CLI::App& app, CommandRunner& run) {
  auto args = std::make_shared<ExportArgs>();
  auto* cmd = app.add_subcommand(
      "export", "Write a scene, solution or design for other tools (VTK, OBJ, PLY, NTRT YAML, MuJoCo MJCF)");
  cmd->add_option("input", args->input, "Scene, solution (with --scene) or design file")->required();
  cmd->add_option("--scene", args->scene, "The scene a solution belongs to");
  cmd->add_option("--format", args->format, "vtk, obj, ply, ntrt-yaml or mjcf (default: from the extension of --out)");
  cmd->add_option("--out", args->out, "Output file, - for standard output (needs --format)")->required();
  cmd->add_option("--length-scale", args->length_scale, "NTRT YAML: metres per file length unit (default 1)")
      ->check(CLI::PositiveNumber);
  cmd->callback([args, &run] {
    run = [args] {
      const reports::ExportFormat format = reports::export_format_for(args->out, args->format);
      const ExportSource src = read_export_source(*args);
      switch (format) {
        case reports::ExportFormat::Mjcf:
          if (!src.design) throw InputError(args->input, "", "MJCF export needs a design (rest lengths and cords)");
          write_text_file_atomically(args->out, write_mjcf(*src.design));
          break;
        case reports::ExportFormat::NtrtYaml: {
          NtrtExtras extras;
          if (src.design || !src.forces.isZero(0.0)) extras.forces = src.forces;
          if (src.design) {
            const Design& d = *src.design;
            const auto materials = d.material_pointers();
            Eigen::VectorXd k = Eigen::VectorXd::Zero(src.scene.num_elements());
            for (int e = 0; e < src.scene.num_elements(); ++e) {
              if (src.scene.elements[e].kind != ElementKind::Cable) continue;
              const auto& el = src.scene.elements[e];
              const double l = (src.positions.col(el.a) - src.positions.col(el.b)).norm();
              const double L = (*d.solution.rest_lengths)[e];
              k[e] = l > L ? d.solution.forces[e] / (l - L)
                           : (materials[e] ? materials[e]->slope_unchecked(l / L - 1.0) / L : 0.0);
            }
            extras.stiffness = k;
            extras.rest_lengths = *d.solution.rest_lengths;
          }
          write_text_file_atomically(args->out, write_ntrt_yaml(src.scene, src.positions, extras, args->length_scale));
          break;
        }
        case reports::ExportFormat::Obj:
          if (args->out != "-")
            write_text_file_atomically(args->out + ".forces.csv", reports::element_forces_csv(src.scene, src.forces));
          write_text_file_atomically(args->out, reports::export_lines(src.scene, src.positions, src.forces, format));
          break;
        default:
          write_text_file_atomically(args->out, reports::export_lines(src.scene, src.positions, src.forces, format));
      }
      return 0;
    };
  });
}

}  // namespace tensegrity::cli
