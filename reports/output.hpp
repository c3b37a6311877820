#pragma once
// Shared output helpers of the commands.
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "model/errors.hpp"
#include "solvers/solver.hpp"
#include "solvers/trace_csv.hpp"  // write_trace_csv, which the commands use with these

namespace tensegrity::reports {

// The one line the program prints for a bad backend option: the library names
// the option, the command line names the flag that gave it.
std::string option_error_line(const OptionError& e);
// The one line the program prints for a name no registry knows: the library
// names the kind of name, the command line the flag that gave it (`command`:
// the subcommand that ran; `compare` and `stress-test` take --solvers).
std::string unknown_name_line(const UnknownNameError& e, std::string_view command = "");

// One-line human summary of a solve, for standard error.
std::string summary_line(const Structure& scene, std::string_view solver, const SolveResult& r);
// Parses "key=value" items of --option.
std::map<std::string, std::string> parse_key_values(const std::vector<std::string>& items);
// The solver a command was asked for (empty: the default), with the options
// checked by it and by SolveOptions::IsValid; InputError (exit 2) otherwise.
std::unique_ptr<Solver> checked_solver(const std::string& name, const SolveOptions& options);
// Help text of --max-iterations (solve, batch): 0 and the backends' own budgets.
std::string max_iterations_help(const std::string& what);
// What --solver defaults to, for its help text: "the recommended one, NAME".
std::string default_solver_help();
// Exit status of a finished solve (docs/USER-GUIDE.md): 0 converged, 1 otherwise.
inline int exit_status(Status s) { return s == Status::Converged ? 0 : 1; }

}  // namespace tensegrity::reports
