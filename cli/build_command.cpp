// tensegrity build CHARACTER --out SCENE [--blocks DIR]
// tensegrity build --chain N --out SCENE [--blocks DIR]
// tensegrity build --write-blocks DIR   (regenerates the standard block files)
#include <filesystem>
#include <iostream>
#include <memory>

#include "cli/commands.hpp"
#include "model/character.hpp"
#include "model/errors.hpp"
#include "model/scene_io.hpp"

namespace tensegrity::cli {

namespace {
struct BuildArgs {
  std::string character;
  std::string out;
  std::string blocks;
  std::string write_blocks;
  int chain = 0;
};
}  // namespace

void register_build_command(CLI::App& app, CommandRunner& run) {
  auto args = std::make_shared<BuildArgs>();
  auto* cmd = app.add_subcommand("build", "Assemble a character from blocks and links into a scene");
  cmd->add_option("character", args->character, "Character file (*.character.json)");
  cmd->add_option("--out", args->out, "Scene file to write, - for standard output");
  cmd->add_option("--chain", args->chain, "Build the parametric chain of N face-linked blocks (2..200)");
  cmd->add_option("--blocks", args->blocks, "Block library folder (default: the character's block_library)");
  cmd->add_option("--write-blocks", args->write_blocks, "Write the standard block templates into this folder");
  cmd->callback([args, &run] {
    run = [args] {
      if (!args->write_blocks.empty()) {
        std::filesystem::create_directories(args->write_blocks);
        int count = 0;
        for (const Block& b : make_standard_blocks()) {
          write_block_file(b, args->write_blocks + "/" + b.name + ".block.json");
          ++count;
        }
        std::cerr << "wrote " << count << " blocks to " << args->write_blocks << "\n";
        if (args->character.empty() && args->chain == 0) return 0;
      }
      const bool chain = args->chain != 0;
      if (chain == !args->character.empty())
        throw InputError("command line", "build", "give either a CHARACTER file or --chain N");
      if (args->out.empty()) throw InputError("command line", "--out", "missing");
      BuiltCharacter built;
      if (chain) {
        if (args->chain < 2 || args->chain > 200)
          throw InputError("command line", "--chain", "N must be within 2..200");
        const BlockLibrary lib =
            args->blocks.empty() ? BlockLibrary::standard() : BlockLibrary::load(args->blocks);
        built = build_character(make_chain_character(args->chain), "chain-" + std::to_string(args->chain), lib);
      } else {
        built = build_character_file(args->character, args->blocks);
      }
      write_scene_file(built.structure, args->out);
      const auto& c = built.counts;
      std::cerr << built.structure.name << ": " << c.blocks << " blocks, " << c.face_links << " face links, "
                << c.edge_links << " edge links, " << c.struts << " struts, " << c.cables << " cables, "
                << c.nodes << " nodes (" << c.fixed_nodes << " fixed), mass " << c.mass << " kg\n";
      return 0;
    };
  });
}

}  // namespace tensegrity::cli
