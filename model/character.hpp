#pragma once
// Characters: block instances joined by links, standing on fixed ground nodes
// under gravity (paper, section 4). File format "tensegrity-character",
// version 1 (docs/FORMATS.md documents every field):
//
//   {"format": "tensegrity-character", "version": 1, "name": "duck",
//    "block_library": "../blocks",            // optional, relative to the file
//    "gravity": [0, 0, -9.81],                // optional (m/s^2)
//    "strut_density": 0.03, "cable_density": 0.002,   // kg/m: element mass = density * length
//    "blocks": [{"id": "body", "type": "double-icosahedron", "scale": 0.06,
//                "rotation_deg": [0, 0, 90], "translation": [0, 0, 0.2],
//                "displacements": [{"node": 3, "by": [0, 0, 0.1]}]}],
//    "links": [{"id": "neck", "type": "face",
//               "a": {"block": "body", "face": "a.x+y+z-"},    // or "facing": [x,y,z],
//               "b": {"block": "neck", "toward": "body"},      // or nothing: toward the other block
//               "depth": 0.6},
//              {"id": "hinge", "type": "edge", "a": {"block": "x", "cable": "top-0"},
//               "b": {"block": "y", "cable": "bottom-2"}}],
//    "ground": [{"block": "foot", "lowest": 3}, {"block": "body", "nodes": [0, 1]}]}
//
// Rotation: R = Rz(rz) Ry(ry) Rx(rx), degrees. Displacements are in template
// (unit-scale) coordinates. Block and link ids are kept on the scene's nodes
// and elements ("block" with "block_node"/"block_element", or "link").
#include <nlohmann/json.hpp>
#include <string>

#include "model/blocks.hpp"
#include "model/structure.hpp"

namespace tensegrity {

struct CharacterCounts {
  int blocks = 0, face_links = 0, edge_links = 0;
  int nodes = 0, struts = 0, cables = 0, fixed_nodes = 0;
  double mass = 0.0;  // kg
};

struct BuiltCharacter {
  Structure structure;  // validated
  CharacterCounts counts;
};

// Builds a character from parsed JSON; `source` names the file in errors and
// `library` provides the block types. Bad input: InputError(source, item, reason).
BuiltCharacter build_character(const nlohmann::json& j, const std::string& source, const BlockLibrary& library);

// Reads the file and its block library ("block_library" relative to the file,
// default ../blocks beside it; `library_override` wins when not empty).
BuiltCharacter build_character_file(const std::string& path, const std::string& library_override = "");

// The parametric family for scaling studies: N expandable octahedra in a row
// along x, each joined to the next by a face link, every block standing on its
// three lowest nodes, under gravity. 2 <= N <= 200.
nlohmann::json make_chain_character(int n);

CharacterCounts count_structure(const Structure& s);

}  // namespace tensegrity
