#include "cli/stress_test.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <mutex>
#include <random>
#include <set>
#include <thread>

#include "bench/large_scenes.hpp"
#include "model/character.hpp"
#include "model/errors.hpp"
#include "model/reference_scenes.hpp"
#include "model/scene_io.hpp"
#include "model/verify.hpp"

namespace tensegrity::cli {

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// ---------------------------------------------------------------- base scenes

void add_reference_scenes(std::vector<StressBaseScene>& out) {
  // The same parameters as `tensegrity generate reference` (data/reference/).
  auto add = [&out](Structure s, const std::string& name) {
    s.name = name;
    out.push_back({name, "reference", std::move(s)});
  };
  for (int n = 3; n <= 12; ++n) {
    PrismParameters p;
    p.n = n;
    add(make_regular_prism(p), "prism-" + std::to_string(n));
    p.gravity = p.fix_bottom = true;
    p.strut_mass = 0.05;
    p.cable_mass = 0.005;
    add(make_regular_prism(p), "prism-" + std::to_string(n) + "-gravity");
  }
  OctahedronParameters o;
  add(make_expandable_octahedron(o), "octahedron");
  o.gravity = o.fix_bottom = true;
  o.strut_mass = 0.05;
  o.cable_mass = 0.005;
  add(make_expandable_octahedron(o), "octahedron-gravity");
}

// The stored equilibria of the 80-strut / 500-cable tower (bench/large_scenes.hpp),
// when the data folder has them.
void add_towers(std::vector<StressBaseScene>& out, const std::string& data_dir) {
  for (bool gravity : {false, true}) {
    const fs::path file =
        fs::path(data_dir) / "bench" / (std::string("tower-80s-500c") + (gravity ? "-gravity" : "") + ".scene.json");
    std::error_code ec;
    if (data_dir.empty() || !fs::is_regular_file(file, ec)) continue;
    Structure s = bench::tower_equilibrium(data_dir, gravity);
    s.name = std::string("tower-80s-500c") + (gravity ? "-gravity" : "");
    out.push_back({s.name, "tower", std::move(s)});
  }
}

void add_characters(std::vector<StressBaseScene>& out, const std::string& data_dir) {
  const fs::path dir = fs::path(data_dir) / "characters";
  std::error_code ec;
  if (data_dir.empty() || !fs::is_directory(dir, ec)) return;
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(dir, ec))
    if (entry.path().string().ends_with(".character.json")) files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  for (const fs::path& file : files) {
    BuiltCharacter c = build_character_file(file.string());
    std::string name = file.filename().string();
    name.erase(name.size() - std::string(".character.json").size());
    c.structure.name = name;
    out.push_back({name, "character", std::move(c.structure)});
  }
}

// ---------------------------------------------------------------- perturbations

double median_element_length(const Structure& s) {
  std::vector<double> lengths;
  for (const Element& e : s.elements) lengths.push_back((s.positions.col(e.b) - s.positions.col(e.a)).norm());
  if (lengths.empty()) return 1.0;
  std::nth_element(lengths.begin(), lengths.begin() + lengths.size() / 2, lengths.end());
  const double l = lengths[lengths.size() / 2];
  return l > 0.0 && std::isfinite(l) ? l : 1.0;
}

// A point uniformly distributed in the unit ball.
Eigen::Vector3d in_unit_ball(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (;;) {
    const Eigen::Vector3d d(u(rng), u(rng), u(rng));
    if (d.squaredNorm() <= 1.0) return d;
  }
}

Eigen::Vector3d on_unit_sphere(std::mt19937_64& rng) {
  for (;;) {
    const Eigen::Vector3d d = in_unit_ball(rng);
    if (d.norm() > 1e-3) return d.normalized();
  }
}

void add_noise(Structure& s, double radius, std::mt19937_64& rng) {
  for (int i = 0; i < s.num_nodes(); ++i)
    if (!s.fixed[i]) s.positions.col(i) += radius * in_unit_ball(rng);
}

std::vector<int> free_nodes(const Structure& s) {
  std::vector<int> nodes;
  for (int i = 0; i < s.num_nodes(); ++i)
    if (!s.fixed[i]) nodes.push_back(i);
  return nodes;
}

int pick(const std::vector<int>& items, std::mt19937_64& rng) {
  std::uniform_int_distribution<std::size_t> u(0, items.size() - 1);
  return items[u(rng)];
}

