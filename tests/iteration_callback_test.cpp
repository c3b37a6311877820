// DriverControls::on_iteration: every backend reports each iteration record,
// the same records that end up in SolveResult::trace, with the part it
// belongs to; SolveOptions::verbose gives one stderr line per record for the
// backends without a log of their own.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "scenes/suites.hpp"
#include "solvers/solver.hpp"

namespace tensegrity {
namespace {

struct Seen {
  TracePoint point;
  int part = 0;
  int num_parts = 0;
};

std::vector<Seen> solve_watching(const std::string& backend, const Structure& scene, SolveResult* result,
                                 bool verbose = false) {
  std::vector<Seen> seen;
  DriverControls controls(false);
  controls.on_iteration = [&seen](const TracePoint& p, int part, int num_parts) { seen.push_back({p, part, num_parts}); };
  SolveOptions options;
  options.verbose = verbose;
  *result = make_solver(backend)->Solve(scene, options, controls);
  return seen;
}

TEST(IterationCallback, EveryBackendReportsExactlyItsTrace) {
  const Structure scene = scenes::perturbed(scenes::prism(5), 0.05, 7u);
  for (const std::string& backend : solver_names()) {
    SCOPED_TRACE(backend);
    SolveResult r;
    const std::vector<Seen> seen = solve_watching(backend, scene, &r);
    EXPECT_EQ(r.status, Status::Converged) << r.message;
    ASSERT_GE(seen.size(), 2u);
    ASSERT_EQ(seen.size(), r.trace.size());
    for (std::size_t i = 0; i < seen.size(); ++i) {
      EXPECT_EQ(seen[i].point.iteration, r.trace[i].iteration);
      EXPECT_EQ(seen[i].point.relative_residual, r.trace[i].relative_residual);
      EXPECT_EQ(seen[i].point.residual, r.trace[i].residual);
      EXPECT_DOUBLE_EQ(seen[i].point.seconds, r.trace[i].seconds);
      EXPECT_EQ(seen[i].part, 0);
      EXPECT_EQ(seen[i].num_parts, 1);
    }
    // The last record is the converged state.
    EXPECT_LE(seen.back().point.relative_residual, 1e-8);
    EXPECT_GT(seen.front().point.relative_residual, 1e-3);
  }
}

TEST(IterationCallback, PartsAreNumberedAndTimesCountFromTheStartOfTheSolve) {
  const Structure one = scenes::perturbed(scenes::prism(4), 0.05, 11u);
  const Structure scene = scenes::two_copies(one, Eigen::Vector3d(10.0, 0.0, 0.0));
  SolveResult r;
  const std::vector<Seen> seen = solve_watching("alternating", scene, &r);
  EXPECT_EQ(r.status, Status::Converged) << r.message;
  ASSERT_EQ(seen.size(), r.trace.size());
  int first_of_part_1 = -1;
  for (std::size_t i = 0; i < seen.size(); ++i) {
    EXPECT_EQ(seen[i].num_parts, 2);
    if (seen[i].part == 1 && first_of_part_1 < 0) first_of_part_1 = static_cast<int>(i);
    // Parts run one after the other, and so do their records.
    if (first_of_part_1 >= 0) {
      EXPECT_EQ(seen[i].part, 1);
    }
    if (i > 0) {
      EXPECT_GE(seen[i].point.seconds, seen[i - 1].point.seconds);
    }
    EXPECT_DOUBLE_EQ(seen[i].point.seconds, r.trace[i].seconds);
  }
  ASSERT_GT(first_of_part_1, 1);
  // Each part starts at its own iteration 0.
  EXPECT_EQ(seen[first_of_part_1].point.iteration, 0);
  EXPECT_EQ(seen.front().point.iteration, 0);
}

TEST(IterationCallback, VerboseLogsOneLinePerRecordWhereTheBackendHasNoLogOfItsOwn) {
  const Structure scene = scenes::perturbed(scenes::prism(4), 0.05, 13u);
  for (const std::string& backend : solver_names()) {
    SCOPED_TRACE(backend);
    SolveResult r;
    ::testing::internal::CaptureStderr();
    const std::vector<Seen> seen = solve_watching(backend, scene, &r, true);
    const std::string err = ::testing::internal::GetCapturedStderr();
    // The caller's callback still sees every record.
    EXPECT_EQ(seen.size(), r.trace.size());
    int lines = 0;
    for (std::size_t at = err.find(backend + ": iteration "); at != std::string::npos;
         at = err.find(backend + ": iteration ", at + 1))
      ++lines;
    if (make_solver(backend)->prints_own_log()) {
      EXPECT_EQ(lines, 0);
      EXPECT_NE(err.find("iter"), std::string::npos);  // Ipopt's own log
    } else {
      EXPECT_EQ(lines, static_cast<int>(r.trace.size())) << err;
      const std::string last = backend + ": iteration " + std::to_string(r.trace.back().iteration) + ":";
      EXPECT_NE(err.find(last), std::string::npos) << err;
    }
  }
}

}  // namespace
}  // namespace tensegrity
