#pragma once
// Designs for the simulation and stability tests: the analytic prism made into
// a design in memory, and designs written by the `tensegrity design` program.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "design/rest_lengths.hpp"
#include "model/design.hpp"
#include "model/reference_scenes.hpp"
#include "model/scene_io.hpp"
#include "process_runner.hpp"

namespace tensegrity::testing {

inline CableMaterial shipped_material(const std::string& name) {
  // Built by appending: GCC 12 warns falsely (-Warray-bounds, -Wstringop-overflow)
  // on chains of operator+ on string temporaries once the tests share a
  // precompiled header (GCC bug 105651).
  std::string path = TENSEGRITY_SOURCE_DIR;
  path.append("/data/materials/").append(name).append(".json");
  return read_material_file(path);
}

// Analytic prism forces: force densities struts -1, verticals 1, rings 1 / (2 sin(pi/n)).
inline Eigen::VectorXd prism_forces(const Structure& s, int n, double mean_cable_force) {
  const int m = s.num_elements();
  Eigen::VectorXd sigma(m);
  double cable_sum = 0.0;
  for (int e = 0; e < m; ++e) {
    const double l = (s.positions.col(s.elements[e].b) - s.positions.col(s.elements[e].a)).norm();
    sigma[e] = (e < n ? -1.0 : e < 2 * n ? 1.0 : 1.0 / (2.0 * std::sin(M_PI / n))) * l;
    if (e >= n) cable_sum += sigma[e];
  }
  return sigma * (mean_cable_force * (m - n) / cable_sum);
}

// The regular prism (radius 0.1 m, height 0.12 m, masses), no gravity, as a
// design whose mean cable force is `mean_force`.
inline Design prism_design(int n, const std::string& material, double mean_force, bool fix_bottom = false) {
  PrismParameters p;
  p.n = n;
  p.radius = 0.1;
  p.height = 0.12;
  p.fix_bottom = fix_bottom;
  p.strut_mass = 0.01;
  p.cable_mass = 0.001;
  Design d;
  d.structure = make_regular_prism(p);
  const Structure& s = d.structure;
  const int m = s.num_elements();
  const Eigen::VectorXd sigma = prism_forces(s, n, mean_force);
  d.materials[material] = shipped_material(material);
  d.cable_material.assign(m, "");
  for (int e = 0; e < m; ++e)
    if (s.elements[e].kind == ElementKind::Cable) d.cable_material[e] = material;
  const RestLengthDesign rest = compute_rest_lengths(s, s.positions, sigma, d.material_pointers());
  EXPECT_TRUE(rest.ok) << rest.message;
  d.solution.positions = s.positions;
  d.solution.forces = sigma;
  d.solution.rest_lengths = rest.rest_lengths;
  d.strains = rest.strains;
  return d;
}

inline std::string temp_dir(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / ("tensegrity-" + name + "-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return dir.string();
}

// Removes a suite's temp_dir once the suite has passed; a failed suite keeps
// it, because its failure messages point at the logs inside.
inline void remove_temp_dir_unless_failed(const std::string& dir) {
  const ::testing::TestSuite* suite = ::testing::UnitTest::GetInstance()->current_test_suite();
  if (dir.empty() || (suite != nullptr && suite->Failed())) return;
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
}

// Runs `tensegrity design INPUT ARGS... --out OUT` (its output in OUT.logs/);
// returns OUT, or "" when the program failed.
inline std::string run_design(const std::string& input, const std::vector<std::string>& args, const std::string& out) {
  std::vector<std::string> command = {"design", input};
  command.insert(command.end(), args.begin(), args.end());
  command.insert(command.end(), {"--out", out});
  const std::string logs = out + ".logs";
  std::filesystem::create_directories(logs);
  return run_program(command, logs).exit_status == 0 ? out : std::string();
}

// A prism standing on its fixed bottom ring under gravity, written as a scene
// file `name` in `dir`.
inline std::string gravity_prism_scene(const std::string& dir, int n = 3,
                                       const std::string& name = "prism-gravity.scene.json") {
  PrismParameters p;
  p.n = n;
  p.radius = 0.1;
  p.height = 0.15;
  p.strut_mass = 0.02;
  p.cable_mass = 0.001;
  p.gravity = p.fix_bottom = true;
  const std::string path = dir + "/" + name;
  write_scene_file(make_regular_prism(p), path);
  return path;
}

}  // namespace tensegrity::testing
