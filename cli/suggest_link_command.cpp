// tensegrity suggest-link CHARACTER --a BLOCK --b BLOCK (--axis X Y Z [--range DEG] | --stiff)
//                         [--faces K] [--cables K] [--solver NAME] [--cable-ea N] [--json FILE]
// Ranks the face and edge links that could join two blocks of a character by
// how well their rotational stiffness matches the wish (simulation/link_suggestion.hpp).
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>

#include "cli/commands.hpp"
#include "cli/link_suggestion_report.hpp"
#include "model/blocks.hpp"
#include "model/errors.hpp"
#include "model/json_io.hpp"
#include "model/json_text.hpp"
#include "model/scene_io.hpp"
#include "reports/output.hpp"
#include "simulation/link_suggestion.hpp"

namespace tensegrity::cli {

namespace {
struct SuggestLinkArgs {
  std::string character, block_a, block_b, blocks, json_out;
  SuggestLinkSettings settings;
};
}  // namespace

void register_suggest_link_command(CLI::App& app, CommandRunner& run) {
  auto args = std::make_shared<SuggestLinkArgs>();
  auto* cmd = app.add_subcommand("suggest-link", "Rank the links between two blocks by their rotational stiffness");
  cmd->add_option("character", args->character, "Character file holding the two blocks")->required();
  cmd->add_option("--a", args->block_a, "Id of the first block")->required();
  cmd->add_option("--b", args->block_b, "Id of the second block")->required();
  cmd->add_option("--axis", args->settings.axis, "Desired rotation axis (world frame): a hinge about it")->expected(3);
  cmd->add_option("--range", args->settings.range_deg, "Desired range of rotation about the axis (degrees)");
  cmd->add_flag("--stiff", args->settings.stiff, "Ask for the stiffest link instead of a hinge");
  cmd->add_option("--faces", args->settings.faces, "Faces per block tried for face links (default 3)");
  cmd->add_option("--cables", args->settings.cables, "Cables per block tried for edge links (default 3)");
  cmd->add_option("--solver", args->settings.solver,
                  "Form-finding backend (default: " + reports::default_solver_help() + ")");
  cmd->add_option("--cable-ea", args->settings.cable_ea, "Cable axial stiffness EA (N) of the linear cord model");
  cmd->add_option("--blocks", args->blocks, "Block library folder (default: the character's block_library)");
  cmd->add_option("--json", args->json_out, "Also write the ranking as JSON to this file");
  cmd->callback([args, &run] {
    run = [args] {
      const CheckedLinkSettings checked = check_link_settings(args->settings);
      const nlohmann::json character = read_json_file(args->character);
      json_expect_header(character, "tensegrity-character", args->character);
      std::string dir = args->blocks;
      if (dir.empty()) {
        const std::filesystem::path base = std::filesystem::path(args->character).parent_path();
        dir = (base / character.value("block_library", std::string("../blocks"))).lexically_normal().string();
      }
      const BlockLibrary library = BlockLibrary::load(dir);
      const auto ranked = suggest_links(character, args->character, library, args->block_a, args->block_b,
                                        checked.request, checked.options);
      std::printf("%-4s %-5s %-22s %-22s %-12s %10s %10s %10s %7s %10s %10s\n", "rank", "type", "a", "b", "status",
                  "k_min", "k_mid", "k_max", "aniso", args->settings.stiff ? "k_min" : "k_axis", args->settings.stiff ? "-" : "k_perp");
      int rank = 0;
      for (const auto& c : ranked) {
        ++rank;
        if (!c.measured) {
          std::printf("%-4d %-5s %-22s %-22s %-12s\n", rank, c.type.c_str(), c.a.c_str(), c.b.c_str(),
                      c.status.substr(0, 12).c_str());
          continue;
        }
        const auto& p = c.stiffness.principal;
        std::printf("%-4d %-5s %-22s %-22s %-12s %10.4g %10.4g %10.4g %7.2f %10.4g %10.4g\n", rank, c.type.c_str(),
                    c.a.c_str(), c.b.c_str(), c.status.c_str(), p[0], p[1], p[2], c.stiffness.anisotropy,
                    args->settings.stiff ? p[0] : c.about_axis, args->settings.stiff ? 0.0 : c.perpendicular);
      }
      if (!args->json_out.empty()) {
        const nlohmann::json out = link_suggestions_json(ranked, args->character, args->block_a, args->block_b);
        write_text_file_atomically(args->json_out, to_json_text(out) + "\n");
      }
      return 0;
    };
  });
}

}  // namespace tensegrity::cli
