// `tensegrity batch` and `stress-test` in worker processes: the files and
// numbers equal single in-process solves, an unreadable scene file is skipped
// with one line and exit status 1, a worker that dies or overruns becomes a
// status of its job (never the end of the run) and is reaped, Ctrl-C stops
// every worker, and the per-backend table of stress-test counts what the JSON
// report holds.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "model/errors.hpp"
#include "model/scene_io.hpp"
#include "model/verify.hpp"
#include "process_runner.hpp"
#include "scenes/families.hpp"
#include "scenes/suites.hpp"
#include "scenes/towers.hpp"
#include "solvers/solver.hpp"

namespace tensegrity {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::ProgramRun;
using testing::read_text;
using testing::start_program;
using testing::wait_program;

// The solution file without the value of `stats.seconds` (the one wall-clock
// field); fails when the field is missing, so the masking hides nothing else.
std::string without_seconds(std::string text) {
  const std::string key = "\"seconds\": ";
  const std::size_t at = text.find(key);
  EXPECT_NE(at, std::string::npos) << text.substr(0, 300);
  if (at == std::string::npos) return text;
  const std::size_t begin = at + key.size();
  const std::size_t end = text.find_first_not_of("0123456789.eE+-", begin);
  return text.replace(begin, end - begin, "T");
}

// The text of a /proc/PID/stat file, or "" once the process is gone: a
// process that exits between open and read makes read() fail with ESRCH,
// which std::ifstream would turn into an exception.
std::string read_proc_stat(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY);
  if (fd < 0) return {};
  constexpr std::size_t kStatBytes = 4096;  // one stat line is far shorter
  std::string text(kStatBytes, '\0');
  const ssize_t n = ::read(fd, text.data(), text.size());
  ::close(fd);
  text.resize(n > 0 ? static_cast<std::size_t>(n) : 0);
  return text;
}

// The state letter of /proc/PID/stat (R, S, Z, ...), or 0 when there is no such process.
char process_state(pid_t pid) {
  const std::string text = read_proc_stat("/proc/" + std::to_string(pid) + "/stat");
  const std::size_t close = text.rfind(')');
  return close == std::string::npos || close + 2 >= text.size() ? 0 : text[close + 2];
}

std::vector<pid_t> children_of(pid_t parent) {
  std::vector<pid_t> found;
  for (const auto& entry : fs::directory_iterator("/proc")) {
    const std::string name = entry.path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    const std::string text = read_proc_stat((entry.path() / "stat").string());
    const std::size_t close = text.rfind(')');
    if (close == std::string::npos) continue;
    std::istringstream rest(text.substr(close + 2));
    char state = 0;
    pid_t ppid = 0;
    rest >> state >> ppid;
    if (ppid == parent && state != 'Z') found.push_back(static_cast<pid_t>(std::stoi(name)));
  }
  return found;
}

