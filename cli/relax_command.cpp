// tensegrity relax DESIGN [--gravity gx,gy,gz] [--out FILE] [--tol T] [--quiet]
//
// The static check of a fabricated character: with the designed rest lengths
// and materials fixed, find the equilibrium by minimising the elastic energy
// (simulation/simulator.hpp, relax), report the largest node displacement from
// the designed shape, and write the relaxed positions and forces as a
// solution file (docs/FORMATS.md) with the design's rest lengths.
#include <cmath>
#include <cstdio>
#include <memory>
#include <sstream>

#include "cli/commands.hpp"
#include "model/design.hpp"
#include "model/errors.hpp"
#include "model/solution.hpp"
#include "model/verify.hpp"
#include "simulation/simulator.hpp"

namespace tensegrity::cli {

namespace {

struct RelaxArgs {
  std::string design, out, gravity;
  double tol = 1e-9;
  int max_iterations = 500;
  bool quiet = false;
};

Eigen::Vector3d parse_gravity(const std::string& text) {
  std::string t = text;
  for (char& c : t)
    if (c == ',') c = ' ';
  std::istringstream in(t);
  Eigen::Vector3d g;
  std::string rest;
  if (!(in >> g.x() >> g.y() >> g.z()) || (in >> rest) || !g.allFinite())
    throw InputError("command line", "--gravity", "expected three finite numbers gx,gy,gz, got '" + text + "'");
  return g;
}

int run_relax(const RelaxArgs& a) {
  if (!(std::isfinite(a.tol) && a.tol > 0)) throw InputError("command line", "--tol", "must be a finite number > 0");
  const Design design = read_design_file(a.design);
  const ElasticModel model = make_elastic_model(design);
  Structure s = model.structure;
  if (!a.gravity.empty()) s.gravity = parse_gravity(a.gravity);
  const ElasticEnergy energy(model, s.gravity);
  RelaxOptions ro;
  ro.tolerance = a.tol;
  ro.max_iterations = a.max_iterations;
  const RelaxResult r = relax(energy, model.reference, {}, ro);

  const Verification v = verify(s, r.positions, r.forces, 1e-6);
  Solution sol;
  sol.scene = s.name;
  sol.solver = "relax";
  sol.status = r.status;
  sol.positions = r.positions;
  sol.forces = r.forces;
  sol.rest_lengths = design.solution.rest_lengths;
  sol.stats.iterations = r.iterations;
  sol.stats.seconds = r.seconds;
  sol.stats.residual = v.residual;
  sol.stats.relative_residual = v.relative_residual;
  sol.stats.geometry_change = (r.positions - model.reference).norm();
  sol.extra["gravity"] = {s.gravity.x(), s.gravity.y(), s.gravity.z()};
  sol.extra["max_displacement"] = r.max_displacement;
  sol.extra["max_displacement_node"] = r.max_displacement_node;
  sol.extra["relative_max_displacement"] = r.max_displacement / model.length_scale;
  sol.extra["size"] = model.length_scale;
  sol.extra["slack_cables"] = r.cables_slack;
  sol.extra["cables_outside_measured_range"] = r.cables_outside_range;
  sol.extra["message"] = r.message;
  if (!a.out.empty()) write_solution_file(sol, a.out);
  // --quiet keeps the summary of a failed relax: it says why.
  if (!a.quiet || r.status != Status::Converged)
    std::fprintf(stderr,
               "relax: %s: %s in %d iterations (%d definite), %.3f ms; max net force %.3g N; largest displacement "
               "%.6g m at node %d (%.3g of the size %.4g m); %d slack cables, %d outside the measured range\n",
               s.name.c_str(), std::string(to_string(r.status)).c_str(), r.iterations, r.definite_steps,
               1e3 * r.seconds, r.gradient_norm, r.max_displacement, r.max_displacement_node,
               r.max_displacement / model.length_scale, model.length_scale, r.cables_slack, r.cables_outside_range);
  if (r.status != Status::Converged) std::fprintf(stderr, "relax: %s\n", r.message.c_str());
  return r.status == Status::Converged ? 0 : 1;
}

}  // namespace

void register_relax_command(CLI::App& app, CommandRunner& run) {
  auto args = std::make_shared<RelaxArgs>();
  auto* cmd = app.add_subcommand(
      "relax", "Static equilibrium of a built design (rest lengths fixed): does it hold its shape?");
  cmd->add_option("design", args->design, "Design file (tensegrity design --out)")->required();
  cmd->add_option("--gravity", args->gravity, "gx,gy,gz in m/s^2 (default: the design's)");
  cmd->add_option("--out", args->out, "Solution file with the relaxed positions and forces (- for stdout)");
  cmd->add_option("--tol", args->tol, "Max net force relative to the largest designed force (default 1e-9)");
  cmd->add_option("--max-iterations", args->max_iterations, "Newton iteration budget");
  cmd->add_flag("--quiet", args->quiet, "No summary on stderr unless relax fails (errors still print)");
  cmd->callback([args, &run] { run = [args] { return run_relax(*args); }; });
}

}  // namespace tensegrity::cli
