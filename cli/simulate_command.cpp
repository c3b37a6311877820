// tensegrity simulate DESIGN --dt H --steps N [--gravity gx,gy,gz] [--drag NODE:x,y,z]...
//   [--drag-script FILE] [--drag-stiffness K] [--damping A] [--stiffness-damping B]
//   --out FRAMES.jsonl [--every K] [--no-vtk] [--render FILMSTRIP.png]
//
// Implicit Euler on the built design (simulation/simulator.hpp). Writes one JSON
// line per output frame, a legacy-VTK file per frame beside FRAMES
// (FRAMES-stem.NNNNNN.vtk) with a ParaView FRAMES-stem.vtk.series, and with
// --render a PNG filmstrip of six frames. On standard error: a status line
// rewritten in place on a terminal (cli/progress.hpp), else a line at every
// tenth of the run; a line for every step whose Newton solve failed even in
// the smallest substeps (simulation/simulator.hpp); and a summary.
#include <cairo.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <sstream>

#include "cli/commands.hpp"
#include "reports/exporters.hpp"
#include "cli/progress.hpp"
#include "reports/renderer.hpp"
#include "model/design.hpp"
#include "model/errors.hpp"
#include "model/scene_io.hpp"
#include "simulation/simulator.hpp"

namespace tensegrity::cli {

namespace {

struct SimulateArgs {
  std::string design, out, render, drag_script, gravity;
  std::vector<std::string> drags;
  double dt = 1.0 / 60.0;
  int steps = 60;
  int every = 1;
  double drag_stiffness = std::nan("");
  double damping = 0.0, stiffness_damping = 0.0;
  double tol = 1e-9;
  bool no_vtk = false, quiet = false;
};

std::vector<double> numbers_in(const std::string& text, const std::string& item, std::size_t count) {
  std::vector<double> v;
  std::string t = text;
  std::replace(t.begin(), t.end(), ',', ' ');
  std::istringstream in(t);
  std::string word;
  while (in >> word) {
    char* end = nullptr;
    const double x = std::strtod(word.c_str(), &end);
    if (end == word.c_str() || *end != '\0' || !std::isfinite(x))
      throw InputError("command line", item, "'" + word + "' is not a finite number");
    v.push_back(x);
  }
  if (v.size() != count)
    throw InputError("command line", item, "expected " + std::to_string(count) + " numbers in '" + text + "'");
  return v;
}

Eigen::Vector3d vector_option(const std::string& text, const std::string& item) {
  const auto v = numbers_in(text, item, 3);
  return {v[0], v[1], v[2]};
}

// Piecewise-linear target of one dragged node over time.
struct DragTrack {
  int node = 0;
  std::vector<std::pair<double, Eigen::Vector3d>> keys;  // sorted by time
  Eigen::Vector3d at(double t) const {
    if (t <= keys.front().first) return keys.front().second;
    if (t >= keys.back().first) return keys.back().second;
    auto it = std::upper_bound(keys.begin(), keys.end(), t, [](double v, const auto& k) { return v < k.first; });
    const auto& [t1, x1] = *it;
    const auto& [t0, x0] = *(it - 1);
    return x0 + (t - t0) / (t1 - t0) * (x1 - x0);
  }
};

void check_node(int node, int n, const std::string& source, const std::string& item) {
  if (node < 0 || node >= n)
    throw InputError(source, item, "node " + std::to_string(node) + " is out of range [0, " + std::to_string(n) + ")");
}

// Lines "time node x y z" (commas or spaces); '#' starts a comment.
std::map<int, DragTrack> read_drag_script(const std::string& path, int n) {
  std::ifstream in(path);
  if (!in) throw InputError(path, "", "cannot read the drag script");
  std::map<int, DragTrack> tracks;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    if (const auto hash = line.find('#'); hash != std::string::npos) line.erase(hash);
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream s(line);
    double t, x, y, z;
    int node;
    if (!(s >> t)) continue;
    const std::string item = "line " + std::to_string(number);
    if (!(s >> node >> x >> y >> z) || !std::isfinite(t) || !std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z))
      throw InputError(path, item, "expected 'time node x y z' with finite numbers");
    check_node(node, n, path, item);
    auto& tr = tracks[node];
    tr.node = node;
    if (!tr.keys.empty() && t <= tr.keys.back().first)
      throw InputError(path, item, "times of one node must increase");
    tr.keys.emplace_back(t, Eigen::Vector3d(x, y, z));
  }
  if (tracks.empty()) throw InputError(path, "", "no drag key found");
  return tracks;
}

