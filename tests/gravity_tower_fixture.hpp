#pragma once
// The gravity tower family (scenes/gravity_tower_family.hpp) as the tests
// build it: the unperturbed tower's equilibrium found by alternating-gn, then
// 1 % node noise, as the benchmarks do.
#include <stdexcept>

#include "model/structure.hpp"
#include "scenes/gravity_tower_family.hpp"
#include "solvers/solver.hpp"

namespace tensegrity::testing {

inline Structure gravity_tower_at_equilibrium(int layers) {
  return scenes::gravity_tower(layers, [](const Structure& unperturbed) {
    const SolveResult eq = make_solver("alternating-gn")->Solve(unperturbed, SolveOptions{});
    if (eq.status != Status::Converged) throw std::runtime_error("no equilibrium of the unperturbed tower");
    return eq.positions;
  });
}

}  // namespace tensegrity::testing
