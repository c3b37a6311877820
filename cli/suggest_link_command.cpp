// tensegrity suggest-link CHARACTER --a BLOCK --b BLOCK (--axis X Y Z [--range DEG] | --stiff)
//                         [--faces K] [--cables K] [--solver NAME] [--cable-ea N] [--json FILE]
// Ranks the face and edge links that could join two blocks of a character by
// how well their rotational stiffness matches the wish (simulation/link_suggestion.hpp).
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>

#include "cli/commands.hpp"
#include "model/blocks.hpp"
#include "model/errors.hpp"
#include "model/json_io.hpp"
#include "model/json_text.hpp"
#include "model/scene_io.hpp"
#include "simulation/link_suggestion.hpp"

namespace tensegrity::cli {

namespace {
struct SuggestLinkArgs {
  std::string character, block_a, block_b, solver, blocks, json_out;
  std::vector<double> axis;
  double range_deg = 30.0;
  bool stiff = false;
  int faces = 3, cables = 3;
  double cable_ea = 20.0;
};

nlohmann::json suggestion_to_json(const LinkCandidate& c) {
  nlohmann::json j = {{"type", c.type}, {"a", c.a}, {"b", c.b}, {"status", c.status}, {"measured", c.measured},
                      {"link", c.link}, {"geometry_change", c.geometry_change}};
  if (c.measured) {
    const auto& p = c.stiffness.principal;
    nlohmann::json axes = nlohmann::json::array();
    for (int k = 0; k < 3; ++k)
      axes.push_back({c.stiffness.principal_axes(0, k), c.stiffness.principal_axes(1, k), c.stiffness.principal_axes(2, k)});
    j["principal_stiffness"] = {p[0], p[1], p[2]};
    j["principal_axes"] = axes;
    j["anisotropy"] = c.stiffness.anisotropy;
    j["about_axis"] = c.about_axis;
    j["perpendicular"] = c.perpendicular;
    j["torque_for_range"] = c.torque_for_range;
    j["score"] = c.score;
  }
  return j;
}
}  // namespace

void register_suggest_link_command(CLI::App& app, CommandRunner& run) {
  auto args = std::make_shared<SuggestLinkArgs>();
  auto* cmd = app.add_subcommand("suggest-link", "Rank the links between two blocks by their rotational stiffness");
  cmd->add_option("character", args->character, "Character file holding the two blocks")->required();
  cmd->add_option("--a", args->block_a, "Id of the first block")->required();
  cmd->add_option("--b", args->block_b, "Id of the second block")->required();
  cmd->add_option("--axis", args->axis, "Desired rotation axis (world frame): a hinge about it")->expected(3);
  cmd->add_option("--range", args->range_deg, "Desired range of rotation about the axis (degrees)");
  cmd->add_flag("--stiff", args->stiff, "Ask for the stiffest link instead of a hinge");
  cmd->add_option("--faces", args->faces, "Faces per block tried for face links (default 3)");
  cmd->add_option("--cables", args->cables, "Cables per block tried for edge links (default 3)");
  cmd->add_option("--solver", args->solver, "Form-finding backend (default: the recommended one)");
  cmd->add_option("--cable-ea", args->cable_ea, "Cable axial stiffness EA (N) of the linear cord model");
  cmd->add_option("--blocks", args->blocks, "Block library folder (default: the character's block_library)");
  cmd->add_option("--json", args->json_out, "Also write the ranking as JSON to this file");
  cmd->callback([args, &run] {
    run = [args] {
      if (args->stiff == !args->axis.empty())
        throw InputError("command line", "suggest-link", "give either --axis X Y Z or --stiff");
      if (args->faces < 1 || args->cables < 0) throw InputError("command line", "--faces", "must be >= 1 (cables >= 0)");
      if (!(args->cable_ea > 0.0)) throw InputError("command line", "--cable-ea", "must be > 0");
      LinkRequest request;
      request.stiff = args->stiff;
      request.range_deg = args->range_deg;
      if (!args->stiff) {
        request.axis = Eigen::Vector3d(args->axis[0], args->axis[1], args->axis[2]);
        if (!request.axis.allFinite() || request.axis.norm() == 0.0)
          throw InputError("command line", "--axis", "must be a finite nonzero vector");
      }
      const nlohmann::json character = read_json_file(args->character);
      json_expect_header(character, "tensegrity-character", args->character);
      std::string dir = args->blocks;
      if (dir.empty()) {
        const std::filesystem::path base = std::filesystem::path(args->character).parent_path();
        dir = (base / character.value("block_library", std::string("../blocks"))).lexically_normal().string();
      }
      const BlockLibrary library = BlockLibrary::load(dir);
      LinkSuggestionOptions options;
      options.faces_per_block = args->faces;
      options.cables_per_block = args->cables;
      options.solver = args->solver;
      options.stiffness.cable_ea = args->cable_ea;
      const auto ranked = suggest_links(character, args->character, library, args->block_a, args->block_b,
                                        request, options);
      std::printf("%-4s %-5s %-22s %-22s %-12s %10s %10s %10s %7s %10s %10s\n", "rank", "type", "a", "b", "status",
                  "k_min", "k_mid", "k_max", "aniso", args->stiff ? "k_min" : "k_axis", args->stiff ? "-" : "k_perp");
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
                    args->stiff ? p[0] : c.about_axis, args->stiff ? 0.0 : c.perpendicular);
      }
      if (!args->json_out.empty()) {
        nlohmann::json out = {{"format", "tensegrity-link-suggestions"}, {"version", 1},
                              {"character", args->character}, {"a", args->block_a}, {"b", args->block_b},
                              {"units", "N m / rad (rotational stiffness), N m (torque)"},
                              {"candidates", nlohmann::json::array()}};
        for (const auto& c : ranked) out["candidates"].push_back(suggestion_to_json(c));
        write_text_file_atomically(args->json_out, to_json_text(out) + "\n");
      }
      return 0;
    };
  });
}

}  // namespace tensegrity::cli
