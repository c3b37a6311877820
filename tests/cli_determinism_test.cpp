// Determinism: the same input and options give bit-identical
// solution files run to run, with one or two batch jobs, and with one or two
// OpenBLAS threads. Compared byte for byte except the value of `stats.seconds`,
// the one wall-clock field of a solution file (docs/FORMATS.md); every other number
// is written in its shortest round-trip form, so equal text means equal bits.
#include <gtest/gtest.h>
#include <stdlib.h>

#include <filesystem>
#include <cstdlib>
#include <optional>
#include <string>
#include <vector>

#include "model/scene_io.hpp"
#include "process_runner.hpp"
#include "scenes/suites.hpp"
#include "solvers/solver.hpp"

namespace tensegrity {
namespace {

namespace fs = std::filesystem;

using testing::read_text;

// The file with the wall-clock time replaced by a fixed token; fails the test
// when the field is missing, so the masking cannot silently hide everything.
std::string without_seconds(std::string text) {
  const std::string key = "\"seconds\": ";
  const std::size_t at = text.find(key);
  EXPECT_NE(at, std::string::npos) << text.substr(0, 300);
  EXPECT_EQ(text.find(key, at + 1), std::string::npos) << "more than one seconds field";
  if (at == std::string::npos) return text;
  const std::size_t begin = at + key.size();
  const std::size_t end = text.find_first_not_of("0123456789.eE+-", begin);
  EXPECT_GT(end, begin) << "no number after " << key;
  return text.replace(begin, end - begin, "T");
}

class CliDeterminism : public ::testing::Test {
 protected:
  std::string write_scene(const Structure& s) {
    const std::string path = dir_.file(s.name + ".scene.json");
    write_scene_file(s, path);
    return path;
  }
  // Exit status of the program; its stderr is kept for the failure message.
  int run(const std::vector<std::string>& args) {
    const testing::ProgramRun r = dir_.run(args, 600);
    last_err_ = r.err;
    return r.exit_status;
  }
  testing::ScratchDir dir_{"determinism"};
  std::string last_err_;
};

// Sets an environment variable for the programs this test starts, restored afterwards.
class ScopedEnv {
 public:
  ScopedEnv(const char* name, const std::string& value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old;
    ::setenv(name, value.c_str(), 1);
  }
  ~ScopedEnv() {
    if (old_)
      ::setenv(name_, old_->c_str(), 1);
    else
      ::unsetenv(name_);
  }

 private:
  const char* name_;
  std::optional<std::string> old_;
};

// Perturbed so that every backend iterates (an exact tensegrity returns at once).
std::vector<Structure> scenes() {
  return {scenes::perturbed(scenes::prism(5), 0.05, 3u), scenes::perturbed(scenes::prism(4, 0.0, true), 0.05, 7u),
          scenes::perturbed(scenes::octahedron(), 0.03, 11u)};
}

TEST_F(CliDeterminism, EveryBackendGivesTheSameFileTwice) {
  const std::string scene = write_scene(scenes()[1]);
  for (const std::string& name : solver_names()) {
    std::string first;
    for (int attempt = 0; attempt < 2; ++attempt) {
      const fs::path out = dir_.work() / (name + "-" + std::to_string(attempt) + ".solution.json");
      const int status = run({"solve", scene, "--solver", name, "--out", out.string()});
      ASSERT_TRUE(status == 0 || status == 1) << name << ": " << last_err_;
      const std::string text = without_seconds(read_text(out));
      ASSERT_NE(text.find("\"forces\""), std::string::npos) << name;
      if (attempt == 0)
        first = text;
      else
        EXPECT_EQ(text, first) << name << ": two runs on " << scene << " differ";
    }
  }
}

TEST_F(CliDeterminism, BatchWithOneOrTwoJobsGivesTheSameFiles) {
  std::vector<std::string> paths;
  for (const Structure& s : scenes()) paths.push_back(write_scene(s));
  for (const std::string& name : solver_names()) {
    std::vector<std::string> texts;
    for (const int jobs : {1, 2}) {
      const fs::path out = dir_.work() / (name + "-jobs" + std::to_string(jobs));
      std::vector<std::string> args = {"batch"};
      args.insert(args.end(), paths.begin(), paths.end());
      args.insert(args.end(), {"--solver", name, "--jobs", std::to_string(jobs), "--out-dir", out.string()});
      const int status = run(args);
      ASSERT_TRUE(status == 0 || status == 1) << name << ": " << last_err_;
      std::string all;
      for (const Structure& s : scenes()) {
        const fs::path file = out / (s.name + ".solution.json");
        ASSERT_TRUE(fs::exists(file)) << file;
        all += without_seconds(read_text(file));
      }
      texts.push_back(all);
    }
    EXPECT_EQ(texts[0], texts[1]) << name << ": batch --jobs 1 and --jobs 2 differ";
  }
}

// MUMPS (under Ipopt) calls the BLAS; a threaded BLAS may sum in another order.
TEST_F(CliDeterminism, OneOrTwoBlasThreadsGiveTheSameFile) {
  const std::string scene = write_scene(scenes()[0]);
  for (const std::string& name : solver_names()) {
    std::vector<std::string> texts;
    for (const char* threads : {"1", "2"}) {
      const fs::path out = dir_.work() / (name + "-blas" + threads + ".solution.json");
      const ScopedEnv blas("OPENBLAS_NUM_THREADS", threads), omp("OMP_NUM_THREADS", threads);
      const int status = run({"solve", scene, "--solver", name, "--out", out.string()});
      ASSERT_TRUE(status == 0 || status == 1) << name << ": " << last_err_;
      texts.push_back(without_seconds(read_text(out)));
    }
    EXPECT_EQ(texts[0], texts[1]) << name << ": 1 and 2 BLAS threads differ";
  }
}

}  // namespace
}  // namespace tensegrity
