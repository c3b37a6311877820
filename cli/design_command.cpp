// tensegrity design SCENE|CHARACTER [--strain S] [--material NAME] [--naive-fraction F]
//   [--solver NAME] --out DESIGN.json [--sheet FILE.csv]
//   [--compare-naive] [--naive-fractions FROM:TO:N] [--settle relax|simulate] [--settle-duration S]
//
// Runs only the stages the input needs: form finding (skipped when the input
// geometry already is a tensegrity), stiffness scaling (the QP of
// formulations/stiffness_qp.hpp), rest lengths (formulations/rest_lengths.hpp).
// Writes a self-contained design file (model/design.hpp), the fabrication
// sheet as CSV and a printable cut list (cli/fabrication_sheet.hpp). With --compare-naive
// it also settles the design and the paper's constant-fraction baseline under
// gravity (solvers/naive_sweep.hpp) and records the comparison.
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
#include "cli/fabrication_sheet.hpp"
#include "cli/naive_comparison_report.hpp"
#include "cli/output.hpp"
#include "formulations/force_scale.hpp"
#include "formulations/rest_lengths.hpp"
#include "model/character.hpp"
#include "model/design.hpp"
#include "model/errors.hpp"
#include "model/scene_io.hpp"
#include "model/verify.hpp"
#include "solvers/force_cap.hpp"
#include "solvers/naive_sweep.hpp"
#include "solvers/stiffness_solver.hpp"

