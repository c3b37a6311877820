#include "cli/prestress_factor_option.hpp"

#include <CLI/CLI.hpp>
#include <cstdio>

namespace tensegrity::cli {

void add_prestress_factor_option(CLI::App& command, double* kappa) {
  *kappa = kDefaultPrestressFactor;
  char help[200];
  std::snprintf(help, sizeof help,
                "kappa: under gravity Eq. 5 caps the mean cable force at kappa times the part's weight "
                "(finite, > 0; default %g; docs/THEORY-force-scale.md)",
                kDefaultPrestressFactor);
  command.add_option(reports::kPrestressFactorFlag, *kappa, help);
}

}  // namespace tensegrity::cli