// Waits until `parent` has `count` live children (workers); their ids.
std::vector<pid_t> wait_for_workers(pid_t parent, std::size_t count, double limit_s = 60.0) {
  const auto t0 = std::chrono::steady_clock::now();
  while (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() < limit_s) {
    const std::vector<pid_t> found = children_of(parent);
    if (found.size() >= count) return found;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return {};
}

// True once the process is gone (reaped, not a zombie) within the limit.
bool vanishes(pid_t pid, double limit_s) {
  const auto t0 = std::chrono::steady_clock::now();
  while (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() < limit_s) {
    if (process_state(pid) == 0) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return false;
}

class BatchProcesses : public ::testing::Test {
 protected:
  std::string write_scene(const Structure& s, const std::string& name) {
    const std::string path = dir_.file(name + ".scene.json");
    write_scene_file(s, path);
    return path;
  }
  // The 80-strut / 500-cable tower: the faithful scheme crawls on it, so a
  // solve runs until its time limit.
  std::string slow_scene(unsigned seed) {
    scenes::TowerParameters p;
    p.seed = seed;
    return write_scene(scenes::make_prism_tower(p), "tower-" + std::to_string(seed));
  }
  testing::ScratchDir dir_{"batch-processes"};
};

// Off equilibrium, so that every backend iterates; one with gravity.
std::vector<Structure> small_scenes() {
  return {scenes::perturbed(scenes::prism(5), 0.05, 3u), scenes::perturbed(scenes::prism(4, 0.0, true), 0.05, 7u),
          scenes::perturbed(scenes::octahedron(), 0.03, 11u)};
}

// The library names the option and the value; the command line adds its flag
// (tests/cli_bad_input_test.cpp).
TEST(StressFamilies, AnUnknownFamilyIsAnOptionValueNotAFlag) {
  try {
    scenes::family_levels("nope");
    ADD_FAILURE() << "family nope has levels";
  } catch (const UnknownNameError& e) {
    EXPECT_EQ(e.kind(), "family");
    EXPECT_STREQ(e.what(),
                 "options: family 'nope': unknown stress-test family (known: noise, twist, scale, length-ratio, "
                 "near-coincident, near-parallel, mass, gravity-direction)");
  }
}

TEST_F(BatchProcesses, SolutionFilesEqualThoseOfSolve) {
  std::vector<std::string> args = {"batch"};
  std::vector<std::string> names;
  for (const Structure& s : small_scenes()) {
    args.push_back(write_scene(s, s.name));
    names.push_back(s.name);
  }
  const fs::path out = dir_.work() / "out";
  const std::string report = dir_.file("report.json");
  args.insert(args.end(), {"--solver", "alternating-gn,ipopt", "--jobs", "2", "--out-dir", out.string(), "--json", report});
  const ProgramRun r = dir_.run(args, 600);
  ASSERT_EQ(r.exit_status, 0) << r.err << r.out;
  const json j = json::parse(read_text(report));
  ASSERT_EQ(j["jobs"].size(), 2 * names.size());
  std::size_t k = 0;
  for (const std::string& name : names)
    for (const std::string solver : {"alternating-gn", "ipopt"}) {
      SCOPED_TRACE(name + " with " + solver);
      const fs::path single = dir_.work() / (name + "." + solver + ".single.json");
      const ProgramRun s = dir_.run({"solve", dir_.file(name + ".scene.json"), "--solver", solver, "--out", single.string()});
      ASSERT_EQ(s.exit_status, 0) << s.err;
      const fs::path batched = out / solver / (name + ".solution.json");
      ASSERT_TRUE(fs::exists(batched));
      EXPECT_EQ(without_seconds(read_text(batched)), without_seconds(read_text(single)));
      // The report's numbers are the solution's, bit for bit.
      const json file = json::parse(read_text(single));
      const json& entry = j["jobs"][k++];
      EXPECT_EQ(entry["scene"], name);
      EXPECT_EQ(entry["solver"], solver);
      EXPECT_EQ(entry["status"], file["status"]);
      EXPECT_EQ(entry["worker"], "finished");
      for (const char* key : {"iterations", "relative_residual", "geometry_change", "residual"})
        EXPECT_EQ(entry[key], file["stats"][key]) << key;
    }
  EXPECT_EQ(j["totals"]["converged"], 2 * names.size());
  EXPECT_EQ(j["options"]["jobs"], 2);
}

TEST_F(BatchProcesses, UnreadableSceneIsSkippedWithOneLine) {
  const fs::path folder = dir_.work() / "scenes";
  fs::create_directories(folder);
  const std::vector<Structure> good = small_scenes();
  for (std::size_t i = 0; i < 2; ++i) write_scene_file(good[i], (folder / (good[i].name + ".scene.json")).string());
  const fs::path broken = folder / "broken.scene.json";
  std::ofstream(broken) << "{\"format\": \"tensegrity-scene\", \"version\": 1, \"nodes\": [";
  const fs::path out = dir_.work() / "out";
  const std::string report = dir_.file("report.json");
  const ProgramRun r = dir_.run({"batch", folder.string(), "--solver", "alternating-gn", "--out-dir", out.string(),
                                 "--json", report});
  EXPECT_EQ(r.exit_status, 1) << r.err;  // output was written, so not 2
  // One line names the file and the reason; the others are the progress lines of the run.
  std::istringstream err(r.err);
  std::vector<std::string> complaints;
  for (std::string line; std::getline(err, line);)
    if (line.rfind("tensegrity: ", 0) == 0) complaints.push_back(line);
  ASSERT_EQ(complaints.size(), 1u) << r.err;
  EXPECT_EQ(complaints[0].find("tensegrity: " + broken.string() + ": line 1"), 0u) << r.err;
  for (std::size_t i = 0; i < 2; ++i) EXPECT_TRUE(fs::exists(out / (good[i].name + ".solution.json"))) << good[i].name;
  EXPECT_FALSE(fs::exists(out / "broken.solution.json"));
  EXPECT_NE(r.out.find("converged 2 of 2"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("skipped 1 unreadable scene files"), std::string::npos) << r.out;
  const json j = json::parse(read_text(report));
  ASSERT_EQ(j["skipped"].size(), 1u);
  EXPECT_EQ(j["skipped"][0]["file"], broken.string());
  EXPECT_NE(j["skipped"][0]["reason"].get<std::string>().find("broken.scene.json"), std::string::npos);
  EXPECT_EQ(j["totals"]["jobs"], 2);
  EXPECT_EQ(j["totals"]["skipped_files"], 1);
}

// One worker; the first job (a long one) loses its worker to SIGKILL. That job
// ends numerical_error with a written solution, the worker is reaped at once,
// and a new worker solves the rest.
TEST_F(BatchProcesses, DeadWorkerIsAStatusAndIsReaped) {
  const std::string first = slow_scene(1), second = slow_scene(2);
  const std::string fast = write_scene(small_scenes()[0], "fast");
  const fs::path out = dir_.work() / "out";
  const std::string report = dir_.file("report.json");
  const pid_t batch = start_program({"batch", first, second, fast, "--solver", "alternating", "--jobs", "1",
                                     "--time-limit", "4", "--out-dir", out.string(), "--json", report},
                                    dir_.logs());
  const std::vector<pid_t> workers = wait_for_workers(batch, 1);
  ASSERT_EQ(workers.size(), 1u);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  ASSERT_EQ(::kill(workers[0], SIGKILL), 0);
  // Reaped while the run goes on (the second tower takes its 4 s).
  EXPECT_TRUE(vanishes(workers[0], 3.0)) << "state " << process_state(workers[0]);
  EXPECT_NE(process_state(batch), 0);
  const int status = wait_program(batch, 120);
  ASSERT_TRUE(WIFEXITED(status)) << status;
  EXPECT_EQ(WEXITSTATUS(status), 1) << read_text(dir_.logs() / "stderr");
  const json j = json::parse(read_text(report));
  ASSERT_EQ(j["jobs"].size(), 3u);
  EXPECT_EQ(j["jobs"][0]["worker"], "crashed");
  EXPECT_EQ(j["jobs"][0]["status"], "numerical_error");
  EXPECT_NE(j["jobs"][0]["message"].get<std::string>().find("signal 9"), std::string::npos) << j["jobs"][0];
  EXPECT_EQ(j["jobs"][1]["worker"], "finished");
  EXPECT_EQ(j["jobs"][2]["status"], "converged");
  const json written = json::parse(read_text(out / "tower-1.solution.json"));
  EXPECT_EQ(written["status"], "numerical_error");
}

TEST_F(BatchProcesses, OverrunningSolveIsKilledAsTimeLimit) {
  const std::string slow = slow_scene(3);
  const std::string fast = write_scene(small_scenes()[1], "fast");
  const std::string report = dir_.file("report.json");
  const ProgramRun r = dir_.run({"batch", slow, fast, "--solver", "alternating", "--jobs", "2", "--time-limit", "600",
                                 "--kill-after", "1", "--out-dir", (dir_.work() / "out").string(), "--json", report});
  EXPECT_EQ(r.exit_status, 1) << r.err;
  const json j = json::parse(read_text(report));
  EXPECT_EQ(j["jobs"][0]["status"], "time_limit");
  EXPECT_EQ(j["jobs"][0]["worker"], "killed");
  EXPECT_EQ(j["jobs"][1]["status"], "converged");
  EXPECT_EQ(j["options"]["kill_after_s"], 1.0);
}

TEST_F(BatchProcesses, InterruptStopsEveryWorker) {
  const std::string a = slow_scene(4), b = slow_scene(5);
  const pid_t batch = start_program({"batch", a, b, "--solver", "alternating", "--jobs", "2", "--time-limit", "300",
                                     "--out-dir", (dir_.work() / "out").string()},
                                    dir_.logs());
  const std::vector<pid_t> workers = wait_for_workers(batch, 2);
  ASSERT_EQ(workers.size(), 2u);
  ASSERT_EQ(::kill(batch, SIGINT), 0);
  const int status = wait_program(batch, 60);
  EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGINT) << status;
  for (const pid_t w : workers) EXPECT_TRUE(vanishes(w, 5.0)) << w << " state " << process_state(w);
  EXPECT_NE(read_text(dir_.logs() / "stderr").find("interrupted"), std::string::npos);
}

// The table's counts per backend are the report's; the trials' numbers equal
// solves of the same perturbed scenes in this process.
TEST_F(BatchProcesses, StressTableCountsAndNumbersEqualInProcessSolves) {
  const std::string data = (fs::path(TENSEGRITY_SOURCE_DIR) / "data").string();
  const std::string report = dir_.file("stress.json");
  const ProgramRun r = dir_.run({"stress-test", "--scenes", "prism-3", "--families", "noise", "--trials", "1",
                                 "--seed", "7", "--solvers", "alternating-gn,ipopt", "--jobs", "2", "--quiet",
                                 "--data", data, "--json", report},
                                600);
  ASSERT_TRUE(r.exit_status == 0) << r.err;
  const json j = json::parse(read_text(report));

  // backend trials converged stalled max_iterations time_limit numerical_error infeasible rejected crashed median_s
  std::istringstream table(r.out);
  std::string line;
  std::getline(table, line);
  EXPECT_EQ(line.rfind("backend", 0), 0u) << r.out;
  const std::vector<std::string> statuses = {"converged", "stalled", "max_iterations", "time_limit", "numerical_error",
                                             "infeasible"};
  int rows = 0;
  while (std::getline(table, line)) {
    std::istringstream words(line);
    std::string solver;
    int trials = 0;
    words >> solver >> trials;
    if (solver != "alternating-gn" && solver != "ipopt") continue;
    ++rows;
    SCOPED_TRACE(line);
    const json& overall = j["solvers"][solver]["overall"];
    EXPECT_EQ(trials, overall["trials"].get<int>());
    EXPECT_EQ(trials + overall["rejected_inputs"].get<int>(), 6);  // six noise levels, one trial each
    int sum = 0;
    for (const std::string& s : statuses) {
      int count = -1;
      words >> count;
      EXPECT_EQ(count, overall["statuses"].value(s, 0)) << s;
      sum += count;
    }
    EXPECT_EQ(sum, trials);
    int rejected = -1, crashed = -1;
    words >> rejected >> crashed;
    EXPECT_EQ(rejected, overall["rejected_inputs"].get<int>());
    EXPECT_EQ(crashed, 0);
  }
  EXPECT_EQ(rows, 2) << r.out;
  EXPECT_GE(j["solvers"]["alternating-gn"]["overall"]["converged"].get<int>(), 3);

  std::vector<scenes::BaseScene> bases = scenes::base_scenes(data);
  const scenes::BaseScene* prism = nullptr;
  for (const auto& b : bases)
    if (b.name == "prism-3") prism = &b;
  ASSERT_NE(prism, nullptr);
  const std::vector<scenes::FamilyLevel> levels = scenes::family_levels("noise");
  int compared = 0;
  for (const json& t : j["trials"]) {
    std::size_t level = 0;
    while (level < levels.size() && levels[level].label != t["level"].get<std::string>()) ++level;
    ASSERT_LT(level, levels.size());
    if (level > 2) continue;  // a few small levels suffice
    SCOPED_TRACE(t.dump());
    const Structure scene = scenes::make_family_case(prism->scene, "noise", static_cast<int>(level), 0, 7);
    SolveOptions options;
    options.time_limit_s = 20.0;
    const SolveResult mine = solve_scene(*make_solver(t["solver"].get<std::string>()), scene, options);
    EXPECT_EQ(t["status"], std::string(to_string(mine.status)));
    EXPECT_EQ(t["iterations"].get<int>(), mine.stats.iterations);
    EXPECT_EQ(t["geometry_change"].get<double>(), mine.stats.geometry_change);
    EXPECT_EQ(t["relative_residual"].get<double>(), verify(scene, mine.positions, mine.forces).relative_residual);
    ++compared;
  }
  EXPECT_EQ(compared, 6);  // three levels, two backends
}

}  // namespace
}  // namespace tensegrity
