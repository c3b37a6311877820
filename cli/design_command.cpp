// tensegrity design SCENE|CHARACTER [--strain S] [--material NAME] [--naive-fraction F]
//   [--solver NAME] --out DESIGN.json [--sheet FILE.csv]
//
// Runs only the stages the input needs: form finding (skipped when the input
// geometry already is a tensegrity), stiffness scaling (the QP of
// formulations/stiffness_qp.hpp), rest lengths (formulations/rest_lengths.hpp).
// Writes a self-contained design file (model/design.hpp) and, with --sheet, the
// fabrication sheet as CSV.
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
#include "cli/output.hpp"
#include "formulations/force_scale.hpp"
#include "formulations/rest_lengths.hpp"
#include "model/character.hpp"
#include "model/design.hpp"
#include "model/errors.hpp"
#include "model/scene_io.hpp"
#include "model/verify.hpp"
#include "solvers/stiffness_solver.hpp"

namespace tensegrity::cli {

namespace {

constexpr const char* kDefaultMaterial = "elastic-cord-1mm";

struct DesignArgs {
  std::string input, out, sheet, material = kDefaultMaterial, solver;
  double strain = 0.3;
  double naive_fraction = std::nan("");
  double tol = 1e-8;
  double time_limit = 120.0;
  std::vector<std::string> material_dirs;
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

// Block and link groups in assembly order: blocks first, then links, each in
// the order they first appear; elements without an id last.
struct Group {
  std::string kind, id;
  std::vector<int> elements;
};

std::string id_text(const nlohmann::json& v) { return v.is_string() ? v.get<std::string>() : v.dump(); }

std::vector<Group> assembly_groups(const Structure& s) {
  std::vector<Group> blocks, links;
  Group rest{"none", "", {}};
  auto find_or_add = [](std::vector<Group>& groups, const std::string& kind, const std::string& id) -> Group& {
    for (auto& g : groups)
      if (g.id == id) return g;
    groups.push_back(Group{kind, id, {}});
    return groups.back();
  };
  for (int e = 0; e < s.num_elements(); ++e) {
    const nlohmann::json extra =
        e < static_cast<int>(s.element_extra.size()) ? s.element_extra[e] : nlohmann::json::object();
    if (extra.contains("block")) find_or_add(blocks, "block", id_text(extra.at("block"))).elements.push_back(e);
    else if (extra.contains("link")) find_or_add(links, "link", id_text(extra.at("link"))).elements.push_back(e);
    else rest.elements.push_back(e);
  }
  std::vector<Group> out = blocks;
  out.insert(out.end(), links.begin(), links.end());
  if (!rest.elements.empty()) out.push_back(rest);
  // Within a group: struts (cut from tube) before cables, each in element order.
  for (auto& g : out)
    std::stable_sort(g.elements.begin(), g.elements.end(), [&](int a, int b) {
      return (s.elements[a].kind == ElementKind::Strut) > (s.elements[b].kind == ElementKind::Strut);
    });
  return out;
}

std::string csv_field(const std::string& v) {
  if (v.find_first_of(",\"\n") == std::string::npos) return v;
  std::string q = "\"";
  for (char c : v) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

std::string number17(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

void write_sheet(const std::string& path, const Design& d, const Eigen::VectorXd& lengths) {
  const Structure& s = d.structure;
  std::ostringstream out;
  out << "group_kind,group,element,kind,node_a,node_b,material,length_m,rest_length_m,force_N,strain,count\n";
  int struts = 0;
  double strut_length = 0.0;
  std::map<std::string, std::pair<int, std::pair<double, double>>> per_material;  // count, (l, L)
  for (const Group& g : assembly_groups(s)) {
    for (int e : g.elements) {
      const bool strut = s.elements[e].kind == ElementKind::Strut;
      const double L = (*d.solution.rest_lengths)[e];
      out << g.kind << ',' << csv_field(g.id) << ',' << e << ',' << (strut ? "strut" : "cable") << ','
          << s.elements[e].a << ',' << s.elements[e].b << ',' << csv_field(d.cable_material[e]) << ','
          << number17(lengths[e]) << ',' << number17(L) << ',' << number17(d.solution.forces[e]) << ','
          << number17(d.strains[e]) << ",1\n";
      if (strut) {
        ++struts;
        strut_length += lengths[e];
      } else {
        auto& t = per_material[d.cable_material[e]];
        ++t.first;
        t.second.first += lengths[e];
        t.second.second += L;
      }
    }
  }
  out << "total,,,strut,,,," << number17(strut_length) << ',' << number17(strut_length) << ",,," << struts << "\n";
  for (const auto& [name, t] : per_material)
    out << "total,,,cable,,," << csv_field(name) << ',' << number17(t.second.first) << ','
        << number17(t.second.second) << ",,," << t.first << "\n";
  write_text_file_atomically(path, out.str());
}

int run_design(const DesignArgs& a) {
  const bool naive = !std::isnan(a.naive_fraction);
  if (naive && (!std::isfinite(a.naive_fraction) || !(a.naive_fraction > 0.0) || a.naive_fraction > 1.0))
    throw InputError("command line", "--naive-fraction", "must be a number in (0, 1], got " + text(a.naive_fraction));
  if (!std::isfinite(a.strain) || !(a.strain > -1.0))
    throw InputError("command line", "--strain", "must be a finite number > -1, got " + text(a.strain));
  if (a.out.empty()) throw InputError("command line", "--out", "missing");
  SolveOptions options;
  options.tolerance = a.tol;
  options.time_limit_s = a.time_limit;
  std::string why;
  if (!options.IsValid(&why)) throw InputError("command line", "options", why);
  const std::string solver_name = a.solver.empty() ? default_solver_name() : a.solver;
  const auto solver = make_solver(solver_name);  // unknown names fail before any work
  solver->check_options(options);

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

  // Stage 1: form finding, only when the input geometry is not a tensegrity.
  SolveResult ff = solve_forces_only(scene, options);
  std::string form_solver = "none (already in equilibrium)";
  if (ff.status != Status::Converged) {
    ff = solve_scene(*solver, scene, options);
    form_solver = solver_name;
    std::cerr << summary_line(scene, solver_name, ff) << "\n";
    if (ff.status != Status::Converged) {
      std::cerr << "design: form finding did not converge (" << to_string(ff.status) << "): " << ff.message
                << "; nothing written\n";
      return 1;
    }
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
    if (qr.status != Status::Converged) {
      std::cerr << "design: stiffness scaling failed; nothing written\n";
      return 1;
    }
    forces = qr.sigma;
    // Stage 3: rest lengths.
    rest = compute_rest_lengths(d.structure, d.structure.positions, forces, materials_of);
    if (!rest.ok) throw InputError(a.input, "rest lengths", rest.message);
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
  d.solution.scene = scene.name;
  d.solution.solver = form_solver;
  d.solution.positions = d.structure.positions;
  d.solution.forces = forces;
  d.solution.rest_lengths = rest.rest_lengths;
  d.solution.stats = ff.stats;
  d.solution.stats.residual = v.residual;
  d.solution.stats.relative_residual = v.relative_residual;
  d.solution.status = v.ok ? Status::Converged : Status::NumericalError;
  d.strains = rest.strains;
  d.info = info;
  write_design_file(d, a.out);
  if (!a.sheet.empty()) write_sheet(a.sheet, d, rest.lengths);

  int struts = 0, cables = 0;
  for (const auto& el : d.structure.elements) (el.kind == ElementKind::Strut ? struts : cables)++;
  std::cerr << "design: " << scene.name << ": " << struts << " struts, " << cables << " cables, cable strain "
            << text(100 * strain_lo) << "% .. " << text(100 * strain_hi) << "%, relative residual "
            << text(v.relative_residual) << (v.ok ? "" : " (does not verify)") << "\n";
  return v.ok ? 0 : 1;
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
                  "Cable material name or file (default elastic-cord-1mm); elements may carry material");
  cmd->add_option("--material-dir", args->material_dirs, "Extra folder to look for NAME.json in (repeatable)");
  cmd->add_option("--naive-fraction", args->naive_fraction,
                  "Baseline: every cable's rest length = F * its length, in (0, 1] (no stiffness scaling)");
  cmd->add_option("--solver", args->solver, "Form-finding backend when the input is not in equilibrium");
  cmd->add_option("--tol", args->tol, "Relative residual for form finding and verification");
  cmd->add_option("--time-limit", args->time_limit, "Form-finding wall-clock budget in seconds");
  cmd->add_option("--out", args->out, "Design file to write, - for standard output")->required();
  cmd->add_option("--sheet", args->sheet, "Fabrication sheet (CSV) to write");
  cmd->callback([args, &run] { run = [args] { return run_design(*args); }; });
}

}  // namespace tensegrity::cli
