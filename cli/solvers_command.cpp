// tensegrity solvers: the backend names, one per line.
#include <iostream>

#include "cli/commands.hpp"
#include "solvers/solver.hpp"

namespace tensegrity::cli {

void register_solvers_command(CLI::App& app, CommandRunner& run) {
  auto* cmd = app.add_subcommand("solvers", "List the backend names, one per line");
  cmd->callback([&run] {
    run = [] {
      for (const auto& n : solver_names()) std::cout << n << "\n";
      return 0;
    };
  });
}

}  // namespace tensegrity::cli
