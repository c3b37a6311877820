// The ipopt backend called from two threads at once (as a library user, the
// Python module or the local server may do): MUMPS, Ipopt's linear solver here, is
// not thread-safe, so without the backend's lock this aborts or corrupts
// results. Each concurrent result must equal, bit for bit, the serial one.
#include <gtest/gtest.h>

#include <cmath>
#include <thread>
#include <vector>

#include "model/reference_scenes.hpp"
#include "scenes/perturb.hpp"
#include "solvers/ipopt/ipopt_solver.hpp"

namespace tensegrity {
namespace {

Structure perturbed_prism(int n, unsigned seed) {
  PrismParameters p;
  p.n = n;
  p.gravity = p.fix_bottom = (seed % 2) == 0;
  p.strut_mass = p.gravity ? 0.05 : 0.0;
  scenes::NodeNoise noise;  // up to 5 cm per coordinate on the free nodes
  noise.fraction = 0.05;
  noise.length = scenes::LengthMeasure::OneMetre;
  noise.shape = scenes::NoiseShape::Cube;
  return scenes::with_node_noise(make_regular_prism(p), noise, seed);
}

TEST(IpoptThreadSafety, ConcurrentSolvesEqualSerialOnes) {
  std::vector<Structure> scenes;
  for (unsigned k = 0; k < 12; ++k) scenes.push_back(perturbed_prism(3 + k % 6, 100 + k));
  const IpoptSolver solver;
  SolveOptions options;
  std::vector<SolveResult> serial, parallel(scenes.size());
  for (const Structure& s : scenes) serial.push_back(solver.Solve(s, options, DriverControls{false}));
  std::vector<std::thread> threads;
  for (int t = 0; t < 2; ++t)
    threads.emplace_back([&, t] {
      for (std::size_t k = t; k < scenes.size(); k += 2) parallel[k] = solver.Solve(scenes[k], options, DriverControls{false});
    });
  for (auto& th : threads) th.join();
  int converged = 0;
  for (std::size_t k = 0; k < scenes.size(); ++k) {
    SCOPED_TRACE(k);
    EXPECT_EQ(parallel[k].status, serial[k].status);
    converged += serial[k].status == Status::Converged;
    ASSERT_EQ(parallel[k].positions.cols(), serial[k].positions.cols());
    EXPECT_TRUE((parallel[k].positions.array() == serial[k].positions.array()).all());
    EXPECT_TRUE((parallel[k].forces.array() == serial[k].forces.array()).all());
  }
  EXPECT_EQ(converged, static_cast<int>(scenes.size()));
}

}  // namespace
}  // namespace tensegrity
