#include "solvers/solver.hpp"

#include <cmath>

#include "solvers/options_parsing.hpp"

namespace tensegrity {

bool SolveOptions::IsValid(std::string* why) const {
  auto fail = [&](const char* reason) {
    if (why) *why = reason;
    return false;
  };
  if (!(std::isfinite(tolerance) && tolerance > 0.0)) return fail("tolerance must be a finite number > 0");
  if (max_iterations < 0) return fail("max_iterations must be >= 0 (0: the backend's default)");
  if (!(time_limit_s > 0.0) || std::isnan(time_limit_s)) return fail("time_limit_s must be > 0");
  if (!(std::isfinite(margin_fraction) && margin_fraction > 0.0 && margin_fraction < 1.0))
    return fail("margin_fraction must be in (0, 1)");
  return true;
}

void Solver::check_options(const SolveOptions& options) const {
  BackendOptionReader reader(options.backend_options);
  reader.reject_unknown(std::string(name()));
}

}  // namespace tensegrity