// Fixes the three nodes lying furthest along `down` when no node is fixed, so
// that a gravity load has supports.
void ensure_supports(Structure& s, const Eigen::Vector3d& down) {
  if (std::any_of(s.fixed.begin(), s.fixed.end(), [](bool f) { return f; })) return;
  std::vector<std::pair<double, int>> depth;
  for (int i = 0; i < s.num_nodes(); ++i) depth.push_back({-s.positions.col(i).dot(down), i});
  std::sort(depth.begin(), depth.end());
  for (int k = 0; k < std::min(3, s.num_nodes() - 1); ++k) s.fixed[depth[k].second] = true;
}

void twist_upper_half(Structure& s, double degrees) {
  std::vector<double> z(s.num_nodes());
  for (int i = 0; i < s.num_nodes(); ++i) z[i] = s.positions(2, i);
  std::vector<double> sorted = z;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  const double median_z = sorted[sorted.size() / 2];
  std::vector<int> upper;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (int i = 0; i < s.num_nodes(); ++i)
    if (!s.fixed[i] && z[i] > median_z) {
      upper.push_back(i);
      centre += s.positions.col(i);
    }
  if (upper.empty()) return;
  centre /= static_cast<double>(upper.size());
  const double a = degrees * M_PI / 180.0;
  Eigen::Matrix3d r;
  r << std::cos(a), -std::sin(a), 0.0, std::sin(a), std::cos(a), 0.0, 0.0, 0.0, 1.0;
  for (int i : upper) s.positions.col(i) = centre + r * (s.positions.col(i) - centre);
}

void make_near_coincident(Structure& s, double distance, std::mt19937_64& rng) {
  const std::vector<int> movable = free_nodes(s);
  const int j = pick(movable, rng);
  std::vector<int> others;
  for (int i = 0; i < s.num_nodes(); ++i)
    if (i != j) others.push_back(i);
  const int i = pick(others, rng);
  s.positions.col(j) = s.positions.col(i) + distance * on_unit_sphere(rng);
}

void make_near_parallel(Structure& s, double angle, std::mt19937_64& rng) {
  // Pairs of elements (a, b), (a, c) sharing node a with c free.
  std::vector<std::vector<int>> touching(s.num_nodes());
  for (int e = 0; e < s.num_elements(); ++e) {
    touching[s.elements[e].a].push_back(e);
    touching[s.elements[e].b].push_back(e);
  }
  std::vector<int> hubs;
  for (int a = 0; a < s.num_nodes(); ++a)
    if (touching[a].size() >= 2) hubs.push_back(a);
  if (hubs.empty()) return;
  const int a = pick(hubs, rng);
  auto other_end = [&](int e) { return s.elements[e].a == a ? s.elements[e].b : s.elements[e].a; };
  std::vector<int> free_ends;
  for (int e : touching[a])
    if (!s.fixed[other_end(e)]) free_ends.push_back(e);
  if (free_ends.empty()) return;
  const int moved = pick(free_ends, rng);
  std::vector<int> guides;
  for (int e : touching[a])
    if (e != moved) guides.push_back(e);
  const int guide = pick(guides, rng);
  const int b = other_end(guide), c = other_end(moved);
  const Eigen::Vector3d xa = s.positions.col(a);
  const Eigen::Vector3d u = (s.positions.col(b) - xa).normalized();
  const Eigen::Vector3d v = s.positions.col(c) - xa;
  Eigen::Vector3d w = v - v.dot(u) * u;
  if (w.norm() < 1e-12 * v.norm()) w = u.unitOrthogonal();
  w.normalize();
  s.positions.col(c) = xa + v.norm() * (std::cos(angle) * u + std::sin(angle) * w);
}

const std::vector<std::string>& family_names() {
  static const std::vector<std::string> names = {"noise", "twist", "scale", "length-ratio", "near-coincident",
                                                 "near-parallel", "mass", "gravity-direction"};
  return names;
}

std::string number_label(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%g", v);
  return buffer;
}

std::vector<StressLevel> levels_of(std::initializer_list<double> values, const std::string& unit = "") {
  std::vector<StressLevel> levels;
  for (double v : values) levels.push_back({v, number_label(v) + unit});
  return levels;
}

// FNV-1a over raw bytes.
struct Digest {
  std::uint64_t h = 1469598103934665603ull;
  void bytes(const void* p, std::size_t n) {
    const auto* c = static_cast<const unsigned char*>(p);
    for (std::size_t i = 0; i < n; ++i) {
      h ^= c[i];
      h *= 1099511628211ull;
    }
  }
  void number(double v) { bytes(&v, sizeof v); }
  void integer(std::uint64_t v) { bytes(&v, sizeof v); }
};

