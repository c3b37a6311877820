#pragma once
// Scene files (docs/FORMATS.md, format "tensegrity-scene", version 1).
#include <iosfwd>
#include <nlohmann/json.hpp>
#include <string>

#include "model/structure.hpp"

namespace tensegrity {

// The whole content of a file, for every reader of the model: InputError when it
// cannot be opened, is a directory, or holds more than 256 MiB (an endless
// device stops there); a FIFO without a writer reads as empty instead of hanging.
std::string read_text_file(const std::string& path);

// Parses a JSON file; malformed JSON becomes InputError with line and column.
nlohmann::json read_json_file(const std::string& path);

// Builds and validates a structure from a parsed scene; `source` names the file
// in error messages.
Structure scene_from_json(const nlohmann::json& j, const std::string& source);
Structure read_scene_file(const std::string& path);

nlohmann::json scene_to_json(const Structure& s);
void write_scene_file(const Structure& s, const std::string& path);

// Writes text to `path` through a temporary file and a rename ("-" = stdout).
void write_text_file_atomically(const std::string& path, const std::string& text);

}  // namespace tensegrity
