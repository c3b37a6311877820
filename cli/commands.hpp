#pragma once
// Each subcommand lives in its own file and registers itself on the app.
// A command's callback returns the process exit status (0 converged / ok,
// 1 ran but did not converge or verify, 2 bad input, 3 `check --stability`:
// verified but not stable); InputError thrown from a command is turned into
// one line on stderr and exit status 2 by main.cpp.
#include <CLI/CLI.hpp>
#include <functional>

namespace tensegrity::cli {

using CommandRunner = std::function<int()>;

// Each register_* adds a subcommand and stores its runner in `run` when chosen.
void register_solvers_command(CLI::App& app, CommandRunner& run);
void register_solve_command(CLI::App& app, CommandRunner& run);
void register_forces_command(CLI::App& app, CommandRunner& run);
void register_check_command(CLI::App& app, CommandRunner& run);
void register_generate_command(CLI::App& app, CommandRunner& run);
void register_build_command(CLI::App& app, CommandRunner& run);
void register_export_command(CLI::App& app, CommandRunner& run);
void register_render_command(CLI::App& app, CommandRunner& run);
void register_design_command(CLI::App& app, CommandRunner& run);
void register_fit_material_command(CLI::App& app, CommandRunner& run);
void register_simulate_command(CLI::App& app, CommandRunner& run);
void register_relax_command(CLI::App& app, CommandRunner& run);
void register_batch_command(CLI::App& app, CommandRunner& run);
void register_stress_test_command(CLI::App& app, CommandRunner& run);
void register_serve_command(CLI::App& app, CommandRunner& run);
void register_compare_command(CLI::App& app, CommandRunner& run);
void register_import_command(CLI::App& app, CommandRunner& run);
void register_suggest_link_command(CLI::App& app, CommandRunner& run);
void register_actuation_command(CLI::App& app, CommandRunner& run);

}  // namespace tensegrity::cli