std::uint64_t string_hash(const std::string& s) {
  Digest d;
  d.bytes(s.data(), s.size());
  return d.h;
}

bool finite_result(const SolveResult& r) {
  if (!r.positions.allFinite() || !r.forces.allFinite()) return false;
  const SolutionStats& st = r.stats;
  for (double v : {st.seconds, st.residual, st.relative_residual, st.geometry_change})
    if (!std::isfinite(v)) return false;
  for (const TracePoint& p : r.trace)
    for (double v : {p.seconds, p.residual, p.relative_residual, p.geometry_change, p.objective})
      if (!std::isfinite(v)) return false;
  return true;
}

std::vector<std::string> split_names(const std::vector<std::string>& items) {
  std::vector<std::string> out;
  for (const std::string& item : items) {
    std::size_t start = 0;
    while (start <= item.size()) {
      const std::size_t comma = item.find(',', start);
      const std::string name = item.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
      if (!name.empty()) out.push_back(name);
      if (comma == std::string::npos) break;
      start = comma + 1;
    }
  }
  return out;
}

struct Case {
  const StressBaseScene* base = nullptr;
  std::string family, level;
  int trial = 0;
  Structure scene;
  bool rejected = false;
  std::string rejection;
};

}  // namespace

std::vector<StressBaseScene> stress_base_scenes(const std::string& data_dir) {
  std::vector<StressBaseScene> out;
  add_reference_scenes(out);
  add_towers(out, data_dir);
  add_characters(out, data_dir);
  return out;
}

std::vector<std::string> stress_family_names() { return family_names(); }

std::vector<StressLevel> stress_family_levels(const std::string& family) {
  if (family == "noise") return levels_of({0.001, 0.003, 0.01, 0.03, 0.1, 0.3});
  if (family == "twist") return levels_of({1, 5, 15, 30}, "deg");
  if (family == "scale") return levels_of({1e-4, 1e-2, 1e2, 1e4});
  if (family == "length-ratio") return levels_of({10, 100, 1e3, 1e4});
  if (family == "near-coincident") return levels_of({1e-2, 1e-4, 1e-6, 1e-9});
  if (family == "near-parallel") return levels_of({1e-2, 1e-4, 1e-6}, "rad");
  if (family == "mass") return levels_of({0, 1e-6, 1e-2, 1, 1e2, 1e4, 1e6}, "kg");
  if (family == "gravity-direction") {
    std::vector<StressLevel> levels;
    for (const char* label : {"+x", "-x", "+y", "-y", "+z", "-z", "random"})
      levels.push_back({static_cast<double>(levels.size()), label});
    return levels;
  }
  std::string known;
  for (const auto& f : family_names()) known += (known.empty() ? "" : ", ") + f;
  throw InputError("command line", "--families " + family, "unknown family (known: " + known + ")");
}

Structure make_stress_case(const Structure& base, const std::string& family, int level_index, int trial,
                           std::uint64_t seed) {
  const std::vector<StressLevel> levels = stress_family_levels(family);
  const double level = levels.at(level_index).value;
  std::seed_seq seq{static_cast<std::uint32_t>(seed), static_cast<std::uint32_t>(seed >> 32),
                    static_cast<std::uint32_t>(string_hash(base.name)),
                    static_cast<std::uint32_t>(string_hash(family)), static_cast<std::uint32_t>(level_index),
                    static_cast<std::uint32_t>(trial)};
  std::mt19937_64 rng(seq);
  Structure s = base;
  const double length = median_element_length(base);
  constexpr double kSmallNoise = 0.01;
  if (family == "noise") {
    add_noise(s, level * length, rng);
  } else if (family == "twist") {
    twist_upper_half(s, level);
  } else if (family == "scale") {
    s.positions *= level;
    add_noise(s, kSmallNoise * level * length, rng);
  } else if (family == "length-ratio") {
    s.positions.row(2) *= level;
    add_noise(s, kSmallNoise * length, rng);
  } else if (family == "near-coincident") {
    add_noise(s, kSmallNoise * length, rng);
    make_near_coincident(s, level * length, rng);
  } else if (family == "near-parallel") {
    add_noise(s, kSmallNoise * length, rng);
    make_near_parallel(s, level, rng);
  } else if (family == "mass") {
    s.gravity = Eigen::Vector3d(0.0, 0.0, -9.81);
    ensure_supports(s, s.gravity);
    for (int i = 0; i < s.num_nodes(); ++i) s.node_mass[i] = s.fixed[i] ? 0.0 : level;
    if (level == 0.0)
      for (Element& e : s.elements) e.mass = 0.0;
    add_noise(s, kSmallNoise * length, rng);
  } else if (family == "gravity-direction") {
    Eigen::Vector3d down = Eigen::Vector3d::Zero();
    if (level_index < 6)
      down[level_index / 2] = level_index % 2 == 0 ? 1.0 : -1.0;
    else
      down = on_unit_sphere(rng);
    s.gravity = 9.81 * down;
    if (s.lumped_mass().sum() <= 0.0) s.node_mass.setConstant(0.01);
    ensure_supports(s, down);
    add_noise(s, kSmallNoise * length, rng);
  }
  s.name = base.name + "/" + family + "/" + levels[level_index].label + "/" + std::to_string(trial);
  return s;
}