std::string g17(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

// The same arrays as `tensegrity export` (cli/exporters.hpp).
void write_vtk(const std::string& path, const Structure& s, const Eigen::Matrix3Xd& x, const Eigen::VectorXd& forces,
               double time) {
  const std::string title = "tensegrity " + s.name + " t=" + g17(time);
  write_text_file_atomically(path, reports::export_lines(s, x, forces, reports::ExportFormat::Vtk, title));
}

// Six evenly spaced frames side by side.
void write_filmstrip(const std::string& path, const Structure& s,
                     const std::vector<std::pair<double, std::pair<Eigen::Matrix3Xd, Eigen::VectorXd>>>& frames) {
  const int count = std::min<int>(6, static_cast<int>(frames.size()));
  const int w = 400, h = 400;
  cairo_surface_t* strip = cairo_image_surface_create(CAIRO_FORMAT_ARGB32, w * count, h);
  cairo_t* cr = cairo_create(strip);
  const std::string tmp = path + ".frame.png";
  for (int k = 0; k < count; ++k) {
    const int index = count == 1 ? 0 : static_cast<int>(std::lround(double(k) * (frames.size() - 1) / (count - 1)));
    reports::RenderOptions ro;
    ro.width = w;
    ro.height = h;
    char title[64];
    std::snprintf(title, sizeof title, "t = %.3f s", frames[index].first);
    ro.title = title;
    reports::render_scene(s, frames[index].second.first, frames[index].second.second, ro, tmp);
    cairo_surface_t* img = cairo_image_surface_create_from_png(tmp.c_str());
    cairo_set_source_surface(cr, img, k * w, 0);
    cairo_paint(cr);
    cairo_surface_destroy(img);
  }
  std::filesystem::remove(tmp);
  const cairo_status_t st = cairo_surface_write_to_png(strip, path.c_str());
  cairo_destroy(cr);
  cairo_surface_destroy(strip);
  if (st != CAIRO_STATUS_SUCCESS) throw std::runtime_error("cannot write " + path);
}

int run_simulate(const SimulateArgs& a) {
  if (!(std::isfinite(a.dt) && a.dt > 0)) throw InputError("command line", "--dt", "must be a finite number > 0");
  if (a.steps < 0) throw InputError("command line", "--steps", "must be >= 0");
  if (a.every < 1) throw InputError("command line", "--every", "must be >= 1");
  if (!(a.damping >= 0 && std::isfinite(a.damping))) throw InputError("command line", "--damping", "must be >= 0");
  if (!(a.stiffness_damping >= 0 && std::isfinite(a.stiffness_damping)))
    throw InputError("command line", "--stiffness-damping", "must be >= 0");
  const Design design = read_design_file(a.design);
  const ElasticModel model = make_elastic_model(design);
  const Structure& s = model.structure;
  const int n = s.num_nodes();
  if (!(s.lumped_mass().sum() > 0.0)) throw InputError(a.design, "mass", "the design has no mass to simulate");
  const Eigen::Vector3d gravity = a.gravity.empty() ? s.gravity : vector_option(a.gravity, "--gravity");

  double k_drag = a.drag_stiffness;
  if (std::isnan(k_drag)) k_drag = model.force_scale / (0.05 * model.length_scale);
  if (!(std::isfinite(k_drag) && k_drag > 0)) throw InputError("command line", "--drag-stiffness", "must be > 0");
  std::map<int, DragTrack> tracks;
  if (!a.drag_script.empty()) tracks = read_drag_script(a.drag_script, n);
  for (const std::string& d : a.drags) {
    const auto colon = d.find(':');
    if (colon == std::string::npos) throw InputError("command line", "--drag", "expected NODE:x,y,z, got '" + d + "'");
    const auto node = numbers_in(d.substr(0, colon), "--drag", 1)[0];
    if (node != std::floor(node)) throw InputError("command line", "--drag", "node must be an integer");
    check_node(static_cast<int>(node), n, "command line", "--drag");
    DragTrack tr;
    tr.node = static_cast<int>(node);
    tr.keys.emplace_back(0.0, vector_option(d.substr(colon + 1), "--drag"));
    tracks[tr.node] = tr;
  }

  SimulationOptions so;
  so.time_step = a.dt;
  so.mass_damping = a.damping;
  so.stiffness_damping = a.stiffness_damping;
  so.tolerance = a.tol;
  Simulator sim(model, gravity, so);

  namespace fs = std::filesystem;
  const fs::path out(a.out);
  std::string stem = out.filename().string();
  for (const char* ext : {".jsonl", ".json"})
    if (stem.ends_with(ext)) stem.resize(stem.size() - std::string(ext).size());
  const fs::path dir = out.has_parent_path() ? out.parent_path() : fs::path(".");
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw InputError(a.out, "", "cannot create the folder " + dir.string() + ": " + ec.message());
  std::ostringstream lines;
  nlohmann::json series = {{"file-series-version", "1.0"}, {"files", nlohmann::json::array()}};
  std::vector<std::pair<double, std::pair<Eigen::Matrix3Xd, Eigen::VectorXd>>> kept;

  auto emit = [&](int step, const StepReport* r) {
    const Eigen::VectorXd f = sim.element_forces();
    nlohmann::json j;
    j["format"] = "tensegrity-simulation-frame";
    j["version"] = 1;
    j["step"] = step;
    j["time"] = sim.time();
    nlohmann::json pos = nlohmann::json::array();
    for (int i = 0; i < n; ++i) pos.push_back({sim.positions()(0, i), sim.positions()(1, i), sim.positions()(2, i)});
    j["positions"] = std::move(pos);
    j["forces"] = std::vector<double>(f.data(), f.data() + f.size());
    j["kinetic_energy"] = sim.kinetic_energy();
    j["potential_energy"] = sim.potential_energy();
    if (r) {
      j["newton_iterations"] = r->newton_iterations;
      j["converged"] = r->converged;
      j["substeps"] = r->substeps;
      j["seconds"] = r->seconds;
    }
    nlohmann::json drags = nlohmann::json::array();
    for (const DragSpring& d : sim.drags()) drags.push_back({{"node", d.node}, {"target", {d.target.x(), d.target.y(), d.target.z()}}});
    j["drags"] = std::move(drags);
    lines << j.dump() << '\n';
    if (!a.no_vtk) {
      char name[64];
      std::snprintf(name, sizeof name, ".%06d.vtk", step);
      const std::string file = stem + name;
      write_vtk((dir / file).string(), s, sim.positions(), f, sim.time());
      series["files"].push_back({{"name", file}, {"time", sim.time()}});
    }
    if (!a.render.empty()) kept.push_back({sim.time(), {sim.positions(), f}});
  };

  emit(0, nullptr);
  const bool on_terminal = stderr_is_terminal();
  ProgressLine progress(on_terminal && !a.quiet);
  char status[160];
  int last_tenth = 0;
  int failed = 0, total_newton = 0, split = 0, most_substeps = 1;
  double total_seconds = 0.0, worst = 0.0;
  for (int k = 1; k <= a.steps; ++k) {
    std::vector<DragSpring> drags;
    for (const auto& [node, tr] : tracks) drags.push_back({node, tr.at(sim.time() + a.dt), k_drag});
    sim.set_drags(std::move(drags));
    const StepReport r = sim.step();
    failed += r.converged ? 0 : 1;
    split += r.substeps > 1 ? 1 : 0;
    most_substeps = std::max(most_substeps, r.substeps);
    total_newton += r.newton_iterations;
    total_seconds += r.seconds;
    worst = std::max(worst, r.seconds);
    if (!a.quiet) {
      if (!r.converged) {
        progress.clear();
        std::fprintf(stderr, "simulate: step %d t=%.4f s newton=%d%s substeps=%d time=%.3f ms NOT CONVERGED\n", k,
                     sim.time(), r.newton_iterations, r.definite_fallbacks ? " (definite)" : "", r.substeps,
                     1e3 * r.seconds);
      }
      if (progress.due() || (k == a.steps && progress.shown())) {
        std::snprintf(status, sizeof status, "simulate: step %d/%d, t = %.4f s, %.1f s elapsed", k, a.steps,
                      sim.time(), progress.elapsed());
        progress.show(status);
      }
      // Without a terminal, a line at every tenth of the run.
      const int tenth = 10 * k / a.steps;
      if (!on_terminal && tenth > last_tenth) {
        last_tenth = tenth;
        std::fprintf(stderr,
                     "simulate: step %d/%d (%d %%), t = %.4f s, %.2f Newton iterations per step, %d not converged, "
                     "%.1f s elapsed\n",
                     k, a.steps, 100 * k / a.steps, sim.time(), double(total_newton) / k, failed, progress.elapsed());
      }
    }
    if (k % a.every == 0 || k == a.steps) emit(k, &r);
  }
  progress.finish();
  write_text_file_atomically(a.out, lines.str());
  if (!a.no_vtk) write_text_file_atomically((dir / (stem + ".vtk.series")).string(), series.dump(2) + "\n");
  if (!a.render.empty()) write_filmstrip(a.render, s, kept);
  Eigen::Matrix3Xd moved = sim.positions() - model.reference;
  // --quiet keeps the summary of a run with failed steps: it says how many.
  if (!a.quiet || failed > 0)
    std::fprintf(stderr,
               "simulate: %s: %d steps of %.4g s, %d Newton iterations (%.2f per step), %.3f ms per step (max %.3f), "
               "%d split into substeps (up to %d per step), %d not converged; largest displacement from the design "
               "%.4g m (%.3g of its size)\n",
               s.name.c_str(), a.steps, a.dt, total_newton, a.steps ? double(total_newton) / a.steps : 0.0,
               a.steps ? 1e3 * total_seconds / a.steps : 0.0, 1e3 * worst, split, most_substeps, failed,
               moved.colwise().norm().maxCoeff(), moved.colwise().norm().maxCoeff() / model.length_scale);
  return failed ? 1 : 0;
}

}  // namespace

