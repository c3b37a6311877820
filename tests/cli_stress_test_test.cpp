// `tensegrity stress-test` and determinism: the same options give a
// bit-identical report run to run and on one or two threads; `solve` gives
// bit-identical positions and forces run to run with every backend; a bad
// file of the data folder is skipped with one line and exit status 1; the
// driver's check finds that a stress-test scorpion with long elements stands.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "process_runner.hpp"

namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using tensegrity::testing::read_text;

// `tensegrity ARGS...` with its standard error saved as `err`; the exit status.
int run(const std::vector<std::string>& args, const fs::path& err) {
  const fs::path logs = err.parent_path() / (err.filename().string() + ".logs");
  fs::create_directories(logs);
  const tensegrity::testing::ProgramRun r = tensegrity::testing::run_program(args, logs, 300);
  std::ofstream(err, std::ios::binary) << r.err;
  return r.exit_status;
}

class StressTestCommand : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("tensegrity-stress-" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  // A small stress run: two scenes, two families, every backend.
  std::string report(int jobs, const std::string& name) {
    const fs::path out = dir_ / name;
    const int status = run({"stress-test", "--scenes", "prism-3,prism-4-gravity", "--families", "noise,gravity-direction",
                            "--trials", "1", "--seed", "7", "--jobs", std::to_string(jobs), "--no-times", "--quiet",
                            "--out", out.string()},
                           dir_ / (name + ".err"));
    EXPECT_EQ(status, 0) << read_text(dir_ / (name + ".err"));
    return read_text(out);
  }
  fs::path dir_;
};

TEST_F(StressTestCommand, ReportIsBitIdenticalRunToRunAndOnOneOrTwoThreads) {
  const std::string one = report(1, "one.json");
  const std::string two = report(2, "two.json");
  const std::string again = report(2, "again.json");
  ASSERT_FALSE(one.empty());
  EXPECT_EQ(one, two) << "one thread and two threads differ";
  EXPECT_EQ(two, again) << "two runs differ";

  const json j = json::parse(one);
  EXPECT_EQ(j["format"], "tensegrity-stress-report");
  // 2 scenes x (6 noise levels + 7 gravity directions) x 1 trial, per backend.
  ASSERT_TRUE(j["solvers"].contains("alternating-gn"));
  for (const auto& [solver, s] : j["solvers"].items()) {
    SCOPED_TRACE(solver);
    const json& overall = s["overall"];
    EXPECT_EQ(overall["trials"].get<int>() + overall["rejected_inputs"].get<int>(), 2 * (6 + 7));
    EXPECT_EQ(overall["non_finite"], 0);
    EXPECT_EQ(overall["false_converged"], 0);
    EXPECT_EQ(overall["verified"], overall["converged"]);
    EXPECT_FALSE(overall.contains("median_seconds")) << "--no-times must leave timings out";
  }
  // The small noise levels are easy: alternating-gn solves them all.
  const json& gn = j["solvers"]["alternating-gn"]["families"]["noise"]["by_level"];
  for (const char* level : {"0.001", "0.01", "0.1"}) EXPECT_EQ(gn[level]["converged"], 2) << level;
}

