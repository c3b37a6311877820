#pragma once
// Seeded families of perturbed scenes for robustness runs (`tensegrity
// stress-test`, the Python sweeps): every benchmark scene and character,
// perturbed family by family and level by level.
//
// Families (levels in brackets; L = median element length of the base scene):
//   noise          free nodes moved uniformly in a ball of radius level * L
//                  [0.001 0.003 0.01 0.03 0.1 0.3]
//   twist          nodes above the median height turned about the vertical
//                  axis through their centroid by level degrees [1 5 15 30]
//   scale          the whole scene scaled by level, then 1 % noise
//                  [1e-4 1e-2 1e2 1e4]
//   length-ratio   heights (z) multiplied by level, so element lengths differ
//                  by up to that ratio, then 1 % noise [10 100 1e3 1e4]
//   near-coincident  1 % noise, then one free node put at distance level * L
//                  from another node [1e-2 1e-4 1e-6 1e-9]
//   near-parallel  1 % noise, then one element turned about its shared node
//                  until it makes an angle of level radians with a neighbour
//                  [1e-2 1e-4 1e-6]
//   mass           gravity -z, every free node of mass level kg (element
//                  masses kept, all masses removed at level 0), the 3 lowest
//                  nodes fixed when none is, 1 % noise [0 1e-6 1e-2 1 1e2 1e4 1e6]
//   gravity-direction  |g| = 9.81 along +-x, +-y, +-z or a random direction;
//                  existing masses (else 0.01 kg per node), the 3 lowest nodes
//                  along g fixed when none is, 1 % noise
// Every trial's perturbation comes from its own generator seeded by (seed,
// scene, family, level, trial), so results do not depend on the thread count
// or the order in which trials run.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "model/structure.hpp"

namespace tensegrity::scenes {

struct BaseScene {
  std::string name;
  std::string group;  // "reference", "tower" or "character"
  Structure scene;
};

// A data file left out of base_scenes, and the InputError's one line saying why.
struct SkippedFile {
  std::string file;
  std::string reason;
};

// Every benchmark scene (the reference prisms and octahedra, plain and with
// gravity; the 80-strut tower's stored equilibria `data_dir`/bench/tower-80s-500c*.scene.json,
// plain and with gravity) and every character of `data_dir`/characters.
// A bad tower or character file throws InputError, or, when `skipped` is
// given, is recorded there and left out.
std::vector<BaseScene> base_scenes(const std::string& data_dir, std::vector<SkippedFile>* skipped = nullptr);

std::vector<std::string> family_names();

struct FamilyLevel {
  double value = 0.0;
  std::string label;
};
// The levels of a family (InputError for an unknown family).
std::vector<FamilyLevel> family_levels(const std::string& family);

// The perturbed scene of one trial; deterministic in its arguments.
Structure make_family_case(const Structure& base, const std::string& family, int level_index, int trial,
                           std::uint64_t seed);

// FNV-1a over raw bytes: a digest that is the same on every platform.
struct StableDigest {
  std::uint64_t h = 1469598103934665603ull;  // the FNV offset basis
  void bytes(const void* p, std::size_t n);
  void number(double v) { bytes(&v, sizeof v); }
  void integer(std::uint64_t v) { bytes(&v, sizeof v); }
};

// StableDigest of the bytes of `text`.
std::uint64_t stable_hash(std::string_view text);

}  // namespace tensegrity::scenes