StressReport run_stress_test(const StressTestOptions& options) {
  const auto t0 = Clock::now();
  if (options.trials < 1) throw InputError("command line", "--trials", "must be at least 1");
  if (options.jobs < 1) throw InputError("command line", "--jobs", "must be at least 1");
  if (!(options.time_limit_s > 0.0) || !std::isfinite(options.time_limit_s))
    throw InputError("command line", "--time-limit", "must be a finite number > 0");

  // Scenes: names or groups of the built-in set, plus files.
  std::vector<StressBaseScene> all = stress_base_scenes(options.data_dir);
  for (const std::string& file : options.scene_files) {
    Structure s = read_scene_file(file);
    std::string name = fs::path(file).filename().string();
    if (name.ends_with(".scene.json")) name.erase(name.size() - std::string(".scene.json").size());
    if (s.name.empty()) s.name = name;
    all.push_back({name, "file", std::move(s)});
  }
  std::vector<const StressBaseScene*> scenes;
  const std::vector<std::string> wanted = split_names(options.scenes);
  for (const StressBaseScene& b : all) {
    bool chosen = wanted.empty() || b.group == "file";
    for (const std::string& w : wanted) chosen = chosen || w == b.name || w == b.group || w == "all";
    if (chosen) scenes.push_back(&b);
  }
  for (const std::string& w : wanted) {
    const bool known = w == "all" || std::any_of(all.begin(), all.end(), [&](const StressBaseScene& b) {
                         return w == b.name || w == b.group;
                       });
    if (!known) {
      std::string names;
      for (const StressBaseScene& b : all) names += (names.empty() ? "" : ", ") + b.name;
      throw InputError("command line", "--scenes " + w,
                       "unknown scene (known: groups reference, tower, character; " + names + ")");
    }
  }
  std::vector<std::string> families = split_names(options.families);
  if (families.empty()) families = family_names();
  for (const std::string& f : families) stress_family_levels(f);  // rejects unknown names
  std::vector<std::string> solvers = split_names(options.solvers);
  if (solvers.empty()) solvers = solver_names();
  SolveOptions solve_options;
  solve_options.tolerance = options.tolerance;
  solve_options.time_limit_s = options.time_limit_s;
  solve_options.backend_options = options.backend_options;
  std::string why;
  if (!solve_options.IsValid(&why)) throw InputError("command line", "options", why);
  for (const std::string& name : solvers) make_solver(name)->check_options(solve_options);

  std::vector<Case> cases;
  for (const StressBaseScene* b : scenes)
    for (const std::string& family : families) {
      const auto levels = stress_family_levels(family);
      for (int l = 0; l < static_cast<int>(levels.size()); ++l)
        for (int t = 0; t < options.trials; ++t) {
          Case c;
          c.base = b;
          c.family = family;
          c.level = levels[l].label;
          c.trial = t;
          c.scene = make_stress_case(b->scene, family, l, t, options.seed);
          try {
            validate(c.scene, c.scene.name);
          } catch (const InputError& e) {
            c.rejected = true;
            c.rejection = e.what();
          }
          cases.push_back(std::move(c));
        }
    }

  StressReport report;
  report.options = options;
  const int total = static_cast<int>(cases.size() * solvers.size());
  report.trials.resize(total);
  std::atomic<int> next{0}, done{0}, failures{0};
  const double overrun_s = 2.0 * options.time_limit_s + 5.0;

  auto work = [&] {
    std::map<std::string, std::unique_ptr<Solver>> instances;
    for (;;) {
      const int k = next.fetch_add(1);
      if (k >= total) return;
      const Case& c = cases[k / solvers.size()];
      const std::string& solver_name = solvers[k % solvers.size()];
      StressTrial& t = report.trials[k];
      t.scene = c.base->name;
      t.family = c.family;
      t.level = c.level;
      t.trial = c.trial;
      t.solver = solver_name;
      if (c.rejected) {
        t.rejected = true;
        t.message = c.rejection;
        done.fetch_add(1);
        continue;
      }
      auto& solver = instances[solver_name];
      if (!solver) solver = make_solver(solver_name);
      const auto start = Clock::now();
      SolveResult r;
      try {
        r = solve_scene(*solver, c.scene, solve_options);
      } catch (const std::exception& e) {
        r = SolveResult{};
        r.status = Status::NumericalError;
        r.message = std::string("exception escaped the driver: ") + e.what();
        r.positions = c.scene.positions;
        r.forces = Eigen::VectorXd::Zero(c.scene.num_elements());
      }
      t.seconds = std::chrono::duration<double>(Clock::now() - start).count();
      t.overran = t.seconds > overrun_s;
      t.status = r.status;
      t.finite = finite_result(r);
      const Verification v = verify(c.scene, r.positions, r.forces, options.tolerance);
      t.verified = v.ok;
      t.relative_residual = v.relative_residual;
      t.message = r.message;
      Digest d;
      d.integer(static_cast<std::uint64_t>(r.status));
      d.bytes(r.positions.data(), sizeof(double) * r.positions.size());
      d.bytes(r.forces.data(), sizeof(double) * r.forces.size());
      t.digest = d.h;
      if (r.status != Status::Converged || !t.verified || !t.finite) {
        failures.fetch_add(1);
        if (!options.failures_dir.empty()) {
          try {
            write_scene_file(c.scene, options.failures_dir + "/" + t.scene + "_" + t.family + "_" + t.level +
                                          "_t" + std::to_string(t.trial) + "_" + t.solver + ".scene.json");
          } catch (const std::exception& e) {
            t.message += std::string(" (scene not saved: ") + e.what() + ")";
          }
        }
      }
      done.fetch_add(1);
    }
  };

  std::vector<std::thread> pool;
  for (int j = 0; j < std::min(options.jobs, std::max(1, total)); ++j) pool.emplace_back(work);
  while (done.load() < total) {
    if (options.progress) options.progress(done.load(), total, failures.load());
    std::this_thread::sleep_for(std::chrono::milliseconds(250));
  }
  for (std::thread& th : pool) th.join();
  if (options.progress) options.progress(done.load(), total, failures.load());
  report.wall_seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  return report;
}

