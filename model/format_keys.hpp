#pragma once
// The known keys of the file formats (docs/FORMATS.md; model/known_keys.hpp
// says what happens to the others), and the parsers of formats that other
// formats embed, sharing the embedding file's KeyChecker: a design file holds
// a scene, a solution's keys and materials.
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "model/known_keys.hpp"
#include "model/material.hpp"
#include "model/structure.hpp"

namespace tensegrity {

// A scene's top level, node and element keys, including those the program
// writes itself (block and link ids, materials).
const std::vector<std::string_view>& scene_keys();
const std::vector<std::string_view>& scene_node_keys();
const std::vector<std::string_view>& scene_element_keys();
// A solution's top-level keys (the commands' optional ones included) and its
// "stats" keys.
const std::vector<std::string_view>& solution_keys();
const std::vector<std::string_view>& solution_stats_keys();
// A material's keys; "fit" holds free-form provenance, not checked inside.
const std::vector<std::string_view>& material_keys();

// scene_from_json and material_from_json with the unknown keys collected in
// `keys` (not reported); a material's keys are checked at path `item`.
Structure scene_from_json(const nlohmann::json& j, const std::string& source, KeyChecker& keys);
CableMaterial material_from_json(const nlohmann::json& j, const std::string& source, KeyChecker& keys,
                                 const std::string& item);

}  // namespace tensegrity
