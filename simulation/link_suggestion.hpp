#pragma once
// Which link to put between two blocks (paper, section 6: "automatically
// suggest the connection type that best fits a desired deformation behavior
// or range of motion").
//
// Candidates: face links between the faces_per_block faces of each block that
// face the other block most (outward normal . direction to the other block's
// centroid), and edge links between the cables_per_block cables of each block
// nearest the other block. Each candidate is built on its own (the two blocks
// as placed, no gravity, no ground), form-found with the given backend, its
// forces scaled to a mean cable force of 1 N, and measured with
// relative_rotation_stiffness (simulation/link_stiffness.hpp).
//
// Ranking:
//   stiff       by the smallest principal rotational stiffness, largest first;
//   hinge about w (unit): by the ratio k_w / k_perp, smallest first, with
//               k_w = w^T S_rot w and k_perp = the smaller rotational
//               stiffness within the plane normal to w (a good hinge turns
//               easily about w and resists every other rotation);
//   the torque k_w * range (N m) is reported for the desired range.
#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "model/blocks.hpp"
#include "simulation/link_stiffness.hpp"

namespace tensegrity {

struct LinkRequest {
  bool stiff = false;
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();  // world frame, for a hinge request
  double range_deg = 30.0;
};

struct LinkSuggestionOptions {
  int faces_per_block = 3;
  int cables_per_block = 3;
  std::string solver;  // empty: the default backend
  LinkStiffnessOptions stiffness;
};

struct LinkCandidate {
  std::string type;             // "face" or "edge"
  std::string a, b;             // face or cable names on block a and block b
  std::string status;           // the form-finding status ("converged", ...)
  bool measured = false;        // converged and stiffness computed
  LinkStiffness stiffness;
  double about_axis = 0.0;      // k_w (N m / rad)
  double perpendicular = 0.0;   // k_perp (N m / rad)
  double score = 0.0;           // ranking key (see top; smaller ranks first)
  double torque_for_range = 0.0;  // N m
  double geometry_change = 0.0;   // m
  nlohmann::json link;          // the link as a character file writes it
};

// The two blocks with ids block_a and block_b of `character` (parsed
// character JSON) are kept; InputError(source, ...) when either is absent.
std::vector<LinkCandidate> suggest_links(const nlohmann::json& character, const std::string& source,
                                         const BlockLibrary& library, const std::string& block_a,
                                         const std::string& block_b, const LinkRequest& request,
                                         const LinkSuggestionOptions& options = {});

// A two-block character JSON: the two block entries of `character` and `link`,
// no gravity, no ground.
nlohmann::json two_block_character(const nlohmann::json& character, const std::string& source,
                                   const std::string& block_a, const std::string& block_b,
                                   const nlohmann::json& link);

}  // namespace tensegrity
