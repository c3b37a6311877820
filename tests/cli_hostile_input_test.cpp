// Every command of the program that reads a file, fed hostile input in every
// role it reads a file in: each bad scene of tests/bad_inputs, files beyond the
// size limit, an endless device, deeply nested JSON (at the top and inside an
// otherwise valid scene), a huge string, a FIFO with no writer, a directory, a
// path too long, a missing folder. Expected for each (docs/FORMATS.md): exit status
// 2 within the time limit (no crash, no hang), one line on stderr that names
// the file, nothing on stdout, no output file.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "process_runner.hpp"

namespace {

namespace fs = std::filesystem;

const fs::path kSource = fs::path(TENSEGRITY_SOURCE_DIR);

using tensegrity::testing::ProgramRun;
using tensegrity::testing::read_text;

// A command line with {in} for the hostile file and {out} for an output path.
struct Role {
  std::string name;
  std::vector<std::string> args;
};

class CliHostileInput : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    base_ = fs::temp_directory_path() / ("tensegrity-hostile-" + std::to_string(::getpid()));
    fs::create_directories(base_ / "inputs");
    const fs::path good_scene = kSource / "data" / "reference" / "prism-3.scene.json";
    good_scene_ = good_scene.string();
    // A solution of the good scene, for the commands that need both.
    good_solution_ = (base_ / "inputs" / "good.solution.json").string();
    fs::create_directories(base_ / "setup-logs");
    ASSERT_EQ(tensegrity::testing::run_program({"forces", good_scene_, "--out", good_solution_}, base_ / "setup-logs")
                  .exit_status,
              0);
    commands_ = available_commands();
  }
  static void TearDownTestSuite() {
    std::error_code ec;
    fs::remove_all(base_, ec);
  }
  static std::set<std::string> available_commands() {
    const tensegrity::testing::ProgramRun run = tensegrity::testing::run_program({"--help"}, base_ / "setup-logs");
    std::set<std::string> names;
    std::istringstream help(run.out + run.err);
    std::string line;
    bool in_list = false;
    while (std::getline(help, line)) {
      if (line.rfind("SUBCOMMANDS", 0) == 0 || line.rfind("Subcommands", 0) == 0) {
        in_list = true;
        continue;
      }
      if (!in_list) continue;
      std::istringstream words(line);
      std::string first;
      if (words >> first) names.insert(first);
    }
    return names;
  }

  // Every role in which a command reads a file.
  std::vector<Role> all_roles() const {
    const std::string out = (dir_.work() / "out.json").string();
    return {
        {"solve", {"solve", "{in}", "--out", out}},
        {"forces", {"forces", "{in}", "--out", out}},
        {"check", {"check", "{in}", good_solution_}},
        {"check", {"check", good_scene_, "{in}"}},
        {"export", {"export", "{in}", "--scene", good_scene_, "--format", "vtk", "--out", out}},
        {"export", {"export", good_solution_, "--scene", "{in}", "--format", "vtk", "--out", out}},
        {"render", {"render", "{in}", "--out", (dir_.work() / "out.png").string()}},
        {"render", {"render", good_scene_, "--solution", "{in}", "--out", (dir_.work() / "out.png").string()}},
        {"design", {"design", "{in}", "--out", out}},
        {"build", {"build", "{in}", "--out", out}},
        {"fit-material", {"fit-material", "{in}", "--out", out}},
        {"batch", {"batch", "{in}", "--out-dir", dir_.work().string()}},
        {"stress-test",
         {"stress-test", "--scene", "{in}", "--scenes", "prism-3", "--families", "noise", "--trials", "1",
          "--solvers", "alternating-gn", "--quiet", "--out", out}},
        {"simulate", {"simulate", "{in}", "--out", out}},
        {"relax", {"relax", "{in}", "--out", out}},
    };
  }
  // The same without commands the program does not have (yet).
  std::vector<Role> roles() const {
    std::vector<Role> present;
    for (const Role& r : all_roles())
      if (commands_.count(r.name)) present.push_back(r);
    return present;
  }

  // A shorter limit than the default: every run here should end at once.
  ProgramRun run(const std::vector<std::string>& args) const { return dir_.run(args, 60); }

  // Runs every role (or those given) on `input`; `named` is what stderr must mention.
  void expect_every_command_rejects(const std::string& input, const std::string& named) {
    expect_rejected_in(roles(), input, named);
  }
  void expect_rejected_in(const std::vector<Role>& which, const std::string& input, const std::string& named) {
    for (const Role& role : which) {
      std::vector<std::string> args;
      std::string shown;
      for (const std::string& a : role.args) {
        args.push_back(a == "{in}" ? input : a);
        shown += (a == "{in}" ? "{in}" : a) + " ";
      }
      SCOPED_TRACE(shown + " with {in} = " + named.substr(0, 200));
      const ProgramRun r = run(args);
      EXPECT_EQ(r.exit_status, 2) << r.err;
      ASSERT_FALSE(r.err.empty());
      EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << "not exactly one line:\n" << r.err.substr(0, 2000);
      EXPECT_NE(r.err.find(named), std::string::npos) << r.err.substr(0, 500);
      EXPECT_LT(r.err.size(), 2000u + input.size()) << "the message should stay short";
      EXPECT_TRUE(r.out.empty()) << r.out.substr(0, 500);
      const std::vector<std::string> written = dir_.work_files();
      EXPECT_TRUE(written.empty()) << "output written: " << written.front();
      for (const auto& entry : fs::directory_iterator(dir_.work())) fs::remove_all(entry.path());
    }
  }

  fs::path input(const std::string& name) const { return base_ / "inputs" / name; }

  static inline fs::path base_;
  static inline std::string good_scene_, good_solution_;
  static inline std::set<std::string> commands_;
  tensegrity::testing::ScratchDir dir_{"hostile"};
};

