#pragma once
// Human-friendly JSON text for scene and solution files: known keys first in a
// fixed order (format, version, name, ...), short arrays and objects on one
// line, and numbers in nlohmann's shortest form that round-trips exactly.
#include <nlohmann/json.hpp>
#include <string>

namespace tensegrity {

std::string to_json_text(const nlohmann::json& j);

// A number in at most 6 significant digits, for messages.
std::string message_number(double v);

}  // namespace tensegrity