TEST_F(StressTestCommand, SolveIsBitIdenticalRunToRun) {
  const std::string scene = (fs::path(TENSEGRITY_SOURCE_DIR) / "data" / "reference" / "prism-5-gravity.scene.json").string();
  // Move the scene off equilibrium deterministically: twist the top ring.
  json j = json::parse(read_text(scene));
  for (std::size_t i = 5; i < 10; ++i) {
    auto& x = j["nodes"][i]["x"];
    const double a = 0.2, c = std::cos(a), s = std::sin(a);
    const double px = x[0], py = x[1];
    x[0] = c * px - s * py;
    x[1] = s * px + c * py;
  }
  const fs::path twisted = dir_ / "twisted.scene.json";
  { std::ofstream(twisted) << j.dump(); }
  for (const char* solver : {"alternating", "alternating-gn", "ipopt", "nlopt"}) {
    SCOPED_TRACE(solver);
    std::vector<json> results;
    for (int k = 0; k < 2; ++k) {
      const fs::path out = dir_ / ("out" + std::to_string(k) + ".json");
      run({"solve", twisted.string(), "--solver", solver, "--out", out.string()}, dir_ / "err");
      results.push_back(json::parse(read_text(out)));
    }
    // Bit-identical: the JSON numbers round-trip, so equal text means equal bits.
    EXPECT_EQ(results[0]["positions"].dump(), results[1]["positions"].dump());
    EXPECT_EQ(results[0]["forces"].dump(), results[1]["forces"].dump());
    EXPECT_EQ(results[0]["status"], results[1]["status"]);
  }
}

TEST_F(StressTestCommand, RejectsUnknownNames) {
  for (const std::vector<std::string>& bad :
       {std::vector<std::string>{"--scenes", "no-such-scene"}, {"--families", "no-such-family"},
        {"--solvers", "no-such-solver"}}) {
    std::vector<std::string> args = {"stress-test", "--quiet", "--out", (dir_ / "r.json").string()};
    args.insert(args.end(), bad.begin(), bad.end());
    EXPECT_EQ(run(args, dir_ / "err"), 2) << bad[1];
    EXPECT_NE(read_text(dir_ / "err").find(bad[1]), std::string::npos) << read_text(dir_ / "err");
    EXPECT_FALSE(fs::exists(dir_ / "r.json"));
  }
}

// `--option key=value` reaches every solver of the run: an option the solver
// does not know is bad input (exit 2, no report), a known one is recorded in
// the report and changes the solves (a one-step outer budget cannot converge
// on a perturbed prism, the default can).
TEST_F(StressTestCommand, BackendOptionsReachEverySolver) {
  const fs::path out = dir_ / "r.json";
  auto stress = [&](const std::vector<std::string>& extra) {
    std::vector<std::string> args = {"stress-test", "--scenes", "prism-3", "--families", "noise", "--trials", "1",
                                     "--solvers", "alternating", "--jobs", "1", "--no-times", "--quiet",
                                     "--out", out.string()};
    args.insert(args.end(), extra.begin(), extra.end());
    return run(args, dir_ / "err");
  };
  EXPECT_EQ(stress({"--option", "no_such_option=1"}), 2);
  EXPECT_NE(read_text(dir_ / "err").find("no_such_option"), std::string::npos) << read_text(dir_ / "err");
  EXPECT_FALSE(fs::exists(out));
  EXPECT_EQ(stress({"--option", "i_max=0"}), 2);  // out of range for the solver
  EXPECT_FALSE(fs::exists(out));

  ASSERT_EQ(stress({"--option", "step_length=sdc"}), 0) << read_text(dir_ / "err");
  const json with_sdc = json::parse(read_text(out));
  EXPECT_EQ(with_sdc["options"]["backend_options"]["step_length"], "sdc");
  ASSERT_EQ(stress({}), 0) << read_text(dir_ / "err");
  const json plain = json::parse(read_text(out));
  EXPECT_FALSE(plain["options"].contains("backend_options"));
  const auto converged = [](const json& r) {
    return r["solvers"]["alternating"]["families"]["noise"]["by_level"]["0.001"]["converged"].get<int>();
  };
  EXPECT_EQ(converged(plain), 1);
  ASSERT_EQ(stress({"--option", "gamma=1e-12", "--option", "i_max=1"}), 0) << read_text(dir_ / "err");
  EXPECT_EQ(converged(json::parse(read_text(out))), 0);
}

