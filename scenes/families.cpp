#include "scenes/families.hpp"

#include <Eigen/Core>
#include <algorithm>
#include <filesystem>
#include <random>

#include "model/character.hpp"
#include "model/errors.hpp"
#include "model/scene_io.hpp"
#include "scenes/perturb.hpp"
#include "model/reference_scenes.hpp"
#include "scenes/towers.hpp"

namespace tensegrity::scenes {
namespace {

namespace fs = std::filesystem;

// ---------------------------------------------------------------- base scenes

void add_reference_scenes(std::vector<BaseScene>& out) {
  // The same parameters as `tensegrity generate reference` (data/reference/).
  auto add = [&out](Structure s, const std::string& name) {
    s.name = name;
    out.push_back({name, "reference", std::move(s)});
  };
  for (int n = 3; n <= 12; ++n) {
    PrismParameters p;
    p.n = n;
    add(make_regular_prism(p), "prism-" + std::to_string(n));
    p.gravity = p.fix_bottom = true;
    p.strut_mass = 0.05;
    p.cable_mass = 0.005;
    add(make_regular_prism(p), "prism-" + std::to_string(n) + "-gravity");
  }
  OctahedronParameters o;
  add(make_expandable_octahedron(o), "octahedron");
  o.gravity = o.fix_bottom = true;
  o.strut_mass = 0.05;
  o.cable_mass = 0.005;
  add(make_expandable_octahedron(o), "octahedron-gravity");
}

// Runs `load` (which reads `file`); a bad file throws, or with `skipped`
// given is recorded there and left out.
template <typename Load>
void load_or_skip(const fs::path& file, std::vector<SkippedFile>* skipped, Load&& load) {
  if (skipped == nullptr) return load();
  try {
    load();
  } catch (const InputError& e) {
    skipped->push_back({file.string(), e.what()});
  }
}

// The stored equilibria of the 80-strut / 500-cable tower (bench/large_scenes.hpp),
// when the data folder has them.
void add_towers(std::vector<BaseScene>& out, const std::string& data_dir, std::vector<SkippedFile>* skipped) {
  for (bool gravity : {false, true}) {
    const fs::path file =
        fs::path(data_dir) / "bench" / (std::string("tower-80s-500c") + (gravity ? "-gravity" : "") + ".scene.json");
    std::error_code ec;
    if (data_dir.empty() || !fs::is_regular_file(file, ec)) continue;
    load_or_skip(file, skipped, [&] {
      Structure s = tower_equilibrium(data_dir, gravity);
      s.name = std::string("tower-80s-500c") + (gravity ? "-gravity" : "");
      out.push_back({s.name, "tower", std::move(s)});
    });
  }
}

void add_characters(std::vector<BaseScene>& out, const std::string& data_dir, std::vector<SkippedFile>* skipped) {
  const fs::path dir = fs::path(data_dir) / "characters";
  std::error_code ec;
  if (data_dir.empty() || !fs::is_directory(dir, ec)) return;
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(dir, ec))
    if (entry.path().string().ends_with(".character.json")) files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  for (const fs::path& file : files) {
    load_or_skip(file, skipped, [&] {
      BuiltCharacter c = build_character_file(file.string());
      std::string name = file.filename().string();
      name.erase(name.size() - std::string(".character.json").size());
      c.structure.name = name;
      out.push_back({name, "character", std::move(c.structure)});
    });
  }
}

const std::vector<std::string>& known_family_names() {
  static const std::vector<std::string> names = {"noise", "twist", "scale", "length-ratio", "near-coincident",
                                                 "near-parallel", "mass", "gravity-direction"};
  return names;
}

std::string number_label(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%g", v);
  return buffer;
}

std::vector<FamilyLevel> levels_of(std::initializer_list<double> values, const std::string& unit = "") {
  std::vector<FamilyLevel> levels;
  for (double v : values) levels.push_back({v, number_label(v) + unit});
  return levels;
}

// Free nodes moved uniformly in a ball of `radius` (m).
void add_noise(Structure& s, double radius, std::mt19937_64& rng) {
  NodeNoise noise;
  noise.fraction = radius;
  noise.length = LengthMeasure::OneMetre;
  noise.shape = NoiseShape::UniformBall;
  add_node_noise(s, noise, rng);
}

}  // namespace

std::vector<BaseScene> base_scenes(const std::string& data_dir, std::vector<SkippedFile>* skipped) {
  std::vector<BaseScene> out;
  add_reference_scenes(out);
  add_towers(out, data_dir, skipped);
  add_characters(out, data_dir, skipped);
  return out;
}


