#pragma once
// Wall clock and trace for a backend: records TracePoints and answers whether
// the time budget is spent.
//
// Every record also goes to the iteration observer installed on the recording
// thread (ScopedIterationObserver, which the driver sets around each part's
// DoSolve), so that progress reaches the caller through the one recording
// path that every backend already has, without plumbing through the backends.
#include <chrono>
#include <functional>
#include <vector>

#include "solvers/solver.hpp"

namespace tensegrity {

using IterationObserver = std::function<void(const TracePoint&)>;

// The observer of this thread (null: none).
inline const IterationObserver*& current_iteration_observer() {
  thread_local const IterationObserver* observer = nullptr;
  return observer;
}

// Installs `observer` on this thread for its lifetime (null: none), then
// restores the previous one.
class ScopedIterationObserver {
 public:
  explicit ScopedIterationObserver(const IterationObserver* observer) : previous_(current_iteration_observer()) {
    current_iteration_observer() = observer;
  }
  ~ScopedIterationObserver() { current_iteration_observer() = previous_; }
  ScopedIterationObserver(const ScopedIterationObserver&) = delete;
  ScopedIterationObserver& operator=(const ScopedIterationObserver&) = delete;

 private:
  const IterationObserver* previous_;
};

class TraceRecorder {
 public:
  explicit TraceRecorder(double time_limit_s)
      : start_(std::chrono::steady_clock::now()),
        time_limit_s_(time_limit_s),
        observer_(current_iteration_observer()) {}
  double seconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }
  bool out_of_time() const { return seconds() > time_limit_s_; }
  void record(TracePoint p) {
    p.seconds = seconds();
    p.iteration += count_offset_;
    p.evaluations += count_offset_;
    trace_.push_back(p);
    if (observer_ != nullptr && *observer_) (*observer_)(trace_.back());
  }
  std::vector<TracePoint>& trace() { return trace_; }
  // Added to the iteration and evaluation counts of every later record: a
  // run that counts from zero continues an earlier run's trace (and its live
  // progress) where that one ended.
  void set_count_offset(int offset) { count_offset_ = offset; }

 private:
  std::chrono::steady_clock::time_point start_;
  double time_limit_s_;
  const IterationObserver* observer_;  // captured at construction: the part's observer
  std::vector<TracePoint> trace_;
  int count_offset_ = 0;
};

}  // namespace tensegrity