void register_simulate_command(CLI::App& app, CommandRunner& run) {
  auto args = std::make_shared<SimulateArgs>();
  auto* cmd = app.add_subcommand("simulate", "Implicit-Euler simulation of a design, with scripted drags");
  cmd->add_option("design", args->design, "Design file (tensegrity design --out)")->required();
  cmd->add_option("--dt", args->dt, "Time step in s (default 1/60)");
  cmd->add_option("--steps", args->steps, "Number of steps (default 60)");
  cmd->add_option("--gravity", args->gravity, "gx,gy,gz in m/s^2 (default: the design's)");
  cmd->add_option("--drag", args->drags, "NODE:x,y,z: pull NODE toward a fixed target (repeatable)");
  cmd->add_option("--drag-script", args->drag_script, "Lines 'time node x y z': piecewise-linear drag targets");
  cmd->add_option("--drag-stiffness", args->drag_stiffness,
                  "Drag spring stiffness in N/m (default: largest designed force per 5% of the size)");
  cmd->add_option("--damping", args->damping, "Mass-proportional damping alpha in 1/s (force -alpha M v)");
  cmd->add_option("--stiffness-damping", args->stiffness_damping, "Stiffness-proportional damping beta in s");
  cmd->add_option("--tol", args->tol, "Newton tolerance, relative to the largest designed force");
  cmd->add_option("--out", args->out, "Frames as JSON Lines (VTK files are written beside it)")->required();
  cmd->add_option("--every", args->every, "Write every K-th step (default 1)");
  cmd->add_flag("--no-vtk", args->no_vtk, "Do not write the VTK series");
  cmd->add_option("--render", args->render, "PNG filmstrip of six frames");
  cmd->add_flag("--quiet", args->quiet,
                "No progress and no summary on stderr unless a step fails (errors still print)");
  cmd->callback([args, &run] { run = [args] { return run_simulate(*args); }; });
}

}  // namespace tensegrity::cli
