#pragma once
// The outcome of a solve, shared by every backend and written to solution files.
#include <optional>
#include <string_view>

namespace tensegrity {

enum class Status {
  Converged,       // relative residual <= tolerance, every sign correct, all finite
  MaxIterations,   // the iteration budget ran out
  Infeasible,      // proven: no admissible configuration exists (see the solution format)
  NumericalError,  // a factorization or evaluation failed, or a result failed verification
  TimeLimit,       // the time budget ran out
  Stalled,         // no progress and no proof of infeasibility
};

std::string_view to_string(Status s);
std::optional<Status> status_from_string(std::string_view s);

}  // namespace tensegrity
