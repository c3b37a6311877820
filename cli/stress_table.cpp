#include "cli/stress_test.hpp"

#include <algorithm>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

namespace tensegrity::cli {

void print_stress_table(const StressReport& report, std::FILE* out) {
  // Statuses in the order of docs/FORMATS.md, then the rest of the row.
  const Status columns[] = {Status::Converged, Status::Stalled, Status::MaxIterations, Status::TimeLimit,
                            Status::NumericalError, Status::Infeasible};
  struct Row {
    int trials = 0, rejected = 0, crashed = 0;
    std::map<Status, int> counts;
    std::vector<double> seconds;
  };
  std::map<std::string, Row> rows;
  for (const StressTrial& t : report.trials) {
    Row& r = rows[t.solver];
    if (t.rejected) {
      ++r.rejected;
      continue;
    }
    ++r.trials;
    ++r.counts[t.status];
    if (t.crashed) ++r.crashed;
    r.seconds.push_back(t.seconds);
  }
  std::fprintf(out, "%-16s %6s", "backend", "trials");
  for (const Status s : columns) std::fprintf(out, " %15s", std::string(to_string(s)).c_str());
  std::fprintf(out, " %8s %7s %10s\n", "rejected", "crashed", "median_s");
  for (auto& [solver, r] : rows) {
    std::fprintf(out, "%-16s %6d", solver.c_str(), r.trials);
    for (const Status s : columns) std::fprintf(out, " %15d", r.counts[s]);
    std::sort(r.seconds.begin(), r.seconds.end());
    double median = 0.0;
    if (!r.seconds.empty()) {
      const std::size_t n = r.seconds.size();
      median = n % 2 == 1 ? r.seconds[n / 2] : 0.5 * (r.seconds[n / 2 - 1] + r.seconds[n / 2]);
    }
    std::fprintf(out, " %8d %7d %10.4f\n", r.rejected, r.crashed, median);
  }
  std::fprintf(out, "jobs %d: wall %.3f s, process CPU %.3f s (%.2f cores busy), sum of job wall times %.3f s\n",
               report.options.jobs, report.pool_wall_seconds, report.cpu_seconds,
               report.cpu_seconds / std::max(1e-9, report.pool_wall_seconds), report.sum_job_wall_seconds);
  if (report.serial_wall_seconds > 0.0)
    std::fprintf(out, "jobs 1: wall %.3f s\nmeasured speed-up (serial wall / parallel wall): %.2f\n",
                 report.serial_wall_seconds, report.serial_wall_seconds / std::max(1e-9, report.pool_wall_seconds));
  std::fprintf(out, "speed-up estimate (sum of job wall times / wall): %.2f\n",
               report.sum_job_wall_seconds / std::max(1e-9, report.pool_wall_seconds));
  if (!report.skipped.empty()) std::fprintf(out, "skipped %zu unreadable data files\n", report.skipped.size());
  std::fflush(out);
}

}  // namespace tensegrity::cli
