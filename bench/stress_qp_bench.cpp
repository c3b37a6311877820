// The stress QP of the driver's check whether a scene already stands
// (standing_check_qp_options: the interior-point phase first, the give-up far
// from an equilibrium, the stall end) solved with K and through the node space
// (StressQpOptions::node_space), side by side: its set-up (the StressQp
// constructor) and its solve at the scene's own geometry.
//
//   build/bench/stress_qp_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
//
// Scenes: the gravity tower family (1 % node noise on alternating-gn's
// equilibrium, where the check gives up), `generate tower` as written without
// gravity (near-mechanisms that do not stand: the QP stalls) and those towers'
// equilibria (alternating-gn's, which stand: the QP settles).
//
// Counters: factorizations, iterations (projected-Newton steps), the relative
// residual of the forces (model/verify) and gave_up (1/0), which are the
// same with K and through the node space where the two agree.
#include <benchmark/benchmark.h>

#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "formulations/equilibrium.hpp"
#include "formulations/force_scale.hpp"
#include "gravity_tower_family.hpp"
#include "kernels/stress_qp.hpp"
#include "model/verify.hpp"
#include "scenes/towers.hpp"
#include "solvers/solver.hpp"
#include "solvers/standing_check.hpp"

namespace tensegrity {
namespace {

constexpr double kEquilibriumTimeLimit = 120.0;  // s, alternating-gn's set-up solves

// Built on first use, so that a filtered run sets up only its scenes.
struct Scene {
  std::string name;
  std::function<Structure()> make;
  std::shared_ptr<const Structure> built;
  const Structure& get() {
    if (!built) built = std::make_shared<const Structure>(make());
    return *built;
  }
};

Structure as_generated(int layers) {
  scenes::TowerParameters p;
  p.layers = layers;
  p.cables = 50 * layers;
  p.noise = 0.0;  // as `generate tower` writes it
  return scenes::make_prism_tower(p);
}

Structure equilibrium_of(const Structure& s) {
  SolveOptions o;
  o.time_limit_s = kEquilibriumTimeLimit;
  const SolveResult r = make_solver("alternating-gn")->Solve(s, o, DriverControls{false});
  Structure out = s;
  out.positions = r.positions;
  return out;
}

std::vector<Scene> make_scenes() {
  std::vector<Scene> out;
  for (int layers : {10, 40, 160})
    out.push_back({"tower-" + std::to_string(layers) + "-gravity-noise1",
                   [layers] { return bench::gravity_tower(layers, kEquilibriumTimeLimit); }, nullptr});
  for (int layers : {10, 40, 160})
    out.push_back({"tower-" + std::to_string(layers) + "-as-generated", [layers] { return as_generated(layers); }, nullptr});
  for (int layers : {10, 40})
    out.push_back({"tower-" + std::to_string(layers) + "-equilibrium",
                   [layers] { return equilibrium_of(as_generated(layers)); }, nullptr});
  return out;
}

void run(benchmark::State& state, const Structure& s, bool node_space) {
  const Equilibrium eq(s);
  const ForceScale scale = make_force_scale(s);
  StressQpOptions options = standing_check_qp_options();
  options.node_space = node_space;
  StressQpResult r;
  for (auto _ : state) {
    StressQp qp(eq, scale, options);
    r = qp.solve();
    benchmark::DoNotOptimize(r.sigma.data());
  }
  state.counters["factorizations"] = r.factorizations;
  state.counters["iterations"] = r.iterations;
  state.counters["relative_residual"] = verify(s, s.positions, r.sigma).relative_residual;
  state.counters["gave_up"] = r.gave_up ? 1.0 : 0.0;
}

}  // namespace
}  // namespace tensegrity

int main(int argc, char** argv) {
  using namespace tensegrity;
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  static std::vector<Scene> scenes = make_scenes();
  for (Scene& scene : scenes)
    for (const auto& [label, node_space] : {std::pair{"k", false}, std::pair{"node-space", true}})
      benchmark::RegisterBenchmark(("check-qp/" + scene.name + "/" + label).c_str(),
                                   [&scene, node_space = node_space](benchmark::State& state) {
                                     run(state, scene.get(), node_space);
                                   })
          ->Unit(benchmark::kMillisecond);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