std::vector<FamilyLevel> family_levels(const std::string& family) {
  if (family == "noise") return levels_of({0.001, 0.003, 0.01, 0.03, 0.1, 0.3});
  if (family == "twist") return levels_of({1, 5, 15, 30}, "deg");
  if (family == "scale") return levels_of({1e-4, 1e-2, 1e2, 1e4});
  if (family == "length-ratio") return levels_of({10, 100, 1e3, 1e4});
  if (family == "near-coincident") return levels_of({1e-2, 1e-4, 1e-6, 1e-9});
  if (family == "near-parallel") return levels_of({1e-2, 1e-4, 1e-6}, "rad");
  if (family == "mass") return levels_of({0, 1e-6, 1e-2, 1, 1e2, 1e4, 1e6}, "kg");
  if (family == "gravity-direction") {
    std::vector<FamilyLevel> levels;
    for (const char* label : {"+x", "-x", "+y", "-y", "+z", "-z", "random"})
      levels.push_back({static_cast<double>(levels.size()), label});
    return levels;
  }
  std::string known;
  for (const auto& f : known_family_names()) known += (known.empty() ? "" : ", ") + f;
  throw UnknownNameError("family", family, "unknown stress-test family (known: " + known + ")");
}

Structure make_family_case(const Structure& base, const std::string& family, int level_index, int trial,
                           std::uint64_t seed) {
  const std::vector<FamilyLevel> levels = family_levels(family);
  const double level = levels.at(level_index).value;
  std::seed_seq seq{static_cast<std::uint32_t>(seed), static_cast<std::uint32_t>(seed >> 32),
                    static_cast<std::uint32_t>(stable_hash(base.name)),
                    static_cast<std::uint32_t>(stable_hash(family)), static_cast<std::uint32_t>(level_index),
                    static_cast<std::uint32_t>(trial)};
  std::mt19937_64 rng(seq);
  Structure s = base;
  const double length = measure_length(base, LengthMeasure::MedianElement);
  constexpr double kSmallNoise = 0.01;
  if (family == "noise") {
    add_noise(s, level * length, rng);
  } else if (family == "twist") {
    twist_upper_half(s, level);
  } else if (family == "scale") {
    s.positions *= level;
    add_noise(s, kSmallNoise * level * length, rng);
  } else if (family == "length-ratio") {
    s.positions.row(2) *= level;
    add_noise(s, kSmallNoise * length, rng);
  } else if (family == "near-coincident") {
    add_noise(s, kSmallNoise * length, rng);
    make_near_coincident(s, level * length, rng);
  } else if (family == "near-parallel") {
    add_noise(s, kSmallNoise * length, rng);
    make_near_parallel(s, level, rng);
  } else if (family == "mass") {
    s.gravity = Eigen::Vector3d(0.0, 0.0, -9.81);
    ensure_supports(s, s.gravity);
    for (int i = 0; i < s.num_nodes(); ++i) s.node_mass[i] = s.fixed[i] ? 0.0 : level;
    if (level == 0.0)
      for (Element& e : s.elements) e.mass = 0.0;
    add_noise(s, kSmallNoise * length, rng);
  } else if (family == "gravity-direction") {
    Eigen::Vector3d down = Eigen::Vector3d::Zero();
    if (level_index < 6)
      down[level_index / 2] = level_index % 2 == 0 ? 1.0 : -1.0;
    else
      down = random_direction(rng);
    s.gravity = 9.81 * down;
    if (s.lumped_mass().sum() <= 0.0) s.node_mass.setConstant(0.01);
    ensure_supports(s, down);
    add_noise(s, kSmallNoise * length, rng);
  }
  s.name = base.name + "/" + family + "/" + levels[level_index].label + "/" + std::to_string(trial);
  return s;
}


std::vector<std::string> family_names() { return known_family_names(); }

void StableDigest::bytes(const void* p, std::size_t n) {
  constexpr std::uint64_t kPrime = 1099511628211ull;  // the 64-bit FNV prime
  const auto* c = static_cast<const unsigned char*>(p);
  for (std::size_t i = 0; i < n; ++i) {
    h ^= c[i];
    h *= kPrime;
  }
}

std::uint64_t stable_hash(std::string_view text) {
  StableDigest d;
  d.bytes(text.data(), text.size());
  return d.h;
}

}  // namespace tensegrity::scenes
