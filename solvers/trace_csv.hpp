#pragma once
// The per-iteration record as CSV (the format of `tensegrity solve --trace`):
// seconds,iteration,evaluations,residual,relative_residual,geometry_change,objective
// one row per TracePoint, 17 significant digits; written atomically.
#include <string>
#include <vector>

#include "solvers/solver.hpp"

namespace tensegrity {

void write_trace_csv(const std::string& path, const std::vector<TracePoint>& trace);

}  // namespace tensegrity
