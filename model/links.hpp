#pragma once
// Links between building blocks (paper, section 4, Figs. 3 and 4).
//
// Face link: joins triangle A = (a0, a1, a2) of one block to triangle B of
// another with one new strut and 12 cables. The strut lies on the line through
// the two face centroids c_A, c_B and reaches beyond each face into its block:
// its ends are p_A = c_A - d_A u and p_B = c_B + d_B u (u = (c_B - c_A)/|c_B - c_A|,
// d = depth_fraction * the face's circumradius), so it passes through both
// faces. Each end is tied to its triangle's three corners (6 cables) and six
// cables join the corners of the two triangles in a zigzag (a_i - b_{i+k},
// a_i - b_{i+k+1}, k chosen for the shortest total length), so each corner has
// two of them.
//
// Edge link: an expandable octahedron ("icosahedron") is inserted between two
// cables, one on each block, with one strut of one parallel pair lying on cable
// A and its partner lying on cable B. A compressed strut and a tensioned cable
// on the same segment cancel, so both are removed ("merging", Fig. 4): the
// inserted block's strut ends become the cables' end nodes. That leaves 4 new
// struts and the octahedron's 24 cables, minus the two block cables. 14 tie
// cables (our choice where the paper leaves the detail open; the paper's count
// is 38 = 24 + 14) join the eight new nodes to the nearest block nodes:
// shortest pairs first, at most two ties per new node and per block node, seven
// per side. Net: +4 struts, +38 cables, -2 cables.
//
// Neither link is in equilibrium at the geometry it is built with; form
// finding (Eq. 5) moves the nodes to a valid tensegrity.
#include <array>
#include <vector>

#include "model/structure.hpp"

namespace tensegrity {

struct LinkAddition {
  std::vector<int> nodes;             // new node indices
  std::vector<int> elements;          // new element indices (after any removal)
  std::vector<int> merged_nodes;      // existing nodes the link attaches to by merging (edge link)
  int removed_elements = 0;           // cables removed (edge link: 2)
};

// Adds a face link to `s`. Throws std::invalid_argument for degenerate input
// (coincident centroids, a repeated node). depth_fraction > 0.
LinkAddition add_face_link(Structure& s, const std::array<int, 3>& face_a,
                           const std::array<int, 3>& face_b, double depth_fraction = 0.6);

// Adds an edge link between two cables of `s` (element indices). Element
// indices above the removed cables shift down; the returned indices are final.
LinkAddition add_edge_link(Structure& s, int cable_a, int cable_b);

// Point where segment p-q crosses triangle (a, b, c), if it does (Moller-Trumbore).
bool segment_crosses_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& q, const Eigen::Vector3d& a,
                              const Eigen::Vector3d& b, const Eigen::Vector3d& c);

}  // namespace tensegrity
