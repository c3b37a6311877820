// End-to-end: the `tensegrity` program as outside scripts use it (docs/FORMATS.md).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "model/scene_io.hpp"
#include "process_runner.hpp"
#include "scenes/suites.hpp"
#include "solvers/solver.hpp"

namespace tensegrity {
namespace {

namespace fs = std::filesystem;

class CliSolve : public ::testing::Test {
 protected:
  std::string write_scene(const Structure& s) {
    const std::string path = scratch.file(s.name + ".scene.json");
    write_scene_file(s, path);
    return path;
  }
  // `tensegrity ARGS...`: exit status and standard output.
  testing::ProgramRun run_cli(const std::vector<std::string>& args) const { return scratch.run(args); }
  testing::ScratchDir scratch{"cli-solve"};
  fs::path dir = scratch.work();
};

TEST_F(CliSolve, SolversListsEveryRegisteredBackend) {
  const testing::ProgramRun r = run_cli({"solvers"});
  EXPECT_EQ(r.exit_status, 0);
  std::string expected;
  for (const auto& n : solver_names()) expected += n + "\n";
  EXPECT_EQ(r.out, expected);
}

TEST_F(CliSolve, ForcesConvergedOnAPrismInfeasibleWhenTwisted) {
  const std::string good = write_scene(scenes::prism(5));
  const std::string sol = (dir / "good.json").string();
  EXPECT_EQ(run_cli({"forces", good, "--out", sol}).exit_status, 0);
  EXPECT_EQ(run_cli({"check", good, sol}).exit_status, 0);
  const auto j = nlohmann::json::parse(std::ifstream(sol));
  EXPECT_EQ(j["status"], "converged");
  EXPECT_LE(j["stats"]["relative_residual"].get<double>(), 1e-12);
  EXPECT_EQ(j["stats"]["geometry_change"].get<double>(), 0.0);

  const std::string bad = write_scene(scenes::prism(5, 5.0));
  const std::string sol2 = (dir / "bad.json").string();
  EXPECT_EQ(run_cli({"forces", bad, "--out", sol2}).exit_status, 1);
  const auto j2 = nlohmann::json::parse(std::ifstream(sol2));
  EXPECT_EQ(j2["status"], "infeasible");
  EXPECT_GE(j2["stats"]["relative_residual"].get<double>(), 1e-3);
  EXPECT_EQ(run_cli({"check", bad, sol2}).exit_status, 1);
}

TEST_F(CliSolve, EveryBackendSolvesAndTheSolutionChecks) {
  const std::string scene = write_scene(scenes::perturbed(scenes::prism(6, 0.0, true), 0.05, 1u));
  for (const auto& name : solver_names()) {
    const std::string sol = (dir / (name + ".json")).string();
    const std::string trace = (dir / (name + ".csv")).string();
    EXPECT_EQ(run_cli({"solve", scene, "--solver", name, "--out", sol, "--trace", trace}).exit_status, 0)
        << name;
    EXPECT_EQ(run_cli({"check", scene, sol}).exit_status, 0) << name;
    const auto j = nlohmann::json::parse(std::ifstream(sol));
    for (const char* key : {"format", "version", "status", "positions", "forces", "stats"})
      EXPECT_TRUE(j.contains(key)) << name << " " << key;
    for (const char* key : {"iterations", "seconds", "residual", "relative_residual", "geometry_change"})
      EXPECT_TRUE(j["stats"].contains(key)) << name << " " << key;
    EXPECT_EQ(j["solver"], name);
    std::ifstream csv(trace);
    std::string header;
    std::getline(csv, header);
    EXPECT_EQ(header.rfind("seconds,", 0), 0u) << name;
  }
}

// The backend the README's table marks "(default)" (the recommended one,
// docs/USER-GUIDE.md) is the one `solve` uses without --solver, and it ends at
// the local optimum of Eq. 5 that Ipopt reaches on its own from the same
// start, alternating-gn's equilibrium.
TEST_F(CliSolve, WithoutSolverUsesTheReadmesDefaultAtIpoptsOptimum) {
  std::ifstream readme_file(std::string(TENSEGRITY_SOURCE_DIR) + "/README.md");
  const std::string marker = "` (default) |";
  std::string line, readme_default;
  while (readme_default.empty() && std::getline(readme_file, line)) {
    const std::size_t end = line.find(marker);
    if (line.rfind("| `", 0) == 0 && end != std::string::npos) readme_default = line.substr(3, end - 3);
  }
  EXPECT_EQ(readme_default, default_solver_name());

  const std::string scene = write_scene(scenes::perturbed(scenes::prism(6, 0.0, true), 0.05, 3u));
  const std::string by_default = (dir / "default.json").string();
  const std::string by_ipopt = (dir / "ipopt-equilibrium.json").string();
  ASSERT_EQ(run_cli({"solve", scene, "--out", by_default, "--quiet"}).exit_status, 0);
  const std::vector<std::string> ipopt_run = {"solve", scene, "--solver", "ipopt", "--option",
                                              "start=alternating-gn", "--out", by_ipopt, "--quiet"};
  ASSERT_EQ(run_cli(ipopt_run).exit_status, 0);
  EXPECT_EQ(run_cli({"check", scene, by_default}).exit_status, 0);
  const auto d = nlohmann::json::parse(std::ifstream(by_default));
  const auto i = nlohmann::json::parse(std::ifstream(by_ipopt));
  EXPECT_EQ(d["solver"], default_solver_name());
  const double change = d["stats"]["geometry_change"].get<double>();
  const double ipopt_change = i["stats"]["geometry_change"].get<double>();
  EXPECT_GT(change, 0.0);
  EXPECT_NEAR(change, ipopt_change, 1e-6 * ipopt_change);
}

TEST_F(CliSolve, SolveToStandardOutputAndTamperedSolutionFailsTheCheck) {
  const std::string scene = write_scene(scenes::prism(4, 10.0));
  const testing::ProgramRun r = run_cli({"solve", scene});
  ASSERT_EQ(r.exit_status, 0);
  auto j = nlohmann::json::parse(r.out);
  j["forces"][0] = -j["forces"][0].get<double>();  // a strut now pulls
  const std::string sol = (dir / "tampered.json").string();
  std::ofstream(sol) << j.dump();
  EXPECT_EQ(run_cli({"check", scene, sol}).exit_status, 1);
}

TEST_F(CliSolve, BadToleranceAndUnknownSolverAreUsageErrors) {
  const std::string scene = write_scene(scenes::prism(3));
  const std::string out = (dir / "never.json").string();
  for (const auto& [option, value] : std::vector<std::pair<std::string, std::string>>{
           {"--tol", "0"}, {"--tol", "-1"}, {"--tol", "nan"}, {"--tol", "inf"}, {"--solver", "nosuch"},
           {"--option", "nosuchkey=1"}, {"--prestress-factor", "0"}, {"--prestress-factor", "-2"},
           {"--prestress-factor", "inf"}}) {
    EXPECT_EQ(run_cli({"solve", scene, "--out", out, option, value}).exit_status, 2) << option << " " << value;
    EXPECT_FALSE(fs::exists(out)) << option << " " << value;
  }
}

// `--prestress-factor` reaches Eq. 5: the reference gravity prism-7 stands at
// forces above its weight, so with the cap at kappa = 1 Eq. 5 must move it,
// and a larger kappa lets the prestress balance more of the weight, which
// shrinks the change; ipopt and nlopt agree on the optimum at each kappa.
TEST_F(CliSolve, PrestressFactorSetsEq5sCapUnderGravity) {
  const std::string scene = std::string(TENSEGRITY_SOURCE_DIR) + "/data/reference/prism-7-gravity.scene.json";
  auto change = [&](const std::string& solver, const std::string& kappa) {
    const std::string out = (dir / (solver + "-" + kappa + ".json")).string();
    const testing::ProgramRun r = run_cli({"solve", scene, "--solver", solver, "--no-skip", "--quiet",
                                           "--prestress-factor", kappa, "--out", out});
    EXPECT_EQ(r.exit_status, 0) << solver << " kappa " << kappa << ": " << r.err;
    return nlohmann::json::parse(std::ifstream(out))["stats"]["geometry_change"].get<double>();
  };
  const double at_1 = change("ipopt", "1"), at_5 = change("ipopt", "5");
  EXPECT_GT(at_1, 0.1);             // m: 0.378 measured
  EXPECT_LT(at_5, 0.5 * at_1);      // 0.098 measured
  EXPECT_NEAR(change("nlopt", "5"), at_5, 1e-6 * at_5);
}

// Every backend rejects an out-of-range option value the same way: exit 2, no
// output, one line naming the option, its value and the valid range.
TEST_F(CliSolve, OutOfRangeBackendOptionsNameTheOptionAndTheValidRange) {
  const std::string scene = write_scene(scenes::prism(3, 10.0));
  const std::string out = (dir / "never.json").string();
  const struct {
    const char* solver;
    const char* option;
    const char* range;
  } cases[] = {
      {"alternating", "mu=0", "(valid: (0, inf))"},
      {"alternating-gn", "mu=0", "(valid: (0, inf))"},
      {"alternating", "crawl_ratio=1.5", "(valid: (0, 1])"},
      {"alternating-gn", "restarts=9", "(valid: [0, 5])"},
      {"nlopt", "ftol_rel=0", "(valid: (0, inf))"},
      {"ipopt", "tol=0", "(valid: a number in (0, inf))"},
  };
  for (const auto& c : cases) {
    const testing::ProgramRun r = run_cli({"solve", scene, "--solver", c.solver, "--option", c.option, "--out", out});
    EXPECT_EQ(r.exit_status, 2) << c.solver << " " << c.option;
    EXPECT_FALSE(fs::exists(out)) << c.solver << " " << c.option;
    const std::string expected = std::string("tensegrity: command line: --option ") + c.option + ": out of range " +
                                 c.range + " (solver " + c.solver + ")\n";
    EXPECT_EQ(r.err, expected) << c.solver << " " << c.option;
  }
}

}  // namespace
}  // namespace tensegrity