TEST_F(CliHostileInput, CommandsAreFound) {
  // Guards the help parsing: without it every other test here would pass vacuously.
  for (const char* name : {"solve", "forces", "check", "export", "render", "build", "stress-test"})
    EXPECT_TRUE(commands_.count(name)) << name;
  EXPECT_GE(roles().size(), 10u);
}

// One ctest entry per role (780 program runs in all), so that ctest spreads
// them over both cores: under the sanitizers each run starts a 300 MB binary.
class CliHostileInputPerRole : public CliHostileInput, public ::testing::WithParamInterface<int> {};

TEST_P(CliHostileInputPerRole, EveryBadInputClass) {
  const std::vector<Role> all = all_roles();
  ASSERT_LT(GetParam(), static_cast<int>(all.size()));
  const Role& role = all[GetParam()];
  if (!commands_.count(role.name)) GTEST_SKIP() << role.name << " is not a command of this build";
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(kSource / "tests" / "bad_inputs"))
    if (entry.path().string().ends_with(".json")) files.push_back(entry.path());
  ASSERT_GE(files.size(), 40u);
  for (const fs::path& file : files) expect_rejected_in({role}, file.string(), file.string());
}

INSTANTIATE_TEST_SUITE_P(Roles, CliHostileInputPerRole, ::testing::Range(0, 15));

TEST_F(CliHostileInput, EveryRoleIsCoveredByThePerRoleTests) {
  EXPECT_EQ(all_roles().size(), 15u) << "update the Range of CliHostileInputPerRole";
}

TEST_F(CliHostileInput, FileBeyondTheSizeLimit) {
  // Sparse: 300 MiB of zeros take no disk space; the readers refuse it by size.
  const fs::path file = input("huge.scene.json");
  { std::ofstream(file) << "{"; }
  fs::resize_file(file, std::uintmax_t{300} << 20);
  expect_every_command_rejects(file.string(), file.string());
}

TEST_F(CliHostileInput, EndlessDevice) {
  // /dev/zero never ends: reading must stop at the size limit.
  expect_every_command_rejects("/dev/zero", "/dev/zero");
}

