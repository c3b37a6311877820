// The registry of backends by name. Each backend adds one entry to kBackends
// (declare its factory function here; define it in the backend's own .cpp).
#include <algorithm>
#include <functional>
#include <utility>

#include "model/errors.hpp"
#include "solvers/solver.hpp"

namespace tensegrity {

// Factories, defined in the backends' own files.
std::unique_ptr<Solver> make_alternating_solver();
std::unique_ptr<Solver> make_alternating_gn_solver();
std::unique_ptr<Solver> make_eq5_newton_solver();
std::unique_ptr<Solver> make_nlopt_solver();
std::unique_ptr<Solver> make_ipopt_solver();

namespace {

struct Backend {
  const char* name;
  std::function<std::unique_ptr<Solver>()> make;
};

const std::vector<Backend>& backends() {
  static const std::vector<Backend> kBackends = {
      {"alternating", make_alternating_solver},
      {"alternating-gn", make_alternating_gn_solver},
      {"eq5-newton", make_eq5_newton_solver},
      {"ipopt", make_ipopt_solver},
      {"nlopt", make_nlopt_solver},
  };
  return kBackends;
}

}  // namespace

std::unique_ptr<Solver> make_solver(std::string_view name) {
  for (const auto& b : backends())
    if (name == b.name) return b.make();
  std::string known;
  for (const auto& b : backends()) known += std::string(known.empty() ? "" : ", ") + b.name;
  throw UnknownNameError("solver", std::string(name), "unknown backend (known: " + known + ")");
}

std::vector<std::string> solver_names() {
  std::vector<std::string> names;
  for (const auto& b : backends()) names.emplace_back(b.name);
  return names;
}

std::string default_solver_name() {
  // The recommended backend: eq5-newton ends at Ipopt's local optimum of
  // Eq. 5 where both verify, in about half Ipopt's time (Ipopt starts from
  // its answer), and verifies where Ipopt runs out of iterations
  // (near-degenerate geometry, far from equilibrium; docs/BACKENDS.md).
  const auto names = solver_names();
  for (const char* preferred : {"eq5-newton", "ipopt", "alternating-gn", "alternating"})
    if (std::find(names.begin(), names.end(), preferred) != names.end()) return preferred;
  return names.empty() ? std::string() : names.front();
}

}  // namespace tensegrity
