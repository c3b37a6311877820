// The command line on every file of tests/bad_inputs (and on a missing file and
// a directory): exit status 2, exactly one line on standard error naming the
// file, nothing on standard output, and no output file (docs/FORMATS.md).
// A misspelled key names the typo and the intended key; a distant unknown key
// is kept and warned about.
#include <gtest/gtest.h>

#include <array>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>
#include <vector>

#include "process_runner.hpp"

namespace {

namespace fs = std::filesystem;

const fs::path kBadInputs = fs::path(TENSEGRITY_SOURCE_DIR) / "tests" / "bad_inputs";

using tensegrity::testing::ProgramRun;

class CliBadInput : public ::testing::Test {
 protected:
  ProgramRun run(const std::vector<std::string>& args) const { return dir_.run(args); }
  std::vector<std::string> work_files() const { return dir_.work_files(); }

  // The checks every bad input must pass, for one command line.
  void expect_rejected(const std::vector<std::string>& args, const std::string& file) {
    std::string shown;
    for (const std::string& a : args) shown += a + " ";
    SCOPED_TRACE(shown);
    const ProgramRun r = run(args);
    EXPECT_EQ(r.exit_status, 2);
    ASSERT_FALSE(r.err.empty());
    EXPECT_EQ(r.err.back(), '\n');
    EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << "more than one line:\n" << r.err;
    EXPECT_NE(r.err.find(file), std::string::npos) << "does not name " << file << ": " << r.err;
    EXPECT_TRUE(r.out.empty()) << r.out;
    EXPECT_TRUE(work_files().empty()) << "output written: " << work_files().front();
  }

  tensegrity::testing::ScratchDir dir_{"cli-bad"};
};

std::set<fs::path> bad_scene_files() {
  std::set<fs::path> files;
  for (const auto& entry : fs::directory_iterator(kBadInputs))
    if (entry.path().string().ends_with(".scene.json")) files.insert(entry.path());
  return files;
}

TEST_F(CliBadInput, ProgramExists) { ASSERT_TRUE(fs::exists(TENSEGRITY_BINARY)) << TENSEGRITY_BINARY; }

TEST_F(CliBadInput, ForcesRejectsEveryBadScene) {
  ASSERT_GE(bad_scene_files().size(), 40u);
  const std::string out = (dir_.work() / "out.solution.json").string();
  for (const fs::path& file : bad_scene_files()) expect_rejected({"forces", file.string(), "--out", out}, file.string());
}

TEST_F(CliBadInput, SolveRejectsEveryBadScene) {
  const std::string out = (dir_.work() / "out.solution.json").string();
  for (const fs::path& file : bad_scene_files()) expect_rejected({"solve", file.string(), "--out", out}, file.string());
}

TEST_F(CliBadInput, StandardOutputStaysEmpty) {
  // With --out - a bad scene must not leave half a solution on stdout.
  for (const char* name : {"self_loop", "overflow_number", "truncated"}) {
    const std::string file = (kBadInputs / (std::string(name) + ".scene.json")).string();
    expect_rejected({"forces", file, "--out", "-"}, file);
    expect_rejected({"solve", file}, file);
  }
}

TEST_F(CliBadInput, MissingFileAndDirectory) {
  const std::string out = (dir_.work() / "out.solution.json").string();
  const std::string missing = (dir_.work() / "no-such.scene.json").string();
  for (const char* command : {"forces", "solve"}) {
    expect_rejected({command, missing, "--out", out}, missing);
    expect_rejected({command, kBadInputs.string(), "--out", out}, kBadInputs.string());
  }
}

// A name no registry knows: the library names the option, the program adds
// the flag that gave it.
TEST_F(CliBadInput, UnknownSolverAndFamilyNameTheirFlags) {
  const std::string scene = (fs::path(TENSEGRITY_SOURCE_DIR) / "data" / "reference" / "prism-3.scene.json").string();
  const std::string out = (dir_.work() / "out.json").string();
  const ProgramRun solve = run({"solve", scene, "--solver", "nope", "--out", out});
  EXPECT_EQ(solve.exit_status, 2);
  EXPECT_EQ(solve.err,
            "tensegrity: command line: --solver nope: unknown backend (known: alternating, alternating-gn, "
            "eq5-newton, ipopt, nlopt)\n");
  // compare and stress-test take a list: their flag is --solvers.
  for (const char* command : {"compare", "stress-test"}) {
    const std::vector<std::string> args =
        std::string(command) == "compare"
            ? std::vector<std::string>{command, scene, "--solvers", "alternating,nope", "--out", out + ".d"}
            : std::vector<std::string>{command, "--solvers", "alternating,nope", "--out", out};
    const ProgramRun listed = run(args);
    EXPECT_EQ(listed.exit_status, 2) << command;
    EXPECT_EQ(listed.err,
              "tensegrity: command line: --solvers nope: unknown backend (known: alternating, alternating-gn, "
              "eq5-newton, ipopt, nlopt)\n")
        << command;
  }
  const ProgramRun stress = run({"stress-test", "--families", "nope", "--out", out});
  EXPECT_EQ(stress.exit_status, 2);
  EXPECT_EQ(stress.err,
            "tensegrity: command line: --families nope: unknown stress-test family (known: noise, twist, scale, "
            "length-ratio, near-coincident, near-parallel, mass, gravity-direction)\n");
  EXPECT_TRUE(work_files().empty());
}

TEST_F(CliBadInput, CheckRejectsABadScene) {
  const std::string scene = (kBadInputs / "duplicate_reversed.scene.json").string();
  const std::string solution = (dir_.work() / "no-such.solution.json").string();
  const ProgramRun r = run({"check", scene, solution});
  EXPECT_EQ(r.exit_status, 2);
  EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << r.err;
}

TEST_F(CliBadInput, OutputIntoAMissingDirectoryIsRejected) {
  // A scene that is fine but an --out that cannot be written: also exit 2.
  const std::string scene = (dir_.work() / "good.scene.json").string();
  {
    std::ofstream(scene) << R"({"format": "tensegrity-scene", "version": 1,
      "nodes": [{"x": [0, 0, 0], "fixed": true}, {"x": [1, 0, 0]}],
      "elements": [{"kind": "cable", "nodes": [0, 1]}]})";
  }
  const std::string out = (dir_.work() / "missing-dir" / "out.solution.json").string();
  const ProgramRun r = run({"forces", scene, "--out", out});
  EXPECT_EQ(r.exit_status, 2);
  EXPECT_NE(r.err.find(out), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out));
}

