#pragma once
// The --prestress-factor option (kappa of Eq. 5 under gravity) of every
// command that solves; its check is reports/prestress_factor.hpp's.
#include "formulations/force_scale.hpp"
#include "reports/prestress_factor.hpp"

namespace CLI {
class App;
}  // namespace CLI

namespace tensegrity::cli {

// Adds --prestress-factor to `command`, stored in `*kappa` (which starts at
// kDefaultPrestressFactor); the value is checked by checked_prestress_factor.
void add_prestress_factor_option(CLI::App& command, double* kappa);

}  // namespace tensegrity::cli
