#pragma once
// Wall clock and trace for a backend: records TracePoints and answers whether
// the time budget is spent.
#include <chrono>
#include <vector>

#include "solvers/solver.hpp"

namespace tensegrity {

class TraceRecorder {
 public:
  explicit TraceRecorder(double time_limit_s)
      : start_(std::chrono::steady_clock::now()), time_limit_s_(time_limit_s) {}
  double seconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }
  bool out_of_time() const { return seconds() > time_limit_s_; }
  void record(TracePoint p) {
    p.seconds = seconds();
    trace_.push_back(p);
  }
  std::vector<TracePoint>& trace() { return trace_; }

 private:
  std::chrono::steady_clock::time_point start_;
  double time_limit_s_;
  std::vector<TracePoint> trace_;
};

}  // namespace tensegrity
