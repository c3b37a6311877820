#pragma once
// The gravity tower scaling family shared by the benchmarks: L layers of
// 8-strut prisms with 50 L cables under gravity, exactly what
// `tensegrity generate tower --layers L --struts-per-layer 8 --cables 50L --gravity`
// writes (scenes::make_prism_tower without noise, 58 L elements), solved to an
// equilibrium by alternating-gn and then moved by 1 % node noise
// (scenes::with_tower_noise, seed 1), so that every size is a form-finding
// problem that starts near a known solution.
#include <stdexcept>
#include <string>

#include "model/structure.hpp"
#include "scenes/towers.hpp"
#include "solvers/solver.hpp"

namespace tensegrity::bench {

constexpr int kGravityTowerStrutsPerLayer = 8;
constexpr int kGravityTowerCablesPerLayer = 50;
constexpr double kGravityTowerNoise = 0.01;  // fraction of the first element's length
constexpr unsigned kGravityTowerSeed = 1u;

inline std::string gravity_tower_name(int layers) {
  return "tower-" + std::to_string(layers) + "-gravity-noise1";
}

// The L-layer member of the family; throws std::runtime_error when
// alternating-gn finds no equilibrium of the unperturbed tower within
// `equilibrium_time_limit_s` seconds.
inline Structure gravity_tower(int layers, double equilibrium_time_limit_s) {
  scenes::TowerParameters p;
  p.layers = layers;
  p.struts_per_layer = kGravityTowerStrutsPerLayer;
  p.cables = kGravityTowerCablesPerLayer * layers;
  p.noise = 0.0;
  p.gravity = true;
  Structure s = scenes::make_prism_tower(p);
  SolveOptions options;
  options.time_limit_s = equilibrium_time_limit_s;
  const SolveResult eq = make_solver("alternating-gn")->Solve(s, options);
  if (eq.status != Status::Converged)
    throw std::runtime_error("gravity tower " + std::to_string(layers) + ": no equilibrium (" + eq.message + ")");
  s.positions = eq.positions;
  s = scenes::with_tower_noise(s, kGravityTowerNoise, kGravityTowerSeed);
  s.name = gravity_tower_name(layers);
  return s;
}

}  // namespace tensegrity::bench
