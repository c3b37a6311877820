#include "reports/output.hpp"

#include <cstdio>
#include <sstream>

#include "model/errors.hpp"
#include "model/scene_io.hpp"
#include "solvers/alternating/alternating_solver.hpp"

namespace tensegrity::reports {

std::string option_error_line(const OptionError& e) {
  return "tensegrity: command line: --option " + e.key() + (e.value().empty() ? "" : "=" + e.value()) + ": " +
         e.reason() + " (solver " + e.backend() + ")";
}

std::string unknown_name_line(const UnknownNameError& e, std::string_view command) {
  const bool takes_a_list = command == "compare" || command == "stress-test";
  const std::map<std::string, std::string> flag_of_kind = {{"solver", takes_a_list ? "--solvers" : "--solver"},
                                                           {"family", "--families"}};
  const auto flag = flag_of_kind.find(e.kind());
  return "tensegrity: command line: " + (flag == flag_of_kind.end() ? "--" + e.kind() : flag->second) + " " +
         e.name() + ": " + e.reason();
}

std::string summary_line(const Structure& scene, std::string_view solver, const SolveResult& r) {
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "%s: %s by %.*s in %d iterations, %.3g s, relative residual %.3g, geometry change %.6g m",
                scene.name.empty() ? "scene" : scene.name.c_str(), std::string(to_string(r.status)).c_str(),
                static_cast<int>(solver.size()), solver.data(), r.stats.iterations, r.stats.seconds,
                r.stats.relative_residual, r.stats.geometry_change);
  std::string line = buf;
  if (r.status != Status::Converged && !r.message.empty()) line += " (" + r.message + ")";
  return line;
}

std::unique_ptr<Solver> checked_solver(const std::string& name, const SolveOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw InputError("command line", "options", why);
  auto solver = make_solver(name.empty() ? default_solver_name() : name);
  solver->ValidateOptions(options);
  return solver;
}

std::map<std::string, std::string> parse_key_values(const std::vector<std::string>& items) {
  std::map<std::string, std::string> kv;
  for (const auto& item : items) {
    const auto eq = item.find('=');
    if (eq == std::string::npos || eq == 0)
      throw InputError("command line", "--option " + item, "expected key=value");
    kv[item.substr(0, eq)] = item.substr(eq + 1);
  }
  return kv;
}

std::string default_solver_help() { return "the recommended one, " + default_solver_name(); }

std::string max_iterations_help(const std::string& what) {
  return what + " (default 0: the backend's own, " + std::to_string(kFaithfulIterationBudget) +
         " outer iterations for alternating, " + std::to_string(kDefaultIterationBudget) + " for the others)";
}

}  // namespace tensegrity::reports
