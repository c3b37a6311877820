// The command line on every file of tests/bad_inputs (and on a missing file and
// a directory): exit status 2, exactly one line on standard error naming the
// file, nothing on standard output, and no output file (CONTRACT.md).
#include <gtest/gtest.h>

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

}  // namespace
