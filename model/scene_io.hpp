#pragma once
// Scene files (docs/FORMATS.md, format "tensegrity-scene", version 1).
#include <iosfwd>
#include <nlohmann/json.hpp>
#include <string>

#include "model/json_io.hpp"
#include "model/structure.hpp"
#include "model/text_file.hpp"

namespace tensegrity {

// Builds and validates a structure from a parsed scene; `source` names the file
// in error messages.
Structure scene_from_json(const nlohmann::json& j, const std::string& source);
Structure read_scene_file(const std::string& path);

nlohmann::json scene_to_json(const Structure& s);
void write_scene_file(const Structure& s, const std::string& path);

}  // namespace tensegrity
