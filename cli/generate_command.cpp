// tensegrity generate reference [--out-dir DIR]: the analytic reference scenes
// of data/reference/ (regular prisms n = 3..12 and the expandable octahedron,
// each plain and with gravity, masses and fixed bottom nodes).
// tensegrity generate tower [--gravity] [--noise X] [--seed S] --out FILE: the
// benchmark's large tower (scenes/towers.hpp) as built, before form
// finding; data/bench/tower-*.scene.json are Ipopt equilibria of it, solved once
// and stored (docs/USER-GUIDE.md, generate).
// tensegrity generate grid [--rows R] [--cols C] [--cables-per-join K] --out FILE:
// expandable octahedra on a grid joined by cables (scenes/towers.hpp).
#include <filesystem>
#include <iostream>
#include <memory>

#include "cli/commands.hpp"
#include "scenes/towers.hpp"
#include "model/errors.hpp"
#include "model/reference_scenes.hpp"
#include "model/scene_io.hpp"

namespace tensegrity::cli {

void register_generate_command(CLI::App& app, CommandRunner& run) {
  auto out_dir = std::make_shared<std::string>("data/reference");
  auto* cmd = app.add_subcommand("generate", "Write generated scene sets");
  auto* ref = cmd->add_subcommand("reference", "Regular prisms n=3..12 and the expandable octahedron");
  ref->add_option("--out-dir", *out_dir, "Folder to write into");
  struct TowerArgs {
    scenes::TowerParameters p;
    std::string out;
  };
  auto tower = std::make_shared<TowerArgs>();
  tower->p.noise = 0.0;
  auto* tw = cmd->add_subcommand("tower", "The benchmark's tower of prisms joined by cables (not in equilibrium)");
  tw->add_option("--layers", tower->p.layers, "Prism layers")->check(CLI::Range(1, 1000));
  tw->add_option("--struts-per-layer", tower->p.struts_per_layer, "Struts per prism")->check(CLI::Range(3, 100));
  tw->add_option("--cables", tower->p.cables, "Total cables (prism cables included)")->check(CLI::Range(0, 1000000));
  tw->add_option("--noise", tower->p.noise, "Node noise, fraction of the strut length")->check(CLI::Range(0.0, 1.0));
  tw->add_option("--seed", tower->p.seed, "Seed of the noise");
  tw->add_flag("--gravity", tower->p.gravity, "Masses on every element, bottom ring fixed, gravity -z");
  tw->add_option("--out", tower->out, "Scene file to write")->required();
  tw->callback([tower, &run] {
    run = [tower] {
      write_scene_file(scenes::make_prism_tower(tower->p), tower->out);
      return 0;
    };
  });
  struct GridArgs {
    scenes::OctahedronGridParameters p;
    std::string out;
  };
  auto grid = std::make_shared<GridArgs>();
  auto* gr = cmd->add_subcommand("grid", "Expandable octahedra on a grid joined by cables (not in equilibrium)");
  gr->add_option("--rows", grid->p.rows, "Rows of octahedra")->check(CLI::Range(1, 100));
  gr->add_option("--cols", grid->p.cols, "Columns of octahedra")->check(CLI::Range(1, 100));
  gr->add_option("--cables-per-join", grid->p.cables_per_join, "Shortest cables between grid neighbours")
      ->check(CLI::Range(1, 144));
  gr->add_option("--out", grid->out, "Scene file to write")->required();
  gr->callback([grid, &run] {
    run = [grid] {
      write_scene_file(scenes::octahedron_grid(grid->p), grid->out);
      return 0;
    };
  });
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
