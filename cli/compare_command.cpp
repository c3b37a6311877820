// tensegrity compare SCENE [--solvers a,b,...] [--repeat N] [--time-limit S] [--tol T] [--max-iterations N]
//                   [--prestress-factor K] --out DIR [--json]
#include <algorithm>
#include <filesystem>
#include <iostream>
#include <memory>

#include "cli/commands.hpp"
#include "cli/compare_report.hpp"
#include "cli/prestress_factor_option.hpp"
#include "reports/output.hpp"
#include "model/errors.hpp"
#include "model/scene_io.hpp"
#include "model/verify.hpp"

namespace tensegrity::cli {

namespace {

struct CompareArgs {
  std::string scene, out_dir;
  std::vector<std::string> solvers;
  int repeat = 1;
  double time_limit = 120.0;
  double tol = 1e-8;
  int max_iterations = 0;
  double prestress_factor = 0.0;  // set by add_prestress_factor_option
  bool json = false;
};

CompareRow compare_one(const Structure& scene, const std::string& name, const SolveOptions& options, int repeat,
                       const TracePoint& start) {
  const auto solver = reports::checked_solver(name, options);
  std::vector<SolveResult> runs;
  for (int k = 0; k < repeat; ++k) runs.push_back(solve_scene(*solver, scene, options));
  std::vector<double> seconds;
  for (const SolveResult& r : runs) seconds.push_back(r.stats.seconds);
  std::sort(seconds.begin(), seconds.end());
  const double median = repeat % 2 ? seconds[repeat / 2] : 0.5 * (seconds[repeat / 2 - 1] + seconds[repeat / 2]);
  // The reported run is the one whose time is closest to the median.
  const SolveResult& r = *std::min_element(runs.begin(), runs.end(), [&](const SolveResult& a, const SolveResult& b) {
    return std::abs(a.stats.seconds - median) < std::abs(b.stats.seconds - median);
  });
  CompareRow row;
  row.solver = name;
  row.status = r.status;
  row.message = r.message;
  row.median_seconds = median;
  row.iterations = r.stats.iterations;
  const Verification v = verify(scene, r.positions, r.forces, options.tolerance);
  row.relative_residual = v.relative_residual;
  row.geometry_change = v.geometry_change;
  row.largest_node_move = (r.positions - scene.positions).colwise().norm().maxCoeff();
  row.verified = v.ok;
  row.trace = normalised_trace(r.trace, start, r);
  return row;
}

}  // namespace

void register_compare_command(CLI::App& app, CommandRunner& run) {
  auto args = std::make_shared<CompareArgs>();
  auto* cmd = app.add_subcommand("compare", "Run every backend (or the chosen ones) on one scene; table, CSV, JSON, plot");
  cmd->add_option("scene", args->scene, "Scene file (*.scene.json)")->required();
  cmd->add_option("--solvers", args->solvers, "Backends to run, comma separated (default: all)")->delimiter(',');
  cmd->add_option("--repeat", args->repeat, "Solves per backend; seconds is their median")->check(CLI::Range(1, 1000));
  cmd->add_option("--time-limit", args->time_limit, "Wall-clock budget per solve in seconds");
  cmd->add_option("--tol", args->tol, "Relative residual for `converged` (finite, > 0)");
  cmd->add_option("--max-iterations", args->max_iterations, reports::max_iterations_help("Backend iteration budget"));
  add_prestress_factor_option(*cmd, &args->prestress_factor);
  cmd->add_option("--out", args->out_dir, "Folder for compare.csv, compare.json, compare-trace.csv, compare.png/.svg")
      ->required();
  cmd->add_flag("--json", args->json, "Print compare.json on standard output instead of the table");
  cmd->callback([args, &run] {
    run = [args] {
      SolveOptions options;
      options.tolerance = args->tol;
      options.max_iterations = args->max_iterations;
      options.time_limit_s = args->time_limit;
      options.prestress_factor = reports::checked_prestress_factor(args->prestress_factor);
      std::vector<std::string> names = args->solvers.empty() ? solver_names() : args->solvers;
      for (const std::string& name : names) reports::checked_solver(name, options);  // usage errors before any work
      const Structure scene = read_scene_file(args->scene);
      std::error_code ec;
      std::filesystem::create_directories(args->out_dir, ec);
      if (ec || !std::filesystem::is_directory(args->out_dir))
        throw InputError(args->out_dir, "--out", "cannot create the folder");
      const TracePoint start = start_point(scene, options);
      std::vector<CompareRow> rows;
      for (const std::string& name : names) rows.push_back(compare_one(scene, name, options, args->repeat, start));
      const std::filesystem::path dir(args->out_dir);
      const std::string json = compare_json(scene.name, args->tol, args->repeat, rows);
      write_text_file_atomically((dir / "compare.csv").string(), compare_csv(rows));
      write_text_file_atomically((dir / "compare.json").string(), json);
      write_text_file_atomically((dir / "compare-trace.csv").string(), compare_trace_csv(rows));
      write_compare_plot(scene.name, rows, (dir / "compare.png").string());
      write_compare_plot(scene.name, rows, (dir / "compare.svg").string());
      std::cout << (args->json ? json : compare_table(rows));
      const bool all_verified =
          std::all_of(rows.begin(), rows.end(), [](const CompareRow& r) { return r.status == Status::Converged && r.verified; });
      return all_verified ? 0 : 1;
    };
  });
}

}  // namespace tensegrity::cli