namespace tensegrity::cli {

namespace {

// The 2 mm cord: the 1 mm one cannot carry any of the shipped characters (README).
constexpr const char* kDefaultMaterial = "elastic-cord-2mm";

struct DesignArgs {
  std::string input, out, sheet, material = kDefaultMaterial, solver;
  double strain = 0.3;
  double naive_fraction = std::nan("");
  double tol = 1e-8;
  double time_limit = 120.0;
  std::vector<std::string> material_dirs;
  bool compare_naive = false;
  std::string naive_fractions, settle = "relax";
  double settle_duration = 5.0;
};

std::string text(double v) {
  std::ostringstream s;
  s.precision(6);
  s << v;
  return s.str();
}

// Scenes, characters (assembled on the fly) and earlier designs are accepted.
Structure read_input(const std::string& path) {
  const nlohmann::json j = read_json_file(path);
  const std::string format = j.is_object() && j.contains("format") && j.at("format").is_string()
                                 ? j.at("format").get<std::string>()
                                 : std::string();
  if (format == "tensegrity-character") return build_character_file(path).structure;
  if (format == "tensegrity-design") {
    Structure s = design_from_json(j, path).structure;
    return s;
  }
  return scene_from_json(j, path);
}

std::string executable_dir() {
  std::error_code ec;
  const auto exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::string() : exe.parent_path().string();
}

// NAME as a file, else NAME.json in --material-dir folders, $TENSEGRITY_DATA/materials,
// ./data/materials and data/materials beside or above the program.
CableMaterial find_material(const std::string& name, const std::vector<std::string>& extra_dirs,
                            const std::string& item) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (name.find('/') != std::string::npos || name.ends_with(".json")) {
    if (!fs::exists(name, ec)) throw InputError(name, "", "material file not found");
    return read_material_file(name);
  }
  std::vector<std::string> dirs = extra_dirs;
  if (const char* env = std::getenv("TENSEGRITY_DATA")) dirs.push_back(std::string(env) + "/materials");
  dirs.push_back("data/materials");
  const std::string exe = executable_dir();
  if (!exe.empty()) {
    dirs.push_back(exe + "/data/materials");
    dirs.push_back(exe + "/../data/materials");
  }
  for (const auto& d : dirs) {
    const fs::path p = fs::path(d) / (name + ".json");
    if (fs::exists(p, ec)) {
      CableMaterial m = read_material_file(p.string());
      if (m.name != name)
        throw InputError(p.string(), "name", "is '" + m.name + "', expected '" + name + "' (the file name)");
      return m;
    }
  }
  std::string searched;
  for (const auto& d : dirs) searched += (searched.empty() ? "" : ", ") + d;
  throw InputError("command line", item, "material '" + name + "' not found (searched " + searched + ")");
}

// "elements[E] (cable of block B)" for messages.
std::string element_name(const Structure& s, int e) {
  std::string name = "elements[" + std::to_string(e) + "] (" +
                     (s.elements[e].kind == ElementKind::Cable ? "cable" : "strut");
  const nlohmann::json& extra = s.element_extra[e];
  for (const char* group : {"block", "link"})
    if (extra.contains(group))
      name += std::string(" of ") + group + " " +
              (extra.at(group).is_string() ? extra.at(group).get<std::string>() : extra.at(group).dump());
  return name + ")";
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

// Why the stiffness QP found no forces: measure the smallest achievable
// overload of the material caps (solvers/force_cap.hpp) and name the cable.
std::string stiffness_failure_reason(const Design& d, const StiffnessProblem& problem, const StiffnessResult& qr,
                                     double margin) {
  const Structure& s = d.structure;
  const int m = s.num_elements();
  const auto materials_of = d.material_pointers();
  Eigen::VectorXd upper = problem.upper, cap = Eigen::VectorXd::Constant(m, INFINITY);
  for (int e = 0; e < m; ++e)
    if (materials_of[e]) {
      upper[e] = INFINITY;
      cap[e] = materials_of[e]->force_max();
    } else {
      upper[e] = -margin;
    }
  const ForceCapResult fc = smallest_force_cap(s, s.positions, problem.lower, upper, cap);
  if (fc.status == Status::Converged && fc.ratio > 1.0 + 1e-6 && !fc.tightest.empty()) {
    const int e = fc.tightest.front();
    const CableMaterial& mat = *materials_of[e];
    std::ostringstream r;
    r.precision(4);
    r << element_name(s, e) << ": no equilibrium at the form-found geometry keeps every cable inside its "
      << "material's measured force range; at best this cable (and " << fc.tightest.size() - 1
      << " more equally tight) must pull " << fc.ratio * mat.force_max() << " N, " << fc.ratio << " times the "
      << mat.force_max() << " N that material '" << mat.name << "' reaches at its largest measured strain "
      << mat.strain_max << " (the target strain does not change this: use a stronger cord for these cables)";
    return r.str();
  }
  if (fc.status == Status::Infeasible)
    return "stiffness QP: " + std::string(to_string(qr.status)) +
           ": no forces with the right signs balance the loads at the form-found geometry";
  return "stiffness QP: " + std::string(to_string(qr.status)) + ": " + qr.message;
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
  const bool naive = !std::isnan(a.naive_fraction);
  if (naive && (!std::isfinite(a.naive_fraction) || !(a.naive_fraction > 0.0) || a.naive_fraction > 1.0))
    throw InputError("command line", "--naive-fraction", "must be a number in (0, 1], got " + text(a.naive_fraction));
  if (!std::isfinite(a.strain) || !(a.strain > -1.0))
    throw InputError("command line", "--strain", "must be a finite number > -1, got " + text(a.strain));
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
  const auto solver = checked_solver(a.solver, options);  // unknown names fail before any work
  const std::string solver_name(solver->name());

  const Structure scene = read_input(a.input);
  const int m = scene.num_elements();

  // Materials: --material for every cable unless the element names its own.
  Design d;
  d.cable_material.assign(m, "");
  std::map<std::string, std::string> resolved;  // requested name or path -> material name
  for (int e = 0; e < m; ++e) {
    if (scene.elements[e].kind != ElementKind::Cable) continue;
    std::string name = a.material;
    std::string item = "--material";
    const auto& extra = scene.element_extra[e];
    if (extra.contains("material")) {
      item = "elements[" + std::to_string(e) + "].material";
      if (!extra.at("material").is_string()) throw InputError(a.input, item, "expected a material name");
      name = extra.at("material").get<std::string>();
    }
    // A file path resolves to the material's own name.
    auto known = resolved.find(name);
    if (known == resolved.end()) {
      CableMaterial mat = find_material(name, a.material_dirs, item);
      const auto clash = d.materials.find(mat.name);
      if (clash != d.materials.end() && material_to_json(clash->second) != material_to_json(mat))
        throw InputError("command line", item, "two different materials are named '" + mat.name + "'");
      known = resolved.emplace(name, mat.name).first;
      d.materials[mat.name] = std::move(mat);
    }
    d.cable_material[e] = known->second;
  }

  // Target strains: --strain, or an element's own "target_strain".
  Eigen::VectorXd target_strain = Eigen::VectorXd::Zero(m);
  Eigen::VectorXd targets = Eigen::VectorXd::Zero(m);
  const auto materials_of = d.material_pointers();
  for (int e = 0; e < m; ++e) {
    if (!materials_of[e]) continue;
    const auto& extra = scene.element_extra[e];
    std::string item = "--strain";
    target_strain[e] = a.strain;
    if (extra.contains("target_strain")) {
      item = "elements[" + std::to_string(e) + "].target_strain";
      target_strain[e] = extra.at("target_strain").is_number() ? extra.at("target_strain").get<double>() : NAN;
    }
    const CableMaterial& mat = *materials_of[e];
    if (!naive && !mat.in_range(target_strain[e]))
      throw InputError(item == "--strain" ? "command line" : a.input, item,
                       "strain " + text(target_strain[e]) + " is outside the measured range [" + text(mat.strain_min) +
                           ", " + text(mat.strain_max) + "] of material '" + mat.name + "'");
    if (!naive) targets[e] = mat.force(target_strain[e]);
  }
  // The baseline's one strain must be inside every material before any work.
  if (naive) {
    const RestLengthDesign check = naive_rest_lengths(scene, scene.positions, a.naive_fraction, materials_of);
    if (!check.ok) throw InputError("command line", "--naive-fraction", check.message);
  }

  // Stage 1: form finding, only when the input geometry is not a tensegrity.
  SolveResult ff = solve_forces_only(scene, options);
  std::string form_solver = "none (already in equilibrium)";
  if (ff.status != Status::Converged) {
    ff = solve_scene(*solver, scene, options);
    form_solver = solver_name;
    std::cerr << summary_line(scene, solver_name, ff) << "\n";
    if (ff.status != Status::Converged)
      return no_design(a.input, "form finding", std::string(to_string(ff.status)) + ": " + ff.message);
  }
  d.structure = scene;
  d.structure.positions = ff.positions;
  d.structure.name = scene.name;

  nlohmann::json info = nlohmann::json::object();
  info["mode"] = naive ? "naive" : "stiffness";
  info["input"] = std::filesystem::path(a.input).filename().string();
  info["form_finding"] = {{"solver", form_solver},
                          {"status", std::string(to_string(ff.status))},
                          {"iterations", ff.stats.iterations},
                          {"geometry_change", ff.stats.geometry_change}};

  Eigen::VectorXd forces = ff.forces;
  RestLengthDesign rest;
  if (naive) {
    info["naive_fraction"] = a.naive_fraction;
    rest = naive_rest_lengths(d.structure, d.structure.positions, a.naive_fraction, materials_of);
    if (!rest.ok) throw InputError("command line", "--naive-fraction", rest.message);
    // What the cables actually pull with at these rest lengths.
    const Eigen::VectorXd pulled =
        cable_forces_from_rest_lengths(d.structure, d.structure.positions, rest.rest_lengths, materials_of);
    info["material_forces"] = std::vector<double>(pulled.data(), pulled.data() + m);
  } else {
    // Stage 2: stiffness scaling, with each cable kept inside its material's
    // measured force range so that stage 3 always has a strain.
    info["target_strain"] = a.strain;
    const ForceScale fs = make_force_scale(d.structure, options.margin_fraction);
    StiffnessProblem problem = make_stiffness_problem(d.structure, targets, fs.margin);
    for (int e = 0; e < m; ++e)
      if (materials_of[e]) {
        problem.lower[e] = std::max(problem.lower[e], materials_of[e]->force_min());
        problem.upper[e] = materials_of[e]->force_max();
      }
    StiffnessOptions so;
    so.tolerance = a.tol;  // the geometry itself is only in equilibrium to this level
    const StiffnessResult qr = solve_stiffness_qp(d.structure, d.structure.positions, problem, so, &ff.forces);
    info["stiffness_qp"] = {{"status", std::string(to_string(qr.status))},
                            {"message", qr.message},
                            {"iterations", qr.iterations},
                            {"objective", qr.objective},
                            {"max_target_deviation", qr.max_target_deviation},
                            {"residual", qr.residual},
                            {"relative_residual", qr.relative_residual},
                            {"active_bounds", qr.active_bounds},
                            {"polished", qr.polished},
                            {"seconds", qr.seconds}};
    std::cerr << "design: stiffness QP " << to_string(qr.status) << ": " << qr.message << ", relative residual "
              << text(qr.relative_residual) << ", max |sigma - target| " << text(qr.max_target_deviation) << " N, "
              << qr.active_bounds << " bounds active\n";
    if (qr.status != Status::Converged)
      return no_design(a.input, "", stiffness_failure_reason(d, problem, qr, fs.margin));
    forces = qr.sigma;
    // Stage 3: rest lengths. The QP's bounds keep every force in range, so a
    // failure here is a solver defect, reported like one.
    rest = compute_rest_lengths(d.structure, d.structure.positions, forces, materials_of);
    if (!rest.ok)
      return no_design(a.input, element_name(d.structure, rest.out_of_range.front()), "rest length: " + rest.message);
    const Eigen::VectorXd back =
        cable_forces_from_rest_lengths(d.structure, d.structure.positions, rest.rest_lengths, materials_of);
    double round_trip = 0.0;
    for (int e = 0; e < m; ++e)
      if (materials_of[e]) round_trip = std::max(round_trip, std::abs(back[e] - forces[e]) / std::abs(forces[e]));
    info["round_trip_relative_error"] = round_trip;
  }

  double strain_lo = INFINITY, strain_hi = -INFINITY;
  for (int e = 0; e < m; ++e)
    if (materials_of[e]) strain_lo = std::min(strain_lo, rest.strains[e]), strain_hi = std::max(strain_hi, rest.strains[e]);
  if (std::isfinite(strain_lo)) info["cable_strain_range"] = {strain_lo, strain_hi};

  const Verification v = verify(d.structure, d.structure.positions, forces, options.tolerance);
  if (!v.ok)
    return no_design(a.input, "verification",
                     "the designed forces do not verify (relative residual " + text(v.relative_residual) +
                         (v.problems.empty() ? std::string() : ", " + v.problems.front()) + ")");
  d.solution.scene = scene.name;
  d.solution.solver = form_solver;
  d.solution.positions = d.structure.positions;
  d.solution.forces = forces;
  d.solution.rest_lengths = rest.rest_lengths;
  d.solution.stats = ff.stats;
  d.solution.stats.residual = v.residual;
  d.solution.stats.relative_residual = v.relative_residual;
  d.solution.status = Status::Converged;
  d.strains = rest.strains;
  d.info = info;

  if (compare) {
    if (fractions.empty()) fractions = default_fraction_grid(d);
    const bool terminal = ::isatty(STDERR_FILENO);
    const NaiveComparison c = naive_fraction_sweep(d, fractions, settle_options, [terminal](int done, int total) {
      if (!terminal) return;
      std::cerr << "\rdesign: settling " << done << "/" << total << std::flush;
      if (done == total) std::cerr << "\n";
    });
    std::cerr << naive_comparison_table(c, settle_options.method);
    d.info["naive_comparison"] = naive_comparison_json(c, settle_options.method);
  }

  // The sheet first: standard output (--out -) cannot be taken back. Without
  // --sheet it goes beside the design, with the printable cut list.
  const std::string sheet = a.sheet.empty() ? default_sheet_path(a.out, ".sheet.csv") : a.sheet;
  const std::string cut_list = default_sheet_path(sheet == "-" ? a.out : sheet, ".cutlist.svg");
  if (!sheet.empty()) write_text_file_atomically(sheet, fabrication_sheet_csv(d, rest.lengths));
  try {
    if (!cut_list.empty()) write_cut_list(d, rest.lengths, cut_list);
    write_design_file(d, a.out);
  } catch (...) {
    std::error_code ec;
    if (!sheet.empty() && sheet != "-") std::filesystem::remove(sheet, ec);
    if (!cut_list.empty()) std::filesystem::remove(cut_list, ec);
    throw;
  }

  int struts = 0, cables = 0;
  for (const auto& el : d.structure.elements) (el.kind == ElementKind::Strut ? struts : cables)++;
  std::cerr << "design: " << scene.name << ": " << struts << " struts, " << cables << " cables, cable strain "
            << text(100 * strain_lo) << "% .. " << text(100 * strain_hi) << "%, relative residual "
            << text(v.relative_residual) << "\n";
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
  cmd->add_option("--solver", args->solver, "Form-finding backend when the input is not in equilibrium");
  cmd->add_option("--tol", args->tol, "Relative residual for form finding and verification");
  cmd->add_option("--time-limit", args->time_limit, "Form-finding wall-clock budget in seconds");
  cmd->add_option("--out", args->out, "Design file to write, - for standard output")->required();
  cmd->add_option("--sheet", args->sheet, "Fabrication sheet (CSV; default: beside the design, NAME.sheet.csv, with NAME.cutlist.svg)");
  cmd->add_flag("--compare-naive", args->compare_naive,
                "Settle the design and the constant-fraction baseline under gravity for a sweep of fractions "
                "(default: 10 fractions over the materials' strain range 0.05..max) and report the displacements");
  cmd->add_option("--naive-fractions", args->naive_fractions,
                  "Fractions of --compare-naive as FROM:TO:N (implies --compare-naive)");
  cmd->add_option("--settle", args->settle,
                  "How --compare-naive settles: relax (static equilibrium, default) or simulate (damped implicit "
                  "Euler)");
  cmd->add_option("--settle-duration", args->settle_duration, "Simulated seconds for --settle simulate (default 5)");
  cmd->callback([args, &run] { run = [args] { return run_design(*args); }; });
}

}  // namespace tensegrity::cli
