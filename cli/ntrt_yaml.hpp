#pragma once
// NASA Tensegrity Robotics Toolkit (NTRT) YAML structures, both ways.
//
// The format: `nodes` (name: [x, y, z]), `pair_groups` (space-separated tags:
// list of [node, node]), `builders` (tag: {class, parameters}: a class with
// "Rod" in its name builds struts, any other class cables; the default tags
// `rod` and `string` need no builder), `substructures` (names joined by '/':
// {path, rotation {axis, angle in degrees, reference}, scale, translation,
// offset}) and `bond_groups` (tag: {"a/b/.../node_node": list of [node of a,
// node of b]}, joining neighbours of the series; child nodes by dot paths).
// NTRT's y axis is vertical, ours z: a file point (x, y, z) is our
// (x, -z, y), times `length_scale` (metres per file unit). Node names become
// node "name" extras ("child.node" for nodes of substructures). node_edge bonds
// attach to the middle of a string, which a scene cannot express: rejected.
#include <optional>
#include <string>

#include <Eigen/Core>

#include "model/design.hpp"
#include "model/structure.hpp"

namespace tensegrity::cli {

// Reads a structure file and its substructures; InputError names the file and
// item on bad input. No node is fixed and there is no gravity (NTRT puts
// structures on a ground of its own): callers choose supports.
Structure read_ntrt_yaml(const std::string& path, double length_scale = 1.0);

// What the writer knows about the elements beyond the scene.
struct NtrtExtras {
  std::optional<Eigen::VectorXd> forces;        // N: pretension of the cables
  std::optional<Eigen::VectorXd> rest_lengths;  // m, with stiffness: per-cable builders
  std::optional<Eigen::VectorXd> stiffness;     // N/m per cable
};

// A structure file at `positions`; tags: `rod` / `string` plus the block or
// link id of the element, per-cable builders (`cable_E`) when stiffness is known.
std::string write_ntrt_yaml(const Structure& scene, const Eigen::Matrix3Xd& positions, const NtrtExtras& extras,
                            double length_scale = 1.0);

}  // namespace tensegrity::cli
