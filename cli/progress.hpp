#pragma once
// A status line on standard error for long runs, rewritten in place with a
// carriage return: shown only when enabled (standard error is a terminal and
// the user did not ask for --quiet), only after a delay, so that short runs
// print nothing extra, and at most a few times per second.
#include <chrono>
#include <cstddef>
#include <string>

namespace tensegrity::cli {

// Seconds before a status line appears, unless TENSEGRITY_PROGRESS_AFTER
// holds a number >= 0 (tests use 0).
inline constexpr double kDefaultProgressDelay = 2.0;  // s
// Shortest time between two updates of the line.
inline constexpr double kProgressInterval = 0.25;  // s

double progress_delay();
bool stderr_is_terminal();

class ProgressLine {
 public:
  // Shows nothing unless `enabled`.
  explicit ProgressLine(bool enabled, double delay_s = progress_delay());
  ~ProgressLine() { finish(); }
  ProgressLine(const ProgressLine&) = delete;
  ProgressLine& operator=(const ProgressLine&) = delete;

  // True when an update would be shown now (one clock read): enabled, past
  // the delay and past the interval since the last update.
  bool due() const;
  double elapsed() const;  // s since construction
  bool shown() const { return width_ > 0; }
  // Writes `text` over the line shown before.
  void show(const char* text);
  // Blanks the line so that an ordinary line can be printed; the next show()
  // draws it again.
  void clear();
  // Ends a shown line with a newline, after showing `final_text` if given;
  // nothing when no line was shown.
  void finish(const char* final_text = nullptr);

 private:
  using Clock = std::chrono::steady_clock;
  bool enabled_;
  double delay_s_;
  Clock::time_point start_;
  Clock::time_point last_;
  int width_ = 0;  // characters on the line now
};

// How far a run of independent jobs is (`batch`, `stress-test`), on standard
// error: a ProgressLine on a terminal,
//   COMMAND: 12/62 solves done, 1 FAILURES, 14.2 s
// else a line at every tenth of the jobs, with the percentage done,
//   COMMAND: 31/62 solves done (50 %), 1 FAILURES, 20.4 s
// and nothing when not enabled (--quiet).
class JobsProgress {
 public:
  // `failures` names what the second count counts ("failed"); `done` jobs
  // count as done from the start (not run at all).
  JobsProgress(bool enabled, const char* command, const char* failures, std::size_t total, std::size_t done = 0);
  void job_ended(bool failed);
  // While waiting for jobs: keeps the time on the status line current.
  void tick();
  // Ends a shown status line with a newline, so that what follows starts a line of its own.
  void finish() { line_.finish(); }

 private:
  std::string text(bool with_percent) const;

  bool enabled_, on_terminal_;
  const char* command_;
  const char* failures_;
  ProgressLine line_;
  std::size_t total_, done_, failed_ = 0;
  int last_tenth_ = 0;
};

}  // namespace tensegrity::cli
