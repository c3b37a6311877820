#pragma once
// Runs the real `tensegrity` program from a test, the way a user does: through
// the shell, under `timeout` (a hang fails instead of blocking the suite),
// with standard output and standard error captured in files.
//
//   tensegrity::testing::ScratchDir dir("cli-design");      // unique, removed at the end
//   ProgramRun r = run_program({"design", scene, "--out", dir.file("d.json")}, dir.logs());
//   EXPECT_EQ(r.exit_status, 2);
//   EXPECT_TRUE(is_one_line(r.err));
//   EXPECT_TRUE(dir.work_files().empty());
//
// A run that the test must watch or signal meanwhile starts in the background:
//
//   const pid_t pid = start_program({"batch", scene, "--jobs", "2"}, dir.logs());
//   ...                                                   // signal it, read /proc
//   const int status = wait_program(pid, 60);              // raw waitpid status
//
// Needs TENSEGRITY_BINARY (tests/CMakeLists.txt defines it).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace tensegrity::testing {

struct ProgramRun {
  int exit_status = -1;  // the program's exit status; 128 + signal when killed (124: timed out)
  std::string out, err;  // everything written to standard output / standard error
};

inline std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

inline std::string shell_quoted(const std::string& s) {
  std::string out = "'";
  for (const char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

// Exactly one line, ending in a newline.
inline bool is_one_line(const std::string& text) {
  return !text.empty() && text.find('\n') == text.size() - 1;
}

// `tensegrity ARGS...` with stdout and stderr captured in `logs_dir`
// (overwritten on every call), killed after `time_limit_s` seconds.
inline ProgramRun run_program(const std::vector<std::string>& args, const std::filesystem::path& logs_dir,
                              int time_limit_s = 120) {
  // Appended piece by piece: GCC 12 warns falsely (-Wrestrict) on "literal" + string.
  std::string command = "timeout ";
  command += std::to_string(time_limit_s);
  command += ' ';
  command += shell_quoted(TENSEGRITY_BINARY);
  for (const std::string& a : args) {
    command += ' ';
    command += shell_quoted(a);
  }
  command += " </dev/null >";  // no command reads stdin; a stray read must not block
  command += shell_quoted((logs_dir / "stdout").string());
  command += " 2>";
  command += shell_quoted((logs_dir / "stderr").string());
  const int raw = std::system(command.c_str());
  ProgramRun r;
  r.exit_status = WIFEXITED(raw) ? WEXITSTATUS(raw) : 128 + WTERMSIG(raw);
  r.out = read_text(logs_dir / "stdout");
  r.err = read_text(logs_dir / "stderr");
  return r;
}

// `tensegrity ARGS...` started in the background (no shell, no `timeout`, so
// the pid is the program's own), stdout and stderr into files in `logs_dir`.
inline pid_t start_program(const std::vector<std::string>& args, const std::filesystem::path& logs_dir) {
  std::vector<std::string> all = {TENSEGRITY_BINARY};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  const std::string out = (logs_dir / "stdout").string(), err = (logs_dir / "stderr").string();
  const pid_t pid = ::fork();
  if (pid == 0) {
    const int o = ::open(out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int e = ::open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    ::dup2(o, 1);
    ::dup2(e, 2);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  return pid;
}

// waitpid with a limit; a program still running then is killed (and the test fails).
inline int wait_program(pid_t pid, double limit_s) {
  const auto t0 = std::chrono::steady_clock::now();
  for (;;) {
    int status = 0;
    if (::waitpid(pid, &status, WNOHANG) == pid) return status;
    if (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() > limit_s) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, &status, 0);
      ADD_FAILURE() << "program still running after " << limit_s << " s";
      return status;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}

// A fresh pair of folders under the system temp folder: work() for the files
// a test writes and expects, logs() for captured output (kept apart so that
// "no output file was written" can be checked by listing work()). Both are
// removed by the destructor.
class ScratchDir {
 public:
  explicit ScratchDir(const std::string& name) {
    static std::atomic<int> counter{0};
    const std::string base = (std::filesystem::temp_directory_path() /
                              ("tensegrity-" + name + "-" + std::to_string(::getpid()) + "-" + std::to_string(counter++)))
                                 .string();
    work_ = base + "-work";
    logs_ = base + "-logs";
    std::filesystem::remove_all(work_);
    std::filesystem::remove_all(logs_);
    std::filesystem::create_directories(work_);
    std::filesystem::create_directories(logs_);
  }
  ~ScratchDir() {
    std::error_code ec;
    std::filesystem::remove_all(work_, ec);
    std::filesystem::remove_all(logs_, ec);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;

  const std::filesystem::path& work() const { return work_; }
  const std::filesystem::path& logs() const { return logs_; }
  std::string file(const std::string& name) const { return (work_ / name).string(); }
  // Names of the files in work(), sorted.
  std::vector<std::string> work_files() const {
    std::vector<std::string> names;
    for (const auto& entry : std::filesystem::directory_iterator(work_)) names.push_back(entry.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
  }
  ProgramRun run(const std::vector<std::string>& args, int time_limit_s = 120) const {
    return run_program(args, logs_, time_limit_s);
  }

 private:
  std::filesystem::path work_, logs_;
};

}  // namespace tensegrity::testing
