#include "scenes/gravity_tower_family.hpp"

#include "scenes/towers.hpp"

namespace tensegrity::scenes {

std::string gravity_tower_name(int layers) { return "tower-" + std::to_string(layers) + "-gravity-noise1"; }

Structure gravity_tower(int layers, const EquilibriumSolve& equilibrium) {
  TowerParameters p;
  p.layers = layers;
  p.struts_per_layer = kGravityTowerStrutsPerLayer;
  p.cables = kGravityTowerCablesPerLayer * layers;
  p.noise = 0.0;
  p.gravity = true;
  Structure s = make_prism_tower(p);
  s.positions = equilibrium(s);
  s = with_tower_noise(s, kGravityTowerNoise, kGravityTowerSeed);
  s.name = gravity_tower_name(layers);
  return s;
}

}  // namespace tensegrity::scenes