TEST_F(CliHostileInput, LargeFileOfWhitespaceAndAHugeString) {
  const fs::path spaces = input("spaces.scene.json");
  { std::ofstream(spaces) << std::string(std::size_t{20} << 20, ' ') << "{]"; }
  expect_every_command_rejects(spaces.string(), spaces.string());
  const fs::path big_string = input("big-string.scene.json");
  {
    std::ofstream(big_string) << R"({"format": "tensegrity-scene", "version": 1, "name": ")"
                              << std::string(std::size_t{8} << 20, 'a') << R"(", "nodes": 7, "elements": []})";
  }
  expect_every_command_rejects(big_string.string(), big_string.string());
}

TEST_F(CliHostileInput, DeeplyNestedJson) {
  const std::size_t depth = 200000;
  const fs::path top = input("deep.scene.json");
  { std::ofstream(top) << std::string(depth, '[') << std::string(depth, ']'); }
  expect_every_command_rejects(top.string(), top.string());
  // Deep nesting inside an unknown key of an otherwise fine scene (kept as an
  // extra field, so it would be copied and written back).
  const fs::path inner = input("deep-extra.scene.json");
  std::string text;
  {
    std::ostringstream s;
    s << R"({"format": "tensegrity-scene", "version": 1, "extra": )";
    for (std::size_t i = 0; i < depth; ++i) s << R"({"a": )";
    s << "1" << std::string(depth, '}');
    s << R"(, "nodes": [{"x": [0, 0, 0], "fixed": true}, {"x": [1, 0, 0]}],
            "elements": [{"kind": "cable", "nodes": [0, 1]}]})";
    text = s.str();
  }
  { std::ofstream(inner) << text; }
  expect_every_command_rejects(inner.string(), inner.string());
}

TEST_F(CliHostileInput, NestingWithinTheLimitIsFine) {
  // A moderately nested extra field is kept, not rejected: the limit is not too tight.
  const fs::path file = input("nested-ok.scene.json");
  {
    std::ofstream(file) << R"({"format": "tensegrity-scene", "version": 1, "extra": )" << std::string(50, '[')
                        << std::string(50, ']') << R"(, "nodes": [{"x": [0, 0, 0], "fixed": true}, {"x": [1, 0, 0]}],
            "elements": [{"kind": "cable", "nodes": [0, 1]}]})";
  }
  const ProgramRun r = run({"forces", file.string(), "--out", "-"});
  EXPECT_EQ(r.exit_status, 1) << r.err;  // runs; a lone cable is not a tensegrity
  EXPECT_NE(r.out.find("\"forces\""), std::string::npos);
}

TEST_F(CliHostileInput, UnreadablePaths) {
  // A FIFO that nobody writes to: reading must not wait forever.
  const fs::path fifo = input("fifo.scene.json");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  expect_every_command_rejects(fifo.string(), fifo.string());
  // A directory, a missing folder, a name too long for the file system.
  // `batch` reads a folder's scene files instead, each bad one named on a line of its own.
  const std::string folder = (kSource / "tests" / "bad_inputs").string();
  std::vector<Role> without_batch;
  for (const Role& role : roles())
    if (role.name != "batch") without_batch.push_back(role);
  expect_rejected_in(without_batch, folder, folder);
  if (commands_.count("batch")) {
    int scene_files = 0;
    for (const auto& entry : fs::directory_iterator(folder)) scene_files += entry.path().string().ends_with(".scene.json");
    const ProgramRun r = run({"batch", folder, "--out-dir", dir_.work().string()});
    EXPECT_EQ(r.exit_status, 2) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), scene_files) << r.err.substr(0, 3000);
    EXPECT_TRUE(r.out.empty()) << r.out.substr(0, 500);
    EXPECT_TRUE(dir_.work_files().empty());
  }
  const std::string missing = (base_ / "no-such-folder" / "x.scene.json").string();
  expect_every_command_rejects(missing, missing);
  const std::string too_long = (base_ / std::string(5000, 'n')).string() + ".scene.json";
  expect_every_command_rejects(too_long, "nnnnnnnn");
  // No read permission (root may read it anyway: then its content is bad too).
  const fs::path locked = input("locked.scene.json");
  { std::ofstream(locked) << "{\"format\": \"tensegrity-scene\", \"version\": 1"; }
  fs::permissions(locked, fs::perms::none);
  expect_every_command_rejects(locked.string(), locked.string());
}

}  // namespace
