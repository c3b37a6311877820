// tensegrity generate reference [--out-dir DIR]: the analytic reference scenes
// of data/reference/ (regular prisms n = 3..12 and the expandable octahedron,
// each plain and with gravity, masses and fixed bottom nodes).
#include <filesystem>
#include <iostream>
#include <memory>

#include "cli/commands.hpp"
#include "model/reference_scenes.hpp"
#include "model/scene_io.hpp"

namespace tensegrity::cli {

void register_generate_command(CLI::App& app, CommandRunner& run) {
  auto out_dir = std::make_shared<std::string>("data/reference");
  auto* cmd = app.add_subcommand("generate", "Write generated scene sets");
  auto* ref = cmd->add_subcommand("reference", "Regular prisms n=3..12 and the expandable octahedron");
  ref->add_option("--out-dir", *out_dir, "Folder to write into");
  cmd->require_subcommand(1);
  ref->callback([out_dir, &run] {
    run = [out_dir] {
      std::filesystem::create_directories(*out_dir);
      int count = 0;
      auto write = [&](Structure s, const std::string& name) {
        s.name = name;
        write_scene_file(s, *out_dir + "/" + name + ".scene.json");
        ++count;
      };
      for (int n = 3; n <= 12; ++n) {
        PrismParameters p;
        p.n = n;
        write(make_regular_prism(p), "prism-" + std::to_string(n));
        p.gravity = true;
        p.fix_bottom = true;
        p.strut_mass = 0.05;
        p.cable_mass = 0.005;
        write(make_regular_prism(p), "prism-" + std::to_string(n) + "-gravity");
      }
      OctahedronParameters o;
      write(make_expandable_octahedron(o), "octahedron");
      o.gravity = true;
      o.fix_bottom = true;
      o.strut_mass = 0.05;
      o.cable_mass = 0.005;
      write(make_expandable_octahedron(o), "octahedron-gravity");
      std::cerr << "wrote " << count << " scenes to " << *out_dir << "\n";
      return 0;
    };
  });
}

}  // namespace tensegrity::cli
