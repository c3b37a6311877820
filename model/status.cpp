#include "model/status.hpp"

#include <array>
#include <utility>

namespace tensegrity {

namespace {

// The strings of the solution file format (docs/FORMATS.md); never change them.
constexpr std::array<std::pair<Status, std::string_view>, 6> kStatusNames = {{
    {Status::Converged, "converged"},
    {Status::MaxIterations, "max_iterations"},
    {Status::Infeasible, "infeasible"},
    {Status::NumericalError, "numerical_error"},
    {Status::TimeLimit, "time_limit"},
    {Status::Stalled, "stalled"},
}};

}  // namespace

std::string_view to_string(Status s) {
  for (const auto& [status, name] : kStatusNames)
    if (status == s) return name;
  return "numerical_error";
}

std::optional<Status> status_from_string(std::string_view s) {
  for (const auto& [status, name] : kStatusNames)
    if (name == s) return status;
  return std::nullopt;
}

}  // namespace tensegrity