namespace {

using nlohmann::json;

// A JSON number, or null for a non-finite value (which the cell also counts).
json number_or_null(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

struct Cell {
  int trials = 0, rejected = 0, converged = 0, verified = 0, false_converged = 0, non_finite = 0;
  int overran = 0, escaped = 0;
  double worst_converged_residual = 0.0;
  std::vector<double> seconds;
  std::map<std::string, int> statuses;
  Digest digest;

  void add(const StressTrial& t) {
    digest.integer(t.digest);
    if (t.rejected) {
      ++rejected;
      return;
    }
    ++trials;
    ++statuses[std::string(to_string(t.status))];
    if (!t.finite) ++non_finite;
    if (t.overran) ++overran;
    if (t.message.rfind("exception escaped", 0) == 0) ++escaped;
    if (t.status == Status::Converged) {
      ++converged;
      if (t.verified)
        ++verified;
      else
        ++false_converged;
      worst_converged_residual = std::max(worst_converged_residual,
                                          std::isfinite(t.relative_residual) ? t.relative_residual : INFINITY);
    }
    seconds.push_back(t.seconds);
  }

  json to_json(bool with_times) {
    json j = json::object();
    j["trials"] = trials;
    j["rejected_inputs"] = rejected;
    j["converged"] = converged;
    j["success_rate"] = trials > 0 ? static_cast<double>(converged) / trials : 0.0;
    j["verified"] = verified;
    j["verified_rate"] = converged > 0 ? static_cast<double>(verified) / converged : 1.0;
    j["false_converged"] = false_converged;
    j["worst_relative_residual"] = number_or_null(worst_converged_residual);
    j["non_finite"] = non_finite;
    j["exceptions"] = escaped;
    j["statuses"] = statuses;
    if (with_times) {
      std::vector<double> s = seconds;
      std::sort(s.begin(), s.end());
      j["median_seconds"] = s.empty() ? 0.0 : s[s.size() / 2];
      j["worst_seconds"] = s.empty() ? 0.0 : s.back();
      j["overran"] = overran;
    }
    char hex[20];
    std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(digest.h));
    j["digest"] = hex;
    return j;
  }
};

bool noise_up_to_10_percent(const StressTrial& t) {
  return t.family == "noise" && std::atof(t.level.c_str()) <= 0.1 + 1e-12;
}

}  // namespace

