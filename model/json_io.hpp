#pragma once
// Checked reading of JSON values for scene and solution files. Every failure is
// an InputError naming `source` (the file), `item` (e.g. "elements[3].nodes[1]")
// and the reason.
#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>

namespace tensegrity {

// Parses JSON text; malformed JSON (or a number that overflows a double) is an
// InputError whose item is "line L, column C" (1-based), duplicate keys one
// whose item is the key's path.
nlohmann::json parse_json_text(const std::string& text, const std::string& source);

// Parses a JSON file (read_text_file, then parse_json_text).
nlohmann::json read_json_file(const std::string& path);

// 1-based line and column of the character nlohmann's parser stopped at, from
// its byte count (characters read, so the offending one is text[byte - 1]).
std::pair<std::size_t, std::size_t> line_and_column(const std::string& text, std::size_t byte);

// An object whose "format" is `format` and whose "version" is 1.
void json_expect_header(const nlohmann::json& j, const std::string& format, const std::string& source);

// A value's type and its first characters, for messages ("string \"abc\"").
std::string json_describe(const nlohmann::json& v);
// object[key]; InputError "missing required field" (item: item_prefix, or key when empty) when absent.
const nlohmann::json& json_require_key(const nlohmann::json& object, const char* key, const std::string& source,
                                       const std::string& item_prefix);

double json_finite_number(const nlohmann::json& v, const std::string& source, const std::string& item);
double json_mass(const nlohmann::json& v, const std::string& source, const std::string& item);
Eigen::Vector3d json_vector3(const nlohmann::json& v, const std::string& source, const std::string& item);
std::string json_string(const nlohmann::json& v, const std::string& source, const std::string& item);
// An integer in [0, count); `what` names the thing indexed ("node").
int json_index(const nlohmann::json& v, int count, const std::string& what, const std::string& source,
               const std::string& item);

}  // namespace tensegrity
