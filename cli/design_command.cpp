// tensegrity design SCENE|CHARACTER [--strain S] [--material NAME] [--naive-fraction F]
//   [--solver NAME] --out DESIGN.json [--sheet FILE.csv]
//   [--compare-naive] [--naive-fractions FROM:TO:N] [--settle relax|simulate] [--settle-duration S] [--quiet]
//
// Runs only the stages the input needs: form finding (skipped when the input
// geometry already is a tensegrity), stiffness scaling (the QP of
// formulations/stiffness_qp.hpp), rest lengths (design/rest_lengths.hpp).
// Writes a self-contained design file (model/design.hpp), the fabrication
// sheet as CSV and a printable cut list (cli/fabrication_sheet.hpp). With --compare-naive
// it also settles the design and the paper's constant-fraction baseline under
// gravity (design/naive_sweep.hpp) and records the comparison.
//
// Exit status: 0 a design that verifies was written; 2 bad input (nothing
// computed); 1 the input is valid but no buildable design exists (form finding
// failed, or no equilibrium at the form-found geometry keeps every cable
// inside its material's measured force range). A design that cannot be built
// is never written: on status 1 the last line on standard error names the
// file, the cable and the reason, and no file is left behind.
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <sstream>

#include "cli/commands.hpp"
#include "reports/design_pipeline.hpp"
#include "reports/fabrication_sheet.hpp"
#include "reports/naive_comparison_report.hpp"
#include "reports/output.hpp"
#include "design/rest_lengths.hpp"
#include "model/design.hpp"
#include "model/errors.hpp"
#include "model/scene_io.hpp"
#include "design/naive_sweep.hpp"

