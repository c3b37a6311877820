#include "workers/process_pool.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sched.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <exception>
#include <map>
#include <numeric>
#include <stdexcept>

namespace tensegrity {

namespace process_pool_detail {

using Clock = std::chrono::steady_clock;

// A message from a worker: tag, payload length (8 bytes), payload.
constexpr char kResultTag = 'R';
constexpr char kExceptionTag = 'E';
constexpr std::size_t kHeaderBytes = 1 + sizeof(std::uint64_t);
constexpr int kStopSignals[] = {SIGINT, SIGTERM, SIGHUP};

// Written by the signal handler, read by the coordinator's poll loop.
volatile sig_atomic_t signal_pipe_write_end = -1;

extern "C" void forward_stop_signal(int signal_number) {
  const int saved = errno;
  const unsigned char byte = static_cast<unsigned char>(signal_number);
  if (signal_pipe_write_end >= 0) {
    [[maybe_unused]] const ssize_t n = ::write(signal_pipe_write_end, &byte, 1);
  }
  errno = saved;
}

double cpu_seconds_of(int who) {
  rusage u{};
  ::getrusage(who, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

bool write_all(int fd, const void* data, std::size_t size) {
  const char* p = static_cast<const char*>(data);
  while (size > 0) {
    const ssize_t n = ::send(fd, p, size, MSG_NOSIGNAL);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    p += n;
    size -= static_cast<std::size_t>(n);
  }
  return true;
}

bool read_all(int fd, void* data, std::size_t size) {
  char* p = static_cast<char*>(data);
  while (size > 0) {
    const ssize_t n = ::read(fd, p, size);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    p += n;
    size -= static_cast<std::size_t>(n);
  }
  return true;
}

// The worker's life: job numbers in, results out, until the coordinator
// closes the channel. Never returns.
[[noreturn]] void serve_jobs(int fd, const std::function<std::string(std::size_t)>& job) {
  for (;;) {
    std::uint64_t index = 0;
    if (!read_all(fd, &index, sizeof index)) ::_exit(0);
    char tag = kResultTag;
    std::string payload;
    try {
      payload = job(static_cast<std::size_t>(index));
    } catch (const std::exception& e) {
      tag = kExceptionTag;
      payload = e.what();
    } catch (...) {
      tag = kExceptionTag;
      payload = "unknown exception";
    }
    const std::uint64_t size = payload.size();
    if (!write_all(fd, &tag, 1) || !write_all(fd, &size, sizeof size) || !write_all(fd, payload.data(), payload.size()))
      ::_exit(1);
  }
}

std::string describe_wait_status(int status) {
  if (WIFSIGNALED(status)) {
    const int s = WTERMSIG(status);
    return "worker process killed by signal " + std::to_string(s) + " (" + ::strsignal(s) + ")";
  }
  if (WIFEXITED(status)) return "worker process exited with status " + std::to_string(WEXITSTATUS(status));
  return "worker process ended";
}

pid_t reap(pid_t pid, int* status) {
  for (;;) {
    const pid_t r = ::waitpid(pid, status, 0);
    if (r >= 0 || errno != EINTR) return r;
  }
}

struct Worker {
  pid_t pid = -1;
  int fd = -1;
  long job = -1;  // the job it runs, -1 when idle
  Clock::time_point started;
  std::string inbox;
};

class Coordinator {
 public:
  Coordinator(std::size_t total, const std::function<std::string(std::size_t)>& job, const ProcessPoolOptions& options)
      : job_(job), options_(options) {
    outcomes_.resize(total);
  }

  ~Coordinator() {
    stop_all_workers();
    restore_signals();
  }

  ProcessPoolRun run(const std::vector<std::size_t>& order) {
    install_signals();
    const double cpu0 = cpu_seconds_of(RUSAGE_SELF) + cpu_seconds_of(RUSAGE_CHILDREN);
    const auto t0 = Clock::now();
    queue_.assign(order.begin(), order.end());
    const std::size_t total = outcomes_.size();
    const int wanted = static_cast<int>(std::min<std::size_t>(std::max(1, options_.workers), queue_.size()));
    for (int k = 0; k < wanted; ++k)
      if (!start_worker()) break;
    if (workers_.empty()) fail_remaining("cannot start a worker process: " + std::string(std::strerror(errno)));
    for (Worker& w : workers_) hand_out(w);
    retire_idle_workers();

    while (ended_ < total) {
      poll_once();
      if (options_.on_tick) options_.on_tick();
      check_deadlines();
      retire_idle_workers();
      if (workers_.empty() && !queue_.empty()) {
        if (!start_worker()) {
          fail_remaining("cannot start a worker process: " + std::string(std::strerror(errno)));
        } else {
          hand_out(workers_.back());
        }
      }
    }
    ProcessPoolRun run;
    run.wall_seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    stop_all_workers();
    run.cpu_seconds = cpu_seconds_of(RUSAGE_SELF) + cpu_seconds_of(RUSAGE_CHILDREN) - cpu0;
    run.outcomes = std::move(outcomes_);
    restore_signals();
    return run;
  }

 private:
  void install_signals() {
    int fds[2];
    if (::pipe2(fds, O_CLOEXEC | O_NONBLOCK) != 0) throw std::runtime_error("cannot create a pipe for signals");
    signal_read_ = fds[0];
    signal_pipe_write_end = fds[1];
    struct sigaction action {};
    action.sa_handler = forward_stop_signal;
    sigemptyset(&action.sa_mask);
    action.sa_flags = SA_RESTART;
    for (const int s : kStopSignals) {
      struct sigaction old {};
      ::sigaction(s, &action, &old);
      saved_actions_[s] = old;
    }
    struct sigaction ignore {};
    ignore.sa_handler = SIG_IGN;
    sigemptyset(&ignore.sa_mask);
    struct sigaction old {};
    ::sigaction(SIGPIPE, &ignore, &old);
    saved_actions_[SIGPIPE] = old;
  }

  void restore_signals() {
    for (const auto& [s, old] : saved_actions_) ::sigaction(s, &old, nullptr);
    saved_actions_.clear();
    if (signal_pipe_write_end >= 0) {
      ::close(signal_pipe_write_end);
      signal_pipe_write_end = -1;
    }
    if (signal_read_ >= 0) {
      ::close(signal_read_);
      signal_read_ = -1;
    }
  }

  // Forks one worker; false (errno set) when the system refuses.
  bool start_worker() {
    int channel[2];
    if (::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, channel) != 0) return false;
    std::fflush(nullptr);  // nothing buffered is written twice
    const pid_t coordinator = ::getpid();
    const pid_t pid = ::fork();
    if (pid < 0) {
      const int saved = errno;
      ::close(channel[0]);
      ::close(channel[1]);
      errno = saved;
      return false;
    }
    if (pid == 0) {
      for (const int s : kStopSignals) ::signal(s, SIG_DFL);
      ::signal(SIGPIPE, SIG_DFL);
      // A worker never outlives its coordinator, however that ends.
      ::prctl(PR_SET_PDEATHSIG, SIGKILL);
      if (::getppid() != coordinator) ::_exit(0);
      ::close(channel[0]);
      ::close(signal_read_);
      ::close(signal_pipe_write_end);
      for (const Worker& w : workers_) ::close(w.fd);  // else they would not see their end of input
      serve_jobs(channel[1], job_);
    }
    ::close(channel[1]);
    Worker w;
    w.pid = pid;
    w.fd = channel[0];
    workers_.push_back(std::move(w));
    return true;
  }

  void hand_out(Worker& w) {
    while (w.job < 0 && !queue_.empty()) {
      const std::size_t index = queue_.front();
      queue_.pop_front();
      w.job = static_cast<long>(index);
      w.started = Clock::now();
      w.inbox.clear();
      const std::uint64_t wire = index;
      if (!write_all(w.fd, &wire, sizeof wire)) {
        // The worker is gone already; the poll loop reaps it and reports this job.
        return;
      }
    }
  }

  void end_job(Worker& w, JobEnd end, std::string result, std::string reason) {
    JobOutcome& o = outcomes_[static_cast<std::size_t>(w.job)];
    o.end = end;
    o.result = std::move(result);
    o.reason = std::move(reason);
    o.wall_seconds = std::chrono::duration<double>(Clock::now() - w.started).count();
    w.inbox.clear();
    ++ended_;
    if (options_.on_job_end) options_.on_job_end(static_cast<std::size_t>(w.job), o);
    w.job = -1;
  }

  void fail_remaining(const std::string& reason) {
    while (!queue_.empty()) {
      const std::size_t index = queue_.front();
      queue_.pop_front();
      JobOutcome& o = outcomes_[index];
      o.end = JobEnd::Crashed;
      o.reason = reason;
      ++ended_;
      if (options_.on_job_end) options_.on_job_end(index, o);
    }
  }

  // Removes worker k (already dead or to be killed) and reaps it; a job it
  // was running ends as `end`, and a replacement takes over the queue.
  void remove_worker(std::size_t k, JobEnd end, const std::string& why_if_killed) {
    Worker& w = workers_[k];
    if (end == JobEnd::Killed) ::kill(w.pid, SIGKILL);
    ::close(w.fd);
    int status = 0;
    const pid_t reaped = reap(w.pid, &status);
    if (w.job >= 0)
      end_job(w, end, "", end == JobEnd::Killed ? why_if_killed
                                                : (reaped > 0 ? describe_wait_status(status) : "worker process lost"));
    workers_.erase(workers_.begin() + static_cast<std::ptrdiff_t>(k));
    if (!queue_.empty() && start_worker()) hand_out(workers_.back());
  }

  // Takes a whole message out of the inbox, if there is one.
  void take_message(Worker& w) {
    if (w.inbox.size() < kHeaderBytes) return;
    std::uint64_t size = 0;
    std::memcpy(&size, w.inbox.data() + 1, sizeof size);
    if (w.inbox.size() < kHeaderBytes + size) return;
    const char tag = w.inbox[0];
    std::string payload = w.inbox.substr(kHeaderBytes, size);
    if (tag == kResultTag)
      end_job(w, JobEnd::Finished, std::move(payload), "");
    else
      end_job(w, JobEnd::Crashed, "", "exception in the worker: " + payload);
    hand_out(w);
  }

  int poll_timeout_ms() const {
    const int deadline_ms = deadline_timeout_ms();
    if (!options_.on_tick) return deadline_ms;
    const int tick_ms = std::max(1, static_cast<int>(std::ceil(options_.tick_interval_s * 1000.0)));
    return deadline_ms < 0 ? tick_ms : std::min(deadline_ms, tick_ms);
  }

  // Until the soonest deadline of a running job; -1 (wait indefinitely) when none.
  int deadline_timeout_ms() const {
    if (options_.kill_after_s <= 0.0) return -1;
    bool any_busy = false;
    double soonest = 0.0;
    const auto now = Clock::now();
    for (const Worker& w : workers_) {
      if (w.job < 0) continue;
      const double left = options_.kill_after_s - std::chrono::duration<double>(now - w.started).count();
      soonest = any_busy ? std::min(soonest, left) : left;
      any_busy = true;
    }
    if (!any_busy) return -1;
    return soonest <= 0.0 ? 0 : static_cast<int>(std::ceil(soonest * 1000.0)) + 1;
  }

  void poll_once() {
    std::vector<pollfd> fds;
    fds.push_back({signal_read_, POLLIN, 0});
    for (const Worker& w : workers_) fds.push_back({w.fd, POLLIN, 0});
    const int ready = ::poll(fds.data(), fds.size(), poll_timeout_ms());
    if (ready < 0) {
      if (errno == EINTR) return;
      throw std::runtime_error(std::string("poll: ") + std::strerror(errno));
    }
    if (fds[0].revents != 0) stop_by_signal();
    // Backwards, so that removing a worker keeps the earlier indices valid.
    for (std::size_t k = workers_.size(); k-- > 0;) {
      if (fds[k + 1].revents == 0) continue;
      Worker& w = workers_[k];
      char buffer[1 << 16];
      const ssize_t n = ::read(w.fd, buffer, sizeof buffer);
      if (n < 0 && errno == EINTR) continue;
      if (n > 0) {
        w.inbox.append(buffer, static_cast<std::size_t>(n));
        take_message(w);
      } else {
        remove_worker(k, JobEnd::Crashed, "");
      }
    }
  }

  void check_deadlines() {
    if (options_.kill_after_s <= 0.0) return;
    const auto now = Clock::now();
    for (std::size_t k = workers_.size(); k-- > 0;) {
      const Worker& w = workers_[k];
      if (w.job < 0 || std::chrono::duration<double>(now - w.started).count() < options_.kill_after_s) continue;
      char why[160];
      std::snprintf(why, sizeof why, "still running after %.3g s: worker process killed", options_.kill_after_s);
      remove_worker(k, JobEnd::Killed, why);
    }
  }

  // Workers with nothing left to do get end of input and exit.
  void retire_idle_workers() {
    if (!queue_.empty()) return;
    for (std::size_t k = workers_.size(); k-- > 0;) {
      Worker& w = workers_[k];
      if (w.job >= 0) continue;
      ::close(w.fd);
      int status = 0;
      reap(w.pid, &status);
      workers_.erase(workers_.begin() + static_cast<std::ptrdiff_t>(k));
    }
  }

  void stop_all_workers() {
    for (Worker& w : workers_) {
      ::kill(w.pid, SIGKILL);
      ::close(w.fd);
    }
    for (Worker& w : workers_) {
      int status = 0;
      reap(w.pid, &status);
    }
    workers_.clear();
  }

  [[noreturn]] void stop_by_signal() {
    unsigned char byte = SIGINT;
    [[maybe_unused]] const ssize_t n = ::read(signal_read_, &byte, 1);
    const std::size_t stopped = workers_.size();
    stop_all_workers();
    restore_signals();
    std::fprintf(stderr, "tensegrity: interrupted by signal %d (%s): %zu worker processes stopped\n", byte,
                 ::strsignal(byte), stopped);
    std::fflush(nullptr);
    // Ending by the same signal tells a calling shell that the run was interrupted.
    ::signal(byte, SIG_DFL);
    ::raise(byte);
    ::_exit(128 + byte);
  }

  const std::function<std::string(std::size_t)>& job_;
  const ProcessPoolOptions& options_;
  std::vector<JobOutcome> outcomes_;
  std::deque<std::size_t> queue_;
  std::vector<Worker> workers_;
  std::size_t ended_ = 0;
  int signal_read_ = -1;
  std::map<int, struct sigaction> saved_actions_;
};

}  // namespace process_pool_detail

ProcessPoolRun run_in_worker_processes(std::size_t total, const std::vector<std::size_t>& order,
                                       const std::function<std::string(std::size_t)>& job,
                                       const ProcessPoolOptions& options) {
  if (order.size() != total) throw std::logic_error("run_in_worker_processes: order must list every job once");
  process_pool_detail::Coordinator coordinator(total, job, options);
  return coordinator.run(order);
}

int available_cores() {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (::sched_getaffinity(0, sizeof set, &set) == 0) return std::max(1, CPU_COUNT(&set));
  const long online = ::sysconf(_SC_NPROCESSORS_ONLN);
  return online > 0 ? static_cast<int>(online) : 1;
}

std::vector<std::size_t> longest_first(const std::vector<double>& estimated_cost) {
  std::vector<std::size_t> order(estimated_cost.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return estimated_cost[a] > estimated_cost[b]; });
  return order;
}

double estimated_solve_cost(const std::string& backend, int elements) {
  // CPU time per element relative to alternating-gn, rounded from the
  // benchmark tables (docs/BENCHMARKS.md): only the order of the jobs uses it.
  static const std::map<std::string, double> kFactor = {
      {"alternating-gn", 1.0}, {"ipopt", 20.0}, {"alternating", 60.0}, {"nlopt", 60.0}};
  const auto it = kFactor.find(backend);
  return (it == kFactor.end() ? 20.0 : it->second) * std::max(1, elements);
}

}  // namespace tensegrity
