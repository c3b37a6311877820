#pragma once
// The --prestress-factor option (kappa of Eq. 5 under gravity) of every
// command that solves, and its check, shared with the Python module so that
// both refuse the same values with the same words.
#include <cmath>

#include "formulations/force_scale.hpp"
#include "model/errors.hpp"

namespace CLI {
class App;
}  // namespace CLI

namespace tensegrity::cli {

inline constexpr const char* kPrestressFactorFlag = "--prestress-factor";

// Adds --prestress-factor to `command`, stored in `*kappa` (which starts at
// kDefaultPrestressFactor); the value is checked by checked_prestress_factor.
void add_prestress_factor_option(CLI::App& command, double* kappa);

// `kappa` when it is finite and > 0; else InputError naming the flag and the range.
inline double checked_prestress_factor(double kappa) {
  if (!(std::isfinite(kappa) && kappa > 0.0))
    throw InputError("command line", kPrestressFactorFlag, "must be a finite number > 0");
  return kappa;
}

}  // namespace tensegrity::cli