TEST_F(CliBadInput, TyposNameTheTypoAndTheIntendedKey) {
  const std::string out = (dir_.work() / "out.solution.json").string();
  const std::vector<std::array<std::string, 3>> typos = {
      {"typo_fixd", "fixd", "fixed"}, {"typo_gravty", "gravty", "gravity"}, {"typo_mas", "mas", "mass"},
      {"typo_knd", "knd", "kind"}};
  for (const auto& [name, typo, intended] : typos) {
    const std::string file = (kBadInputs / (name + ".scene.json")).string();
    for (const char* command : {"forces", "solve"}) {
      SCOPED_TRACE(std::string(command) + " " + name);
      const ProgramRun r = run({command, file, "--out", out});
      EXPECT_EQ(r.exit_status, 2);
      EXPECT_NE(r.err.find("unknown key '" + typo + "' (did you mean '" + intended + "'?)"), std::string::npos)
          << r.err;
      EXPECT_TRUE(work_files().empty());
    }
  }
}

TEST_F(CliBadInput, BuildRejectsAMisspelledCharacterKey) {
  const std::string file = (kBadInputs / "typo_scal.character.json").string();
  const std::string out = (dir_.work() / "duck.scene.json").string();
  expect_rejected({"build", file, "--out", out}, file);
  const ProgramRun r = run({"build", file, "--out", out});
  EXPECT_EQ(r.err, "tensegrity: " + file + ": blocks[4]: unknown key 'scal' (did you mean 'scale'?)\n");
}

TEST_F(CliBadInput, DistantUnknownKeysAreKeptAndWarnedAboutOnce) {
  // The prism converges as it stands; a comment and a node colour are added.
  std::string text = tensegrity::testing::read_text(fs::path(TENSEGRITY_SOURCE_DIR) / "data/reference/prism-3.scene.json");
  text.replace(text.find("\"name\""), 0, "\"comment\": \"by hand\", ");
  text.replace(text.find("{\"x\"", text.find("{\"x\"") + 1) + 1, 0, "\"color\": \"red\", ");
  const std::string scene = (dir_.logs() / "colored.scene.json").string();
  std::ofstream(scene) << text;
  const std::string solution = (dir_.work() / "out.solution.json").string();
  const std::string rewritten = (dir_.work() / "out.scene.json").string();
  const ProgramRun r = run({"solve", scene, "--out", solution, "--out-scene", rewritten});
  EXPECT_EQ(r.exit_status, 0) << r.err;
  const std::string warning = "tensegrity: " + scene + ": warning: unknown keys kept: comment, nodes[1].color\n";
  EXPECT_EQ(r.err.rfind(warning, 0), 0u) << r.err;
  EXPECT_EQ(r.err.find("warning", warning.size()), std::string::npos) << "warned twice:\n" << r.err;
  const std::string written = tensegrity::testing::read_text(rewritten);
  EXPECT_NE(written.find("\"color\": \"red\""), std::string::npos) << written;
  EXPECT_NE(written.find("\"comment\": \"by hand\""), std::string::npos) << written;
}

}  // namespace
