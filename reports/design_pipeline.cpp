#include "reports/design_pipeline.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <map>
#include <sstream>

#include "reports/output.hpp"
#include "formulations/force_scale.hpp"
#include "model/character.hpp"
#include "model/errors.hpp"
#include "model/scene_io.hpp"
#include "model/verify.hpp"
#include "design/force_cap.hpp"
#include "design/naive_sweep.hpp"
#include "design/stiffness_solver.hpp"
#include "model/json_text.hpp"

namespace tensegrity::reports {

namespace {

// Scenes, characters (assembled on the fly) and earlier designs are accepted.
Structure read_design_input_impl(const std::string& path) {
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
CableMaterial find_material_impl(const std::string& name, const std::vector<std::string>& extra_dirs,
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

// Whether the forces respect the prestress cap of every part with weight.
bool within_prestress_cap(const Structure& scene, const Eigen::VectorXd& forces, const SolveOptions& options) {
  return !exceeds_prestress_cap(make_force_scale(scene, options.margin_fraction, options.prestress_factor), forces);
}

// "elements[E] (cable of block B)": the element as a message names it.
std::string element_description(const Structure& s, int e) {
  std::string name = "elements[" + std::to_string(e) + "] (" +
                     (s.elements[e].kind == ElementKind::Cable ? "cable" : "strut");
  const nlohmann::json& extra = s.element_extra[e];
  for (const char* group : {"block", "link"})
    if (extra.contains(group))
      name += std::string(" of ") + group + " " +
              (extra.at(group).is_string() ? extra.at(group).get<std::string>() : extra.at(group).dump());
  return name + ")";
}

// Why the stiffness QP found no forces: measure the smallest achievable
// overload of the material caps (design/force_cap.hpp) and name the cable.
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
    r << element_description(s, e) << ": no equilibrium at the form-found geometry keeps every cable inside its "
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
}  // namespace

Structure read_design_input(const std::string& path) { return read_design_input_impl(path); }

CableMaterial find_material(const std::string& name, const std::vector<std::string>& extra_dirs,
                            const std::string& item) {
  return find_material_impl(name, extra_dirs, item);
}

void check_design_request(const DesignRequest& req) {
  const bool naive = !std::isnan(req.naive_fraction);
  if (naive && (!std::isfinite(req.naive_fraction) || !(req.naive_fraction > 0.0) || req.naive_fraction > 1.0))
    throw InputError(req.options_source, "--naive-fraction",
                     "must be a number in (0, 1], got " + message_number(req.naive_fraction));
  if (!std::isfinite(req.strain) || !(req.strain > -1.0))
    throw InputError(req.options_source, "--strain", "must be a finite number > -1, got " + message_number(req.strain));
}

DesignOutcome design_structure(const Structure& scene, const std::string& input, const DesignRequest& req,
                               const Solver& solver) {
  check_design_request(req);
  const bool naive = !std::isnan(req.naive_fraction);
  SolveOptions options;
  options.tolerance = req.tol;
  options.time_limit_s = req.time_limit;
  const int m = scene.num_elements();
  DesignOutcome out;
  auto fail = [&out](std::string item, std::string reason) {
    out.failure_item = std::move(item);
    out.failure_reason = std::move(reason);
    return std::move(out);
  };

  // Materials: --material for every cable unless the element names its own.
  Design d;
  d.cable_material.assign(m, "");
  std::map<std::string, std::string> resolved;  // requested name or path -> material name
  for (int e = 0; e < m; ++e) {
    if (scene.elements[e].kind != ElementKind::Cable) continue;
    std::string name = req.material;
    std::string item = "--material";
    const auto& extra = scene.element_extra[e];
    if (extra.contains("material")) {
      item = "elements[" + std::to_string(e) + "].material";
      if (!extra.at("material").is_string()) throw InputError(input, item, "expected a material name");
      name = extra.at("material").get<std::string>();
    }
    // A file path resolves to the material's own name.
    auto known = resolved.find(name);
    if (known == resolved.end()) {
      CableMaterial mat = find_material(name, req.material_dirs, item);
      const auto clash = d.materials.find(mat.name);
      if (clash != d.materials.end() && material_to_json(clash->second) != material_to_json(mat))
        throw InputError(req.options_source, item, "two different materials are named '" + mat.name + "'");
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
    target_strain[e] = req.strain;
    if (extra.contains("target_strain")) {
      item = "elements[" + std::to_string(e) + "].target_strain";
      target_strain[e] = extra.at("target_strain").is_number() ? extra.at("target_strain").get<double>() : NAN;
    }
    const CableMaterial& mat = *materials_of[e];
    if (!naive && !mat.in_range(target_strain[e]))
      throw InputError(item == "--strain" ? req.options_source : input, item,
                       "strain " + message_number(target_strain[e]) + " is outside the measured range [" + message_number(mat.strain_min) +
                           ", " + message_number(mat.strain_max) + "] of material '" + mat.name + "'");
    if (!naive) targets[e] = mat.force(target_strain[e]);
  }
  // The baseline's one strain must be inside every material before any work.
  if (naive) {
    const RestLengthDesign check = naive_rest_lengths(scene, scene.positions, req.naive_fraction, materials_of);
    if (!check.ok) throw InputError(req.options_source, "--naive-fraction", check.message);
  }

  // Stage 1: form finding, unless the input geometry already stands with a
  // prestress a cord can be designed for (mean cable force at most kappa
  // times the weight, the cap of `solve`, so that a design fits the geometry
  // `solve` returns): a near-mechanism may stand only on huge forces, and
  // then Eq. 5 with that cap moves it a little instead.
  const SolveOptions& form_options = options;
  SolveResult ff = solve_forces_only(scene, form_options);
  std::string form_solver = "none (already in equilibrium)";
  if (ff.status != Status::Converged || !within_prestress_cap(scene, ff.forces, form_options)) {
    ff = solver.Solve(scene, form_options, DriverControls{false});
    form_solver = std::string(solver.name());
    if (!req.quiet) std::cerr << summary_line(scene, form_solver, ff) << "\n";
    if (ff.status != Status::Converged)
      return fail("form finding", std::string(to_string(ff.status)) + ": " + ff.message);
  }
  d.structure = scene;
  d.structure.positions = ff.positions;
  d.structure.name = scene.name;

  nlohmann::json info = nlohmann::json::object();
  info["mode"] = naive ? "naive" : "stiffness";
  info["input"] = std::filesystem::path(input).filename().string();
  info["form_finding"] = {{"solver", form_solver},
                          {"status", std::string(to_string(ff.status))},
                          {"iterations", ff.stats.iterations},
                          {"geometry_change", ff.stats.geometry_change}};

  Eigen::VectorXd forces = ff.forces;
  RestLengthDesign rest;
  if (naive) {
    info["naive_fraction"] = req.naive_fraction;
    rest = naive_rest_lengths(d.structure, d.structure.positions, req.naive_fraction, materials_of);
    if (!rest.ok) throw InputError(req.options_source, "--naive-fraction", rest.message);
    // What the cables actually pull with at these rest lengths.
    const Eigen::VectorXd pulled =
        cable_forces_from_rest_lengths(d.structure, d.structure.positions, rest.rest_lengths, materials_of);
    info["material_forces"] = std::vector<double>(pulled.data(), pulled.data() + m);
  } else {
    // Stage 2: stiffness scaling, with each cable kept inside its material's
    // measured force range so that stage 3 always has a strain.
    info["target_strain"] = req.strain;
    const ForceScale fs = make_force_scale(d.structure, options.margin_fraction);
    StiffnessProblem problem = make_stiffness_problem(d.structure, targets, fs.margin);
    for (int e = 0; e < m; ++e)
      if (materials_of[e]) {
        problem.lower[e] = std::max(problem.lower[e], materials_of[e]->force_min());
        problem.upper[e] = materials_of[e]->force_max();
      }
    StiffnessOptions so;
    so.tolerance = req.tol;  // the geometry itself is only in equilibrium to this level
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
    if (!req.quiet)
      std::cerr << "design: stiffness QP " << to_string(qr.status) << ": " << qr.message << ", relative residual "
              << message_number(qr.relative_residual) << ", max |sigma - target| " << message_number(qr.max_target_deviation) << " N, "
              << qr.active_bounds << " bounds active\n";
    if (qr.status != Status::Converged)
      return fail("", stiffness_failure_reason(d, problem, qr, fs.margin));
    forces = qr.sigma;
    // Stage 3: rest lengths. The QP's bounds keep every force in range, so a
    // failure here is a solver defect, reported like one.
    rest = compute_rest_lengths(d.structure, d.structure.positions, forces, materials_of);
    if (!rest.ok)
      return fail(element_description(d.structure, rest.out_of_range.front()), "rest length: " + rest.message);
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
    return fail("verification",
                     "the designed forces do not verify (relative residual " + message_number(v.relative_residual) +
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

  out.ok = true;
  out.design = std::move(d);
  out.rest = std::move(rest);
  out.strain_range = {strain_lo, strain_hi};
  return out;
}

}  // namespace tensegrity::reports
