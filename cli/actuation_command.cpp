// tensegrity actuation SCENE --solution SOL --poses POSES [--max-actuators K] [--cables-only]
//                      [--design FILE | --cable-strain EPS] [--json FILE]
// Finds a few cables or struts whose rest-length changes move the character
// into the desired poses, verified by the static solve (simulation/actuation.hpp).
//
// Poses file: {"format": "tensegrity-poses", "version": 1, "poses": [
//   {"name": "nod", "targets": [{"node": 12, "position": [x, y, z]},
//                               {"block": "head", "by": [dx, dy, dz]}]}]}
// "block" + "by" asks every free node of that block to move by the same vector
// from its position in the solution (docs/FORMATS.md).
// The elastic model is the design's (cable materials and rest lengths) or, without
// --design, linear cords at --cable-strain; either must make the solution a
// stable equilibrium, else the command stops with exit status 2.
#include <cstdio>
#include <iostream>
#include <memory>

#include "cli/commands.hpp"
#include "model/errors.hpp"
#include "model/design.hpp"
#include "model/json_io.hpp"
#include "model/json_text.hpp"
#include "model/known_keys.hpp"
#include "model/scene_io.hpp"
#include "model/solution.hpp"
#include "simulation/actuation.hpp"

namespace tensegrity::cli {

namespace {
struct ActuationArgs {
  std::string scene, solution, poses, design, json_out;
  int max_actuators = 6;
  bool cables_only = false;
  double cable_strain = 0.1;
};

std::vector<Pose> read_poses_file(const std::string& path, const Structure& s, const Eigen::Matrix3Xd& x) {
  const nlohmann::json j = read_json_file(path);
  json_expect_header(j, "tensegrity-poses", path);
  KeyChecker keys(path);
  keys.check(j, {"format", "version", "poses"}, "");
  if (!j.contains("poses") || !j["poses"].is_array() || j["poses"].empty())
    throw InputError(path, "poses", "missing or not a non-empty array");
  std::vector<Pose> out;
  for (std::size_t p = 0; p < j["poses"].size(); ++p) {
    const std::string item = "poses[" + std::to_string(p) + "]";
    const auto& jp = j["poses"][p];
    if (!jp.is_object() || !jp.contains("targets") || !jp["targets"].is_array() || jp["targets"].empty())
      throw InputError(path, item + ".targets", "missing or not a non-empty array");
    keys.check(jp, {"name", "targets"}, item);
    Pose pose;
    pose.name = jp.contains("name") ? json_string(jp["name"], path, item + ".name") : "pose-" + std::to_string(p);
    for (std::size_t k = 0; k < jp["targets"].size(); ++k) {
      const std::string it = item + ".targets[" + std::to_string(k) + "]";
      const auto& jt = jp["targets"][k];
      if (!jt.is_object()) throw InputError(path, it, "not an object");
      keys.check(jt, {"node", "position", "block", "by"}, it);
      if (jt.contains("node")) {
        const int node = json_index(jt["node"], s.num_nodes(), "node", path, it + ".node");
        if (!jt.contains("position")) throw InputError(path, it + ".position", "missing");
        if (s.fixed[node]) throw InputError(path, it + ".node", "is a fixed node");
        pose.targets.push_back({node, json_vector3(jt["position"], path, it + ".position")});
      } else if (jt.contains("block")) {
        const std::string block = json_string(jt["block"], path, it + ".block");
        if (!jt.contains("by")) throw InputError(path, it + ".by", "missing");
        const Eigen::Vector3d by = json_vector3(jt["by"], path, it + ".by");
        int found = 0;
        for (int i = 0; i < s.num_nodes(); ++i)
          if (i < static_cast<int>(s.node_extra.size()) && s.node_extra[i].value("block", "") == block && !s.fixed[i]) {
            pose.targets.push_back({i, x.col(i) + by});
            ++found;
          }
        if (found == 0) throw InputError(path, it + ".block", "no free node of block '" + block + "' in the scene");
      } else {
        throw InputError(path, it, "needs \"node\" and \"position\", or \"block\" and \"by\"");
      }
    }
    out.push_back(std::move(pose));
  }
  keys.report();
  return out;
}

ElasticModel load_model(const ActuationArgs& args, const Structure& scene, const Solution& sol) {
  if (args.design.empty()) return make_linear_elastic_model(scene, sol.positions, sol.forces, args.cable_strain);
  ElasticModel model = make_elastic_model(read_design_file(args.design));
  if (model.structure.num_nodes() != scene.num_nodes() || model.structure.num_elements() != scene.num_elements())
    throw InputError(args.design, "elements", "the design is not of this scene (node or element count differs)");
  for (int e = 0; e < scene.num_elements(); ++e)
    if (model.structure.elements[e].a != scene.elements[e].a || model.structure.elements[e].b != scene.elements[e].b)
      throw InputError(args.design, "elements[" + std::to_string(e) + "]", "joins other nodes than the scene's");
  return model;
}

std::string element_label(const Structure& s, int e) {
  const auto& x = s.element_extra[e];
  std::string label = std::string(s.elements[e].kind == ElementKind::Strut ? "strut" : "cable") + " " +
                      std::to_string(e);
  if (x.contains("block")) label += " (" + x.value("block", "") + " " + x.value("name", "") + ")";
  if (x.contains("link")) label += " (link " + x.value("link", "") + ")";
  return label;
}
}  // namespace

void register_actuation_command(CLI::App& app, CommandRunner& run) {
  auto args = std::make_shared<ActuationArgs>();
  auto* cmd = app.add_subcommand("actuation", "Find a few elements whose rest-length changes reach desired poses");
  cmd->add_option("scene", args->scene, "Scene file (a built character)")->required();
  cmd->add_option("--solution", args->solution, "Its form-found solution (the equilibrium to start from)")->required();
  cmd->add_option("--poses", args->poses, "Poses file (tensegrity-poses)")->required();
  cmd->add_option("--max-actuators", args->max_actuators, "Largest set size tried (default 6)");
  cmd->add_flag("--cables-only", args->cables_only, "Only cables change length");
  cmd->add_option("--cable-strain", args->cable_strain,
                  "Without --design: strain of every cable at the solution's forces (linear cords, default 0.1)");
  cmd->add_option("--design", args->design,
                  "Take cable materials and rest lengths from this design (tensegrity design --out) instead of linear cords");
  cmd->add_option("--json", args->json_out, "Also write the result as JSON to this file");
  cmd->callback([args, &run] {
    run = [args] {
      if (args->max_actuators < 1 || args->max_actuators > 100)
        throw InputError("command line", "--max-actuators", "must be within 1..100");
      if (!(args->cable_strain > 0.0 && args->cable_strain < 10.0))
        throw InputError("command line", "--cable-strain", "must be within (0, 10)");
      const Structure scene = read_scene_file(args->scene);
      const Solution sol = read_solution_file(args->solution, scene);
      for (int e = 0; e < scene.num_elements(); ++e)
        if (scene.elements[e].kind == ElementKind::Cable ? !(sol.forces[e] > 0.0) : !(sol.forces[e] < 0.0))
          throw InputError(args->solution, "forces[" + std::to_string(e) + "]", "has the wrong sign for its element");
      const std::vector<Pose> poses = read_poses_file(args->poses, scene, sol.positions);
      const ElasticModel model = load_model(*args, scene, sol);
      ActuationOptions options;
      options.max_actuators = args->max_actuators;
      options.cables_only = args->cables_only;
      const ActuationResult result = find_actuators(model, sol.positions, poses, options);
      if (!result.stable_start)
        throw InputError(args->solution, "positions",
                         "not a stable equilibrium of the elastic model (" + result.message + "); pass --design" +
                             (args->design.empty() ? " or a smaller --cable-strain" : " of a stiffer build"));
      const auto& levels = result.levels;
      std::printf("%-9s %-14s %12s %12s %12s %12s  %s\n", "actuators", "pose", "start_rms_m", "linear_rms_m",
                  "reached_rms_m", "reached_max_m", "added element");
      nlohmann::json jl = nlohmann::json::array();
      for (const auto& level : levels) {
        const int e = level.elements.back();
        nlohmann::json entry = {{"actuators", level.elements.size()}, {"elements", level.elements},
                                {"poses", nlohmann::json::array()}};
        for (std::size_t p = 0; p < level.poses.size(); ++p) {
          const auto& pr = level.poses[p];
          std::printf("%-9zu %-14s %12.4g %12.4g %12.4g %12.4g  %s\n", level.elements.size(), pr.name.c_str(),
                      pr.initial_error, pr.linear_error, pr.reached_error, pr.max_error,
                      p == 0 ? element_label(scene, e).c_str() : "");
          std::vector<double> dl(pr.rest_length_change.data(), pr.rest_length_change.data() + pr.rest_length_change.size());
          entry["poses"].push_back({{"name", pr.name}, {"start_rms", pr.initial_error}, {"linear_rms", pr.linear_error},
                                    {"reached_rms", pr.reached_error}, {"reached_max", pr.max_error},
                                    {"steps_accepted", pr.steps_accepted}, {"cables_slack", pr.cables_slack},
                                    {"rest_length_change", dl}});
        }
        jl.push_back(entry);
      }
      if (!args->json_out.empty())
        write_text_file_atomically(args->json_out, to_json_text({{"format", "tensegrity-actuation"}, {"version", 1},
                                                                  {"scene", args->scene}, {"levels", jl}}) + "\n");
      return 0;
    };
  });
}

}  // namespace tensegrity::cli