// The driver's check whether a scene already stands: the stress test's
// scorpion with a length ratio of 1,000 stands, yet the stress QP leaves it at
// relative residual 2.3e-4; the check's short polish (solve_scene.cpp) finds
// its forces, so alternating-gn returns it unmoved (without that polish it
// moved the scorpion 1.74 m).
TEST_F(StressTestCommand, TheChecksPolishFindsThatAScorpionWithLongElementsStands) {
  const fs::path out = dir_ / "scorpion.json";
  const fs::path data = fs::path(TENSEGRITY_SOURCE_DIR) / "data";
  // The time limit only cuts short the ratio 1e4's trial, which spends its iteration budget (10 s).
  ASSERT_EQ(run({"stress-test", "--scenes", "scorpion", "--families", "length-ratio", "--trials", "1", "--solvers",
                 "alternating-gn", "--time-limit", "2", "--jobs", "1", "--quiet", "--data", data.string(), "--out",
                 out.string()},
                dir_ / "err"),
            0)
      << read_text(dir_ / "err");
  const json report = json::parse(read_text(out));
  int found = 0;
  for (const json& trial : report["trials"]) {
    if (trial["level"] != "1000") continue;
    ++found;
    EXPECT_TRUE(trial["verified"].get<bool>());
    EXPECT_EQ(trial["geometry_change"].get<double>(), 0.0);
  }
  EXPECT_EQ(found, 1);
}

// A bad file in the data folder is named in one line and left out, as `batch`
// does with a bad scene; the good character is stressed all the same, and the
// exit status is 1 (the run has output, so not 2).
TEST_F(StressTestCommand, BadDataFileIsSkippedWithOneLine) {
  const fs::path source = TENSEGRITY_SOURCE_DIR;
  const fs::path data = dir_ / "data";
  fs::create_directories(data / "characters");
  json duck = json::parse(read_text(source / "data" / "characters" / "minimal" / "duck.character.json"));
  duck["block_library"] = (source / "data" / "blocks").string();
  std::ofstream(data / "characters" / "duck.character.json") << duck.dump();
  const fs::path broken = data / "characters" / "broken.character.json";
  std::ofstream(broken) << "{\"format\": \"tensegrity-character\", \"version\": 1, \"blocks\": [";

  const fs::path out = dir_ / "r.json";
  const int status = run({"stress-test", "--scenes", "character", "--families", "noise", "--trials", "1", "--solvers",
                          "alternating-gn", "--jobs", "2", "--no-times", "--quiet", "--data", data.string(), "--out",
                          out.string()},
                         dir_ / "err");
  const std::string err = read_text(dir_ / "err");
  EXPECT_EQ(status, 1) << err;
  std::vector<std::string> complaints;
  std::istringstream lines(err);
  for (std::string line; std::getline(lines, line);)
    if (line.rfind("tensegrity: ", 0) == 0) complaints.push_back(line);
  ASSERT_EQ(complaints.size(), 1u) << err;
  EXPECT_EQ(complaints[0].find("tensegrity: " + broken.string() + ": "), 0u) << err;
  // The exit status comes from the skipped file alone: every result is sound.
  EXPECT_NE(err.find("stress-test: 6 solves; 0 with"), std::string::npos) << err;

  const json j = json::parse(read_text(out));
  EXPECT_EQ(j["scenes"], json::array({"duck"}));
  // Six noise levels, one trial, one backend.
  EXPECT_EQ(j["totals"]["solves"].get<int>() + j["totals"]["rejected_inputs"].get<int>(), 6);
  EXPECT_EQ(j["trials"].size(), j["totals"]["solves"].get<std::size_t>());
  EXPECT_EQ(j["solvers"]["alternating-gn"]["overall"]["trials"], j["totals"]["solves"]);
  ASSERT_EQ(j["skipped"].size(), 1u);
  EXPECT_EQ(j["skipped"][0]["file"], broken.string());
  EXPECT_EQ("tensegrity: " + j["skipped"][0]["reason"].get<std::string>(), complaints[0]);
  EXPECT_EQ(j["totals"]["skipped_files"], 1);
}

}  // namespace