json stress_report_to_json(const StressReport& report) {
  const StressTestOptions& o = report.options;
  const bool times = o.with_times;
  json j = json::object();
  j["format"] = "tensegrity-stress-report";
  j["version"] = 1;
  json opts = json::object();
  opts["scenes"] = split_names(o.scenes);
  opts["scene_files"] = o.scene_files;
  opts["solvers"] = split_names(o.solvers);
  opts["families"] = split_names(o.families);
  opts["trials"] = o.trials;
  opts["seed"] = o.seed;
  opts["time_limit_s"] = o.time_limit_s;
  opts["tolerance"] = o.tolerance;
  if (!o.backend_options.empty()) opts["backend_options"] = o.backend_options;
  if (times) opts["jobs"] = o.jobs;
  j["options"] = opts;

  // Ordered maps keyed by the names, so the output order is fixed.
  std::map<std::string, std::map<std::string, Cell>> by_family;
  std::map<std::string, std::map<std::string, std::map<std::string, Cell>>> by_level;
  std::map<std::string, std::map<std::string, Cell>> noise_by_scene;
  std::map<std::string, Cell> noise_total, overall;
  std::set<std::string> scene_names;
  for (const StressTrial& t : report.trials) {
    by_family[t.solver][t.family].add(t);
    by_level[t.solver][t.family][t.level].add(t);
    overall[t.solver].add(t);
    scene_names.insert(t.scene);
    if (noise_up_to_10_percent(t)) {
      noise_total[t.solver].add(t);
      noise_by_scene[t.solver][t.scene].add(t);
    }
  }
  j["scenes"] = scene_names;
  json solvers = json::object();
  for (auto& [solver, families] : by_family) {
    json s = json::object();
    s["overall"] = overall[solver].to_json(times);
    if (noise_total.count(solver)) {
      json n = noise_total[solver].to_json(times);
      json per_scene = json::object();
      for (auto& [scene, cell] : noise_by_scene[solver]) {
        json c = json::object();
        c["trials"] = cell.trials;
        c["converged"] = cell.converged;
        c["verified"] = cell.verified;
        per_scene[scene] = c;
      }
      n["by_scene"] = per_scene;
      s["noise_up_to_10_percent"] = n;
    }
    json fam = json::object();
    for (auto& [family, cell] : families) {
      json f = cell.to_json(times);
      json levels = json::object();
      for (auto& [level, lc] : by_level[solver][family]) levels[level] = lc.to_json(times);
      f["by_level"] = levels;
      fam[family] = f;
    }
    s["families"] = fam;
    solvers[solver] = s;
  }
  j["solvers"] = solvers;

  json failures = json::array();
  for (const StressTrial& t : report.trials) {
    if (t.rejected || (t.status == Status::Converged && t.verified && t.finite)) continue;
    json f = json::object();
    f["solver"] = t.solver;
    f["scene"] = t.scene;
    f["family"] = t.family;
    f["level"] = t.level;
    f["trial"] = t.trial;
    f["status"] = to_string(t.status);
    f["verified"] = t.verified;
    f["finite"] = t.finite;
    f["relative_residual"] = number_or_null(t.relative_residual);
    // Messages may quote remaining time budgets: only with timings.
    if (times) {
      f["seconds"] = t.seconds;
      f["message"] = t.message.size() > 300 ? t.message.substr(0, 297) + "..." : t.message;
    }
    failures.push_back(f);
  }
  j["failures"] = failures;
  json rejected = json::array();
  std::set<std::string> seen;
  for (const StressTrial& t : report.trials)
    if (t.rejected && seen.insert(t.scene + "/" + t.family + "/" + t.level + "/" + std::to_string(t.trial)).second)
      rejected.push_back(t.scene + "/" + t.family + "/" + t.level + "/" + std::to_string(t.trial) + ": " +
                         t.message);
  j["rejected_inputs"] = rejected;
  if (times) j["wall_seconds"] = report.wall_seconds;
  return j;
}

}  // namespace tensegrity::cli
