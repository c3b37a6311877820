#pragma once
// The gravity tower family (scenes/gravity_tower_family.hpp) as the benchmarks
// build it: the equilibrium of the unperturbed tower found by alternating-gn.
#include <stdexcept>
#include <string>

#include "model/structure.hpp"
#include "scenes/gravity_tower_family.hpp"
#include "solvers/solver.hpp"

namespace tensegrity::bench {

// The L-layer member of the family; throws std::runtime_error when
// alternating-gn finds no equilibrium of the unperturbed tower within
// `equilibrium_time_limit_s` seconds.
inline Structure gravity_tower(int layers, double equilibrium_time_limit_s) {
  return scenes::gravity_tower(layers, [&](const Structure& unperturbed) {
    SolveOptions options;
    options.time_limit_s = equilibrium_time_limit_s;
    const SolveResult eq = make_solver("alternating-gn")->Solve(unperturbed, options);
    if (eq.status != Status::Converged)
      throw std::runtime_error("gravity tower " + std::to_string(layers) + ": no equilibrium (" + eq.message + ")");
    return eq.positions;
  });
}

}  // namespace tensegrity::bench
