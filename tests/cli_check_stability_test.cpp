// `tensegrity check --stability` tells a verified stable equilibrium (exit 0)
// from a verified one that is marginal or unstable (exit 3) and from a
// solution that does not verify (exit 1), on the analytic pendulums of
// stability_test.cpp: a 1.5 m member with 2 kg on its free end, g = 9.81,
// whose sideways stiffness is -m g / l standing on a strut and +m g / l hung
// from a cable.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "process_runner.hpp"

namespace tensegrity {
namespace {

constexpr double kMass = 2.0, kLength = 1.5, kGravity = 9.81;

struct Pendulum {
  std::string scene, solution;
};

// Writes the scene and its solution with axial force `force` (N).
Pendulum write_pendulum(const testing::ScratchDir& dir, const std::string& name, bool standing, double force) {
  const double z = standing ? kLength : -kLength;
  const nlohmann::json scene = {
      {"format", "tensegrity-scene"},
      {"version", 1},
      {"name", name},
      {"gravity", {0.0, 0.0, -kGravity}},
      {"nodes", {{{"x", {0.0, 0.0, 0.0}}, {"fixed", true}}, {{"x", {0.0, 0.0, z}}, {"mass", kMass}}}},
      {"elements", {{{"kind", standing ? "strut" : "cable"}, {"nodes", {0, 1}}}}}};
  const nlohmann::json solution = {
      {"format", "tensegrity-solution"},
      {"version", 1},
      {"scene", name},
      {"solver", "by hand"},
      {"status", "converged"},
      {"positions", {{0.0, 0.0, 0.0}, {0.0, 0.0, z}}},
      {"forces", {force}},
      {"stats",
       {{"iterations", 0}, {"seconds", 0.0}, {"residual", 0.0}, {"relative_residual", 0.0}, {"geometry_change", 0.0}}}};
  Pendulum p{dir.file(name + ".scene.json"), dir.file(name + ".solution.json")};
  std::ofstream(p.scene) << scene.dump(2);
  std::ofstream(p.solution) << solution.dump(2);
  return p;
}

// The numbers on the line "eigenvalues ..." of the report.
std::vector<double> eigenvalues_in(const std::string& out) {
  const std::size_t at = out.find("eigenvalues");
  std::vector<double> v;
  if (at == std::string::npos) return v;
  std::istringstream line(out.substr(at + 11, out.find('\n', at) - at - 11));
  for (double x; line >> x;) v.push_back(x);
  return v;
}

TEST(CliCheckStability, HungPendulumIsVerifiedAndStable) {
  testing::ScratchDir dir("cli-check-stable");
  const Pendulum p = write_pendulum(dir, "hung", false, kMass * kGravity);
  const testing::ProgramRun r = dir.run({"check", p.scene, p.solution, "--stability"});
  EXPECT_EQ(r.exit_status, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("\nverified\n"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("stability         stable"), std::string::npos) << r.out;
  const std::vector<double> ev = eigenvalues_in(r.out);
  ASSERT_GE(ev.size(), 2u) << r.out;
  EXPECT_NEAR(ev[0], kMass * kGravity / kLength, 1e-4);
  EXPECT_NEAR(ev[1], kMass * kGravity / kLength, 1e-4);
}

TEST(CliCheckStability, StandingPendulumIsVerifiedButUnstable) {
  testing::ScratchDir dir("cli-check-unstable");
  const Pendulum p = write_pendulum(dir, "standing", true, -kMass * kGravity);
  // Without --stability it simply verifies.
  EXPECT_EQ(dir.run({"check", p.scene, p.solution}).exit_status, 0);
  const testing::ProgramRun r = dir.run({"check", p.scene, p.solution, "--stability"});
  EXPECT_EQ(r.exit_status, 3) << r.out << r.err;
  EXPECT_NE(r.out.find("\nverified\n"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("stability         unstable"), std::string::npos) << r.out;
  const std::vector<double> ev = eigenvalues_in(r.out);
  ASSERT_GE(ev.size(), 2u) << r.out;
  EXPECT_NEAR(ev[0], -kMass * kGravity / kLength, 1e-4);
  EXPECT_NEAR(ev[1], -kMass * kGravity / kLength, 1e-4);
}

TEST(CliCheckStability, ASolutionThatDoesNotVerifyExitsOneWithOrWithoutStability) {
  testing::ScratchDir dir("cli-check-unverified");
  // Half the force the weight needs: 9.81 N of net force on the mass.
  const Pendulum p = write_pendulum(dir, "weak", false, 0.5 * kMass * kGravity);
  const testing::ProgramRun plain = dir.run({"check", p.scene, p.solution});
  EXPECT_EQ(plain.exit_status, 1) << plain.out << plain.err;
  EXPECT_NE(plain.out.find("residual          9.81 N"), std::string::npos) << plain.out;
  const testing::ProgramRun r = dir.run({"check", p.scene, p.solution, "--stability"});
  EXPECT_EQ(r.exit_status, 1) << r.out << r.err;
  EXPECT_NE(r.out.find("NOT verified"), std::string::npos) << r.out;
}

}  // namespace
}  // namespace tensegrity
