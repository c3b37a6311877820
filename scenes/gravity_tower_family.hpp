#pragma once
// The gravity tower scaling family of the benchmarks: L layers of 8-strut
// prisms with 50 L cables under gravity, exactly what
// `tensegrity generate tower --layers L --struts-per-layer 8 --cables 50L --gravity`
// writes (make_prism_tower without noise, 58 L elements), brought to an
// equilibrium and then moved by 1 % node noise (with_tower_noise, seed 1), so
// that every size is a form-finding problem that starts near a known solution.
// The caller finds the equilibrium, since scenes/ builds on model/ alone.
#include <Eigen/Core>
#include <functional>
#include <string>

#include "model/structure.hpp"

namespace tensegrity::scenes {

constexpr int kGravityTowerStrutsPerLayer = 8;
constexpr int kGravityTowerCablesPerLayer = 50;
constexpr double kGravityTowerNoise = 0.01;  // fraction of the first element's length
constexpr unsigned kGravityTowerSeed = 1u;

// The node positions of an equilibrium of the given structure; throws when
// it finds none.
using EquilibriumSolve = std::function<Eigen::Matrix3Xd(const Structure&)>;

// "tower-L-gravity-noise1".
std::string gravity_tower_name(int layers);

// The L-layer member of the family: the unperturbed tower moved to the
// positions `equilibrium` returns for it, then perturbed. Exceptions of
// `equilibrium` pass through.
Structure gravity_tower(int layers, const EquilibriumSolve& equilibrium);

}  // namespace tensegrity::scenes
