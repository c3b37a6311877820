// tensegrity render INPUT [--solution SOLUTION | --frames FRAMES.jsonl [--frame K]] --out FILE.png|.svg
//                  [--view front|side|top|iso] [--colour-by force|strain|block|kind] [--labels] [--no-legend]
//                  [--no-reference]
// INPUT is a scene or a design file.
#include <fstream>
#include <memory>
#include <optional>

#include "cli/commands.hpp"
#include "reports/renderer.hpp"
#include "model/design.hpp"
#include "model/errors.hpp"
#include "model/json_io.hpp"
#include "model/scene_io.hpp"
#include "model/solution.hpp"

namespace tensegrity::cli {

namespace {
struct RenderArgs {
  std::string input, solution, frames, out;
  int frame = -1;  // -1: the last
  bool no_legend = false, no_reference = false;
  reports::RenderOptions options;
};

// Positions and forces of frame `index` of a `simulate` JSON Lines file.
std::pair<Eigen::Matrix3Xd, Eigen::VectorXd> read_frame(const std::string& path, int index, const Structure& s,
                                                        double* time) {
  std::istringstream in(read_text_file(path));
  std::string line, chosen;
  int count = 0, line_number = 0, chosen_line = 0, chosen_frame = 0;
  while (std::getline(in, line)) {
    ++line_number;
    if (line.empty()) continue;
    if (count == index || index < 0) chosen = line, chosen_line = line_number, chosen_frame = count;
    ++count;
  }
  if (chosen.empty())
    throw InputError(path, "--frame " + std::to_string(index), "no such frame (" + std::to_string(count) + " frames)");
  // Items name the file's line and the frame (0-based), as the JSON Lines file counts them.
  const std::string where = "line " + std::to_string(chosen_line) + " (frame " + std::to_string(chosen_frame) + ")";
  nlohmann::json j;
  try {
    j = parse_json_text(chosen, path);
  } catch (const InputError& e) {
    // The parser saw one line: its "line 1, column C" is the file's line and column C.
    const std::string line_one = "line 1, ";
    const std::string column = e.item().rfind(line_one, 0) == 0 ? e.item().substr(line_one.size()) : e.item();
    throw InputError(path, where + ", " + column, e.reason());
  }
  if (!j.is_object() || !j.contains("positions") || !j["positions"].is_array() ||
      j["positions"].size() != static_cast<std::size_t>(s.num_nodes()))
    throw InputError(path, where + ": positions", "not one position per node of the design");
  if (!j.contains("forces") || !j["forces"].is_array() || j["forces"].size() != static_cast<std::size_t>(s.num_elements()))
    throw InputError(path, where + ": forces", "not one force per element of the design");
  Eigen::Matrix3Xd x(3, s.num_nodes());
  Eigen::VectorXd f(s.num_elements());
  const auto number = [&](const nlohmann::json& v, const std::string& item) {
    if (!v.is_number()) throw InputError(path, where + ": " + item, "expected a number, got " + json_describe(v));
    return v.get<double>();
  };
  for (int i = 0; i < s.num_nodes(); ++i) {
    const nlohmann::json& p = j["positions"][i];
    const std::string item = "positions[" + std::to_string(i) + "]";
    if (!p.is_array() || p.size() != 3) throw InputError(path, where + ": " + item, "expected 3 numbers");
    for (int k = 0; k < 3; ++k) x(k, i) = number(p[k], item);
  }
  for (int e = 0; e < s.num_elements(); ++e) f[e] = number(j["forces"][e], "forces[" + std::to_string(e) + "]");
  if (!x.allFinite() || !f.allFinite()) throw InputError(path, where, "non-finite number");
  *time = j.contains("time") ? number(j["time"], "time") : 0.0;
  return {x, f};
}

int run_render(RenderArgs& a) {
  a.options.legend = !a.no_legend;
  const nlohmann::json j = read_json_file(a.input);
  const bool design_input = j.is_object() && j.value("format", "") == "tensegrity-design";
  reports::RenderData data;
  if (design_input) {
    const Design d = design_from_json(j, a.input);
    const Structure& s = d.structure;
    data.strains = d.strains;
    if (!a.frames.empty()) {
      double time = 0.0;
      auto [x, f] = read_frame(a.frames, a.frame, s, &time);
      data.forces = f;
      if (!a.no_reference) data.reference = d.solution.positions;
      if (a.options.title.empty()) a.options.title = s.name + ", t = " + std::to_string(time).substr(0, 6) + " s";
      reports::render_structure(s, x, data, a.options, a.out);
    } else {
      data.forces = d.solution.forces;
      reports::render_structure(s, d.solution.positions, data, a.options, a.out);
    }
    return 0;
  }
  if (!a.frames.empty()) throw InputError("command line", "--frames", "frames belong to a design: give the design file");
  const Structure scene = scene_from_json(j, a.input);
  if (a.solution.empty()) {
    reports::render_structure(scene, scene.positions, data, a.options, a.out);
  } else {
    const Solution sol = read_solution_file(a.solution, scene);
    data.forces = sol.forces;
    if (!a.no_reference) data.reference = scene.positions;
    reports::render_structure(scene, sol.positions, data, a.options, a.out);
  }
  return 0;
}
}  // namespace

void register_render_command(CLI::App& app, CommandRunner& run) {
  auto args = std::make_shared<RenderArgs>();
  auto* cmd = app.add_subcommand("render", "Draw a scene, a solution, a design or a simulation frame to PNG or SVG");
  cmd->add_option("input", args->input, "Scene (*.scene.json) or design file")->required();
  cmd->add_option("--solution", args->solution, "Draw this solution of the scene, coloured by its forces");
  cmd->add_option("--frames", args->frames, "With a design: `simulate --out` frames (JSON Lines)");
  cmd->add_option("--frame", args->frame, "Frame to draw (0-based; default the last)");
  cmd->add_option("--out", args->out, "Picture file (.png or .svg)")->required();
  cmd->add_option("--view", args->options.view, "front, side, top or iso");
  cmd->add_option("--colour-by,--color-by", args->options.colour_by, "force (default), strain (designs), block or kind");
  cmd->add_flag("--labels", args->options.labels, "Write node and element ids");
  cmd->add_flag("--no-legend", args->no_legend, "No key, colour bar, scale bar or axes");
  cmd->add_flag("--no-reference", args->no_reference, "Do not draw the shape before form finding behind the result");
  cmd->add_option("--width", args->options.width, "Width in pixels")->check(CLI::Range(64, 8192));
  cmd->add_option("--height", args->options.height, "Height in pixels")->check(CLI::Range(64, 8192));
  cmd->add_option("--title", args->options.title, "Caption in the top-left corner");
  cmd->callback([args, &run] { run = [args] { return run_render(*args); }; });
}

}  // namespace tensegrity::cli
