#pragma once
// The check of kappa (Eq. 5's prestress cap under gravity, --prestress-factor),
// shared by the program and the Python module so that both refuse the same
// values with the same words.
#include <cmath>

#include "model/errors.hpp"

namespace tensegrity::reports {

inline constexpr const char* kPrestressFactorFlag = "--prestress-factor";

// `kappa` when it is finite and > 0; else InputError naming the flag and the range.
inline double checked_prestress_factor(double kappa) {
  if (!(std::isfinite(kappa) && kappa > 0.0))
    throw InputError("command line", kPrestressFactorFlag, "must be a finite number > 0");
  return kappa;
}

}  // namespace tensegrity::reports
