#include "cli/progress.hpp"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace tensegrity::cli {

double progress_delay() {
  const char* text = std::getenv("TENSEGRITY_PROGRESS_AFTER");
  if (text == nullptr || *text == '\0') return kDefaultProgressDelay;
  char* end = nullptr;
  const double seconds = std::strtod(text, &end);
  return *end == '\0' && std::isfinite(seconds) && seconds >= 0.0 ? seconds : kDefaultProgressDelay;
}

bool stderr_is_terminal() { return ::isatty(STDERR_FILENO) == 1; }

ProgressLine::ProgressLine(bool enabled, double delay_s)
    : enabled_(enabled), delay_s_(delay_s), start_(Clock::now()), last_(start_) {}

double ProgressLine::elapsed() const { return std::chrono::duration<double>(Clock::now() - start_).count(); }

bool ProgressLine::due() const {
  if (!enabled_) return false;
  const Clock::time_point now = Clock::now();
  if (std::chrono::duration<double>(now - start_).count() < delay_s_) return false;
  return !shown() || std::chrono::duration<double>(now - last_).count() >= kProgressInterval;
}

void ProgressLine::show(const char* text) {
  if (!enabled_) return;
  const int width = static_cast<int>(std::strlen(text));
  // Spaces over what is left of a longer previous text.
  std::fprintf(stderr, "\r%s%*s", text, width_ > width ? width_ - width : 0, "");
  std::fflush(stderr);
  width_ = width;
  last_ = Clock::now();
}

void ProgressLine::clear() {
  if (!shown()) return;
  std::fprintf(stderr, "\r%*s\r", width_, "");
  std::fflush(stderr);
  width_ = 0;
}

void ProgressLine::finish(const char* final_text) {
  if (!shown()) return;
  if (final_text != nullptr) show(final_text);
  std::fputc('\n', stderr);
  std::fflush(stderr);
  width_ = 0;
}

JobsProgress::JobsProgress(bool enabled, const char* command, const char* failures, std::size_t total,
                           std::size_t done)
    : enabled_(enabled),
      on_terminal_(stderr_is_terminal()),
      command_(command),
      failures_(failures),
      line_(enabled && on_terminal_),
      total_(total),
      done_(done) {}

void JobsProgress::job_ended(bool failed) {
  ++done_;
  if (failed) ++failed_;
  if (!enabled_ || total_ == 0) return;
  if (on_terminal_) {
    if (line_.due() || (done_ == total_ && line_.shown())) line_.show(text(false).c_str());
    return;
  }
  const int tenth = static_cast<int>(10 * done_ / total_);
  if (tenth > last_tenth_) {
    last_tenth_ = tenth;
    std::fprintf(stderr, "%s\n", text(true).c_str());
    std::fflush(stderr);
  }
}

void JobsProgress::tick() {
  if (line_.due()) line_.show(text(false).c_str());
}

std::string JobsProgress::text(bool with_percent) const {
  char percent[24] = "";
  if (with_percent) std::snprintf(percent, sizeof percent, " (%d %%)", static_cast<int>(100 * done_ / total_));
  char t[256];
  std::snprintf(t, sizeof t, "%s: %zu/%zu solves done%s, %zu %s, %.1f s", command_, done_, total_, percent, failed_,
                failures_, line_.elapsed());
  return t;
}

}  // namespace tensegrity::cli
