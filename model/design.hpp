#pragma once
// A design file (format "tensegrity-design", version 1): everything needed to
// build and simulate a character, self-contained.
//
//   the scene keys ("name", "gravity", "nodes", "elements" with their extras)
//     at the designed geometry; every cable element carries "material";
//   the solution keys of docs/FORMATS.md ("scene", "solver", "status",
//     "positions", "forces", "stats", "rest_lengths");
//   "strains": per element, eps = l / L - 1 (0 for struts);
//   "materials": {name: material object (model/material.hpp)} for every
//     material a cable uses;
//   "design": how it was made (mode "stiffness" or "naive", target strain or
//     fraction, stage reports).
#include <Eigen/Core>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "model/material.hpp"
#include "model/solution.hpp"
#include "model/structure.hpp"

namespace tensegrity {

struct Design {
  Structure structure;                           // positions = the designed geometry
  Solution solution;                             // rest_lengths set
  Eigen::VectorXd strains;                       // m
  std::vector<std::string> cable_material;       // m, "" for struts
  std::map<std::string, CableMaterial> materials;
  nlohmann::json info = nlohmann::json::object();  // the "design" key

  // Per element, the material of each cable (nullptr for struts); pointers
  // into `materials`, valid while this Design lives unchanged.
  std::vector<const CableMaterial*> material_pointers() const;
};

nlohmann::json design_to_json(const Design& d);
void write_design_file(const Design& d, const std::string& path);
// Validates the scene part, per-element array lengths, rest lengths > 0 and
// that every cable names a material that the file defines.
Design design_from_json(const nlohmann::json& j, const std::string& source);
Design read_design_file(const std::string& path);

}  // namespace tensegrity