namespace tensegrity::cli {

namespace {

struct DesignArgs {
  std::string input, out, sheet, material = reports::kDefaultMaterial, solver;
  double strain = 0.3;
  double naive_fraction = std::nan("");
  double tol = 1e-8;
  double time_limit = 120.0;
  std::vector<std::string> material_dirs;
  bool compare_naive = false;
  bool quiet = false;
  std::string naive_fractions, settle = "relax";
  double settle_duration = 5.0;
};

std::string text(double v) {
  std::ostringstream s;
  s.precision(6);
  s << v;
  return s.str();
}
// The final line of a run that cannot produce a buildable design (exit 1).
int no_design(const std::string& file, const std::string& item, const std::string& reason) {
  std::cerr << "tensegrity: " << file << ": " << (item.empty() ? "" : item + ": ") << reason
            << "; no design written\n";
  return 1;
}

std::vector<double> parse_fractions(const std::string& spec) {
  const std::string item = "--naive-fractions";
  double from = 0, to = 0;
  int n = 0;
  char tail = 0;
  if (std::sscanf(spec.c_str(), "%lf:%lf:%d%c", &from, &to, &n, &tail) != 3)
    throw InputError("command line", item, "expected FROM:TO:N (e.g. 0.5:0.95:10), got '" + spec + "'");
  for (double f : {from, to})
    if (!std::isfinite(f) || !(f > 0.0) || f > 1.0)
      throw InputError("command line", item, "fractions must lie in (0, 1], got '" + spec + "'");
  if (n < 1 || n > 1000) throw InputError("command line", item, "N must be 1..1000, got '" + spec + "'");
  return fraction_grid(from, to, n);
}

// An output path whose folder does not exist fails before any work.
void check_output_path(const std::string& path, const char* item) {
  if (path.empty() || path == "-") return;
  const std::filesystem::path p(path);
  std::error_code ec;
  if (std::filesystem::is_directory(p, ec)) throw InputError(path, "", "cannot write: it is a directory");
  const std::filesystem::path dir = p.has_parent_path() ? p.parent_path() : std::filesystem::path(".");
  if (!std::filesystem::is_directory(dir, ec))
    throw InputError(path, "", std::string("cannot write ") + item + ": folder " + dir.string() + " does not exist");
}

// FILE.design.json -> FILE + suffix (also for FILE.json, FILE.csv); "" for standard output.
std::string default_sheet_path(const std::string& path, const std::string& suffix) {
  if (path.empty() || path == "-") return "";
  std::string stem = path;
  for (const char* ext : {".csv", ".json", ".design", ".sheet"})
    if (stem.size() > std::string(ext).size() && stem.compare(stem.size() - std::string(ext).size(), std::string::npos, ext) == 0)
      stem.resize(stem.size() - std::string(ext).size());
  return stem + suffix;
}

int run_design(const DesignArgs& a) {
  reports::DesignRequest req;
  req.material = a.material;
  req.material_dirs = a.material_dirs;
  req.strain = a.strain;
  req.naive_fraction = a.naive_fraction;
  req.tol = a.tol;
  req.time_limit = a.time_limit;
  req.quiet = a.quiet;
  reports::check_design_request(req);
  const bool naive = !std::isnan(a.naive_fraction);
  if (a.out.empty()) throw InputError("command line", "--out", "missing");
  if (a.out == "-" && a.sheet == "-")
    throw InputError("command line", "--sheet", "the design already goes to standard output");
  check_output_path(a.out, "the design");
  check_output_path(a.sheet, "the sheet");
  const bool compare = a.compare_naive || !a.naive_fractions.empty();
  if (compare && naive)
    throw InputError("command line", "--compare-naive",
                     "compares the stiffness design with naive ones; it cannot be combined with --naive-fraction");
  std::vector<double> fractions;
  if (!a.naive_fractions.empty()) fractions = parse_fractions(a.naive_fractions);
  SettleOptions settle_options;
  if (a.settle == "simulate") settle_options.method = SettleMethod::Simulate;
  else if (a.settle != "relax")
    throw InputError("command line", "--settle", "expected relax or simulate, got '" + a.settle + "'");
  if (!std::isfinite(a.settle_duration) || !(a.settle_duration > 0.0) || a.settle_duration > 1e4)
    throw InputError("command line", "--settle-duration", "must be a number of seconds in (0, 1e4]");
  settle_options.duration = a.settle_duration;
  SolveOptions options;
  options.tolerance = a.tol;
  options.time_limit_s = a.time_limit;
  const auto solver = reports::checked_solver(a.solver, options);  // unknown names fail before any work

  const Structure scene = reports::read_design_input(a.input);
  reports::DesignOutcome outcome = reports::design_structure(scene, a.input, req, *solver);
  if (!outcome.ok) return no_design(a.input, outcome.failure_item, outcome.failure_reason);
  Design& d = outcome.design;
  const RestLengthDesign& rest = outcome.rest;
  const auto [strain_lo, strain_hi] = outcome.strain_range;

  if (compare) {
    if (fractions.empty()) fractions = default_fraction_grid(d);
    const bool terminal = ::isatty(STDERR_FILENO) && !a.quiet;
    const NaiveComparison c = naive_fraction_sweep(d, fractions, settle_options, [terminal](int done, int total) {
      if (!terminal) return;
      std::cerr << "\rdesign: settling " << done << "/" << total << std::flush;
      if (done == total) std::cerr << "\n";
    });
    if (!a.quiet) std::cerr << reports::naive_comparison_table(c, settle_options.method);
    d.info["naive_comparison"] = reports::naive_comparison_json(c, settle_options.method);
  }

  // The sheet first: standard output (--out -) cannot be taken back. Without
  // --sheet it goes beside the design, with the printable cut list.
  const std::string sheet = a.sheet.empty() ? default_sheet_path(a.out, ".sheet.csv") : a.sheet;
  const std::string cut_list = default_sheet_path(sheet == "-" ? a.out : sheet, ".cutlist.svg");
  const std::string printable = default_sheet_path(sheet == "-" ? a.out : sheet, ".cutlist.pdf");
  if (!sheet.empty()) write_text_file_atomically(sheet, reports::fabrication_sheet_csv(d, rest.lengths));
  if (sheet.empty())
    std::cerr << "design: no fabrication sheet: the design goes to standard output, so there is no place beside "
                 "it; pass --sheet FILE.csv\n";
  try {
    if (!cut_list.empty()) reports::write_cut_list(d, rest.lengths, cut_list);
    if (!printable.empty()) reports::write_cut_list(d, rest.lengths, printable);
    write_design_file(d, a.out);
  } catch (...) {
    std::error_code ec;
    if (!sheet.empty() && sheet != "-") std::filesystem::remove(sheet, ec);
    if (!cut_list.empty()) std::filesystem::remove(cut_list, ec);
    if (!printable.empty()) std::filesystem::remove(printable, ec);
    throw;
  }

  int struts = 0, cables = 0;
  for (const auto& el : d.structure.elements) (el.kind == ElementKind::Strut ? struts : cables)++;
  if (a.quiet) return 0;
  std::cerr << "design: " << scene.name << ": " << struts << " struts, " << cables << " cables, cable strain "
            << text(100 * strain_lo) << "% .. " << text(100 * strain_hi) << "%, relative residual "
            << text(d.solution.stats.relative_residual) << "\n";
  return 0;
}

}  // namespace

void register_design_command(CLI::App& app, CommandRunner& run) {
  auto args = std::make_shared<DesignArgs>();
  auto* cmd = app.add_subcommand(
      "design", "Stiffness scaling and cable rest lengths: a buildable design and its fabrication sheet");
  cmd->add_option("input", args->input, "Scene (*.scene.json), character (*.character.json) or design file")
      ->required();
  cmd->add_option("--strain", args->strain, "Desired cable strain (default 0.3); elements may carry target_strain");
  cmd->add_option("--material", args->material,
                  "Cable material name or file (default elastic-cord-2mm); elements may carry material");
  cmd->add_option("--material-dir", args->material_dirs, "Extra folder to look for NAME.json in (repeatable)");
  cmd->add_option("--naive-fraction", args->naive_fraction,
                  "Baseline: every cable's rest length = F * its length, in (0, 1] (no stiffness scaling)");
  cmd->add_option("--solver", args->solver,
                  "Form-finding backend when the input is not in equilibrium (default: " +
                      reports::default_solver_help() + ")");
  cmd->add_option("--tol", args->tol, "Relative residual for form finding and verification");
  cmd->add_option("--time-limit", args->time_limit, "Form-finding wall-clock budget in seconds");
  cmd->add_option("--out", args->out, "Design file to write, - for standard output")->required();
  cmd->add_option("--sheet", args->sheet, "Fabrication sheet (CSV; default: beside the design, NAME.sheet.csv, with NAME.cutlist.svg and .pdf)");
  cmd->add_flag("--compare-naive", args->compare_naive,
                "Settle the design and the constant-fraction baseline under gravity for a sweep of fractions "
                "(default: 10 fractions over the materials' strain range 0.05..max) and report the displacements");
  cmd->add_option("--naive-fractions", args->naive_fractions,
                  "Fractions of --compare-naive as FROM:TO:N (implies --compare-naive)");
  cmd->add_option("--settle", args->settle,
                  "How --compare-naive settles: relax (static equilibrium, default) or simulate (damped implicit "
                  "Euler)");
  cmd->add_option("--settle-duration", args->settle_duration, "Simulated seconds for --settle simulate (default 5)");
  cmd->add_flag("--quiet", args->quiet,
                "No informational lines on stderr (progress, summaries, the --compare-naive table); errors still "
                "print");
  cmd->callback([args, &run] { run = [args] { return run_design(*args); }; });
}

}  // namespace tensegrity::cli
