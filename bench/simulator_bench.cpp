// One implicit-Euler step (solvers/simulator.hpp) for the scorpion character
// (83 struts, 523 cables in the paper), and one static relax.
//
//   tensegrity design data/characters/scorpion.character.json --material elastic-cord-2mm --out /tmp/scorpion.design.json
//   TENSEGRITY_SCORPION_DESIGN=/tmp/scorpion.design.json build/bench/simulator_bench --benchmark_repetitions=10 --benchmark_report_aggregates_only=true
//
// Without the environment variable the scorpion is form-found here and its
// cables made linear cords at 30 % strain under the solved forces (the design
// pipeline lives in the CLI). Cases: "rest" (under the design gravity, the
// state it was designed for), "turned" (gravity along +x: the character
// sags and swings, the Newton solver works every step), "drag" (a tail node
// pulled by a drag spring). Counters: Newton iterations per step, dofs.
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <iostream>
#include <memory>

#include "model/character.hpp"
#include "model/design.hpp"
#include "simulation/simulator.hpp"
#include "solvers/solver.hpp"

namespace tensegrity {
namespace {

const ElasticModel& scorpion_model() {
  static const std::unique_ptr<ElasticModel> model = [] {
    if (const char* path = std::getenv("TENSEGRITY_SCORPION_DESIGN")) {
      std::cerr << "simulator_bench: design " << path << "\n";
      return std::make_unique<ElasticModel>(make_elastic_model(read_design_file(path)));
    }
    std::cerr << "simulator_bench: form-finding the scorpion (linear cords)...\n";
    const Structure s =
        build_character_file(std::string(TENSEGRITY_SOURCE_DIR) + "/data/characters/scorpion.character.json").structure;
    const auto solver = make_solver(default_solver_name());
    const SolveResult r = solve_scene(*solver, s, SolveOptions{});
    std::cerr << "simulator_bench: form finding " << to_string(r.status) << "\n";
    return std::make_unique<ElasticModel>(make_linear_elastic_model(s, r.positions, r.forces, 0.3));
  }();
  return *model;
}

void run_steps(benchmark::State& state, const Eigen::Vector3d& gravity, bool drag) {
  const ElasticModel& model = scorpion_model();
  SimulationOptions o;
  o.time_step = 1.0 / 60.0;
  o.mass_damping = 1.0;
  Simulator sim(model, gravity, o);
  if (drag) {
    int node = 0;  // the highest free node
    for (int i = 0; i < model.reference.cols(); ++i)
      if (!model.structure.fixed[i] && model.reference(2, i) > model.reference(2, node)) node = i;
    sim.set_drags({{node, model.reference.col(node) + Eigen::Vector3d(0, 0, 0.1 * model.length_scale),
                    model.force_scale / (0.05 * model.length_scale)}});
  }
  long newton = 0, steps = 0;
  for (auto _ : state) {
    const StepReport r = sim.step();
    newton += r.newton_iterations;
    ++steps;
    benchmark::DoNotOptimize(r.gradient_norm);
  }
  state.counters["newton_per_step"] = steps ? double(newton) / steps : 0.0;
  state.counters["dofs"] = sim.energy().num_dofs();
  state.counters["elements"] = model.structure.num_elements();
}

void BM_ScorpionStepAtRest(benchmark::State& state) { run_steps(state, scorpion_model().structure.gravity, false); }
void BM_ScorpionStepTurned(benchmark::State& state) { run_steps(state, Eigen::Vector3d(9.81, 0, 0), false); }
void BM_ScorpionStepDrag(benchmark::State& state) { run_steps(state, scorpion_model().structure.gravity, true); }

void BM_ScorpionRelaxTurned(benchmark::State& state) {
  const ElasticModel& model = scorpion_model();
  const ElasticEnergy energy(model, Eigen::Vector3d(9.81, 0, 0));
  int iterations = 0;
  for (auto _ : state) {
    const RelaxResult r = relax(energy, model.reference);
    iterations = r.iterations;
    benchmark::DoNotOptimize(r.max_displacement);
  }
  state.counters["iterations"] = iterations;
}

BENCHMARK(BM_ScorpionStepAtRest)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ScorpionStepTurned)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ScorpionStepDrag)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ScorpionRelaxTurned)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace tensegrity

BENCHMARK_MAIN();
