// The scene driver (Solver::Solve): a scene that already stands comes back
// unchanged from every backend, and the time spent checking that counts
// against the time limit, so a backend never starts with the whole budget
// after the check has used part of it.
#include <gtest/gtest.h>

#include <string>

#include "model/verify.hpp"
#include "scenes/suites.hpp"
#include "scenes/towers.hpp"
#include "solvers/solver.hpp"

namespace tensegrity {
namespace {

TEST(SceneDriver, AStandingSceneComesBackUnchangedFromEveryBackend) {
  const Structure standing = scenes::prism(6);
  for (const std::string& name : solver_names()) {
    SCOPED_TRACE(name);
    const SolveResult r = make_solver(name)->Solve(standing, SolveOptions{}, {});
    EXPECT_EQ(r.status, Status::Converged) << r.message;
    EXPECT_EQ(r.stats.geometry_change, 0.0);
    EXPECT_EQ((r.positions - standing.positions).cwiseAbs().maxCoeff(), 0.0);
  }
}

// The 80-strut tower moved off equilibrium: its stress QP takes far longer
// than the smallest time a part is given (a millisecond).
TEST(SceneDriver, TheStandingChecksTimeCountsAgainstTheLimit) {
  constexpr double kNoTimeAtAll = 1e-12;  // s
  const Structure moved = scenes::perturbed(scenes::make_prism_tower({}), 0.05, 17u);
  SolveOptions options;
  options.time_limit_s = kNoTimeAtAll;
  for (const std::string& name : solver_names()) {
    SCOPED_TRACE(name);
    const SolveResult r = make_solver(name)->Solve(moved, options, {});
    EXPECT_EQ(r.status, Status::TimeLimit) << r.message;
    EXPECT_NE(r.message.find("checking whether the scene already stands"), std::string::npos) << r.message;
    EXPECT_EQ((r.positions - moved.positions).cwiseAbs().maxCoeff(), 0.0);
  }
}

}  // namespace
}  // namespace tensegrity
