#pragma once
// The building-block library (paper, section 4): template tensegrities that
// characters are assembled from. Each block is stored as
// data/blocks/<name>.block.json (format "tensegrity-block", version 1; the
// format is documented in docs/FORMATS.md) and carries
//   - its template geometry (m, unit scale: instancing scales it),
//   - a self-stress `forces` (N, mean cable force 1) that puts the template in
//     equilibrium: sum_e sigma_e (x_j - x_i)/|x_j - x_i| = 0 at every node,
//   - named triangular faces (three node indices) where face links attach,
//   - named cables (element indices) that edge links may remove.
// A similarity transform (uniform scale, rotation, translation) keeps the same
// forces in equilibrium; per-node displacements do not (form finding repairs
// them).
#include <Eigen/Core>
#include <array>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "model/structure.hpp"

namespace tensegrity {

struct Block {
  std::string name;
  std::string source;                 // where the template comes from, in words
  Structure structure;                // template: no masses, no gravity, no fixed nodes
  Eigen::VectorXd forces;             // self-stress at the template (N), cables > 0 > struts
  std::map<std::string, std::array<int, 3>> faces;  // face name -> three node indices
  std::map<std::string, int> cables;  // cable name -> element index
  // Optional interior tie cables (node pairs), in the order an instance takes
  // them: a character block with "ties": k adds the first k. Every prefix keeps
  // a self-stress with cables > 0 > struts (checked when the list is made).
  std::vector<std::array<int, 2>> ties;

  int num_struts() const;
  int num_cables() const;
  const std::array<int, 3>& face(const std::string& face_name, const std::string& where) const;
  int cable(const std::string& cable_name, const std::string& where) const;
};

// Generators of the standard templates (the data files are written from these).
// Regular n-strut prism (3 <= n <= 12), unit radius and height, faces "bottom"
// and "top" (for n > 3 three ring nodes spread around the ring).
Block make_prism_block(int n);
// The 4-strut prism under its usual name.
Block make_quadruplex_block();
// The expandable octahedron ("icosahedron"): half strut length 1, eight
// all-cable faces named by octant, e.g. "x+y+z-".
Block make_icosahedron_block();
// A single-stage diamond-pattern cylinder (Pugh): n struts, every strut the
// long diagonal of a rhombus of two cable triangles; 2n side cable triangles.
Block make_diamond_block(int n = 4, double diagonal_ratio = 0.5);
// Two expandable octahedra sharing one all-cable face, the second the mirror
// image of the first in that face's plane (a superposition of two self-stresses).
Block make_double_icosahedron_block();
// Braced templates. The paper's characters carry more cables than the minimal
// templates give (docs/CHARACTERS.md counts them); these add the bracing
// cables physical builds use, each at a geometry where the extra cables carry
// tension:
//   icosahedron-braced          the 6 short cables between the ends of parallel
//                               struts (all 20 icosahedron faces become cable
//                               triangles): 30 cables. They carry tension only
//                               for a pair offset h < a/2 (symmetric balance at
//                               a strut end: q_pair = q_cable (a - 2h) / h), so
//                               the pairs sit pair_offset apart (a = 1).
//   prism-<n>-braced            the diamond-pattern cylinder (a side diagonal on
//                               every side face): 4n cables.
//   double-icosahedron-braced   two braced icosahedra sharing a face: 57 cables.
// Each also lists interior ties (see Block::ties): node pairs by increasing
// length whose segment clears every element not sharing a node by
// tie_clearance times the strut length and that keep a signed self-stress.
Block make_braced_icosahedron_block(double pair_offset = 0.4);
Block make_braced_prism_block(int n);
Block make_braced_double_icosahedron_block(double pair_offset = 0.4);
// Appends up to max_ties interior ties to b.ties (rule above).
void add_interior_ties(Block& b, int max_ties, double tie_clearance = 0.1);
// A self-stress of `s` with cables >= 1 and struts <= -1 (N), by alternating
// projections between the null space of the equilibrium matrix and that box;
// false when none is found (e.g. the cables cannot all be tensioned there).
bool find_signed_self_stress(const Structure& s, Eigen::VectorXd* forces);
// The structure with the first `count` ties of b added as cables "tie-<k>".
Structure with_ties(const Block& b, int count);
// Closest distance between segments p0-p1 and q0-q1.
double segment_distance(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1, const Eigen::Vector3d& q0,
                        const Eigen::Vector3d& q1);

// All of the above that data/blocks/ holds.
std::vector<Block> make_standard_blocks();

nlohmann::json block_to_json(const Block& b);
// Validates: format/version, structure rules, faces and cables in range and of
// the right kind, forces with the right signs. InputError names source and item.
Block block_from_json(const nlohmann::json& j, const std::string& source);
Block read_block_file(const std::string& path);
void write_block_file(const Block& b, const std::string& path);

class BlockLibrary {
 public:
  BlockLibrary() = default;
  // Loads every *.block.json of a directory (InputError if none or one is bad).
  static BlockLibrary load(const std::string& directory);
  // The standard blocks generated in memory (no files).
  static BlockLibrary standard();

  void add(Block b);
  bool contains(const std::string& name) const { return blocks_.count(name) > 0; }
  // InputError(source, item, "unknown block type ...") when absent.
  const Block& get(const std::string& name, const std::string& source,
                   const std::string& item) const;
  std::vector<std::string> names() const;

 private:
  std::map<std::string, Block> blocks_;
};

// Instancing: x = translation + scale * rotation * (x_template + displacement).
// Displacements are in template coordinates (unit scale).
struct BlockTransform {
  double scale = 1.0;
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  std::map<int, Eigen::Vector3d> displacements;
};

Eigen::Matrix3Xd instance_positions(const Block& b, const BlockTransform& t);

// Max over nodes of |sum of forces| divided by max |force|: the relative
// equilibrium residual of the stored self-stress at given positions.
double relative_self_stress_residual(const Structure& s, const Eigen::Matrix3Xd& positions,
                                     const Eigen::VectorXd& forces);

}  // namespace tensegrity
