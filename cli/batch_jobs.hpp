#pragma once
// The report of `tensegrity batch` (its solves: workers/solve_jobs.hpp): a
// text table and one JSON object (format
// "tensegrity-batch-report", docs/FORMATS.md, docs/schemas/batch-report.schema.json).
#include <cstdio>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "workers/solve_jobs.hpp"

namespace tensegrity::cli {

struct BatchReport {
  const std::vector<SolveJob>* jobs = nullptr;
  const SolveJobsRun* run = nullptr;
  const SolveJobsRun* serial = nullptr;  // the one-worker reference, when measured
  const SolveJobSettings* settings = nullptr;
  int workers = 1;
  std::vector<std::pair<std::string, std::string>> skipped;  // unreadable file, reason
};

// One line per job, then the summary (wall and CPU time, speed-up, counts).
void print_batch_table(const BatchReport& report, std::FILE* out, bool with_solver_column);
nlohmann::json batch_report_to_json(const BatchReport& report);

}  // namespace tensegrity::cli
