// Scenes made by the library rather than read: characters, the analytic
// reference scenes and the stress test's perturbed scenes.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "model/character.hpp"
#include "model/errors.hpp"
#include "model/reference_scenes.hpp"
#include "model/scene_io.hpp"
#include "scenes/families.hpp"
#include "python/src/bindings.hpp"

namespace tensegrity::python {

void bind_generators(py::module_& m) {
  m.def("build_character",
        [](const std::filesystem::path& path, const std::filesystem::path& blocks) {
          return std::make_shared<Structure>(build_character_file(path.string(), blocks.string()).structure);
        },
        py::arg("path"), py::arg("blocks") = "",
        "Assembles a character file (*.character.json) into a Scene, like `tensegrity build`.");

  m.def("chain",
        [](int n) {
          if (n < 2 || n > 200) throw InputError("command line", "--chain", "N must be within 2..200");
          return std::make_shared<Structure>(
              build_character(make_chain_character(n), "chain-" + std::to_string(n), BlockLibrary::standard())
                  .structure);
        },
        py::arg("n"), "The chain of n face-linked expandable octahedra (`tensegrity build --chain n`).");

  m.def("prism",
        [](int n, double radius, double height, double twist_offset, double strut_mass, double cable_mass,
           bool gravity, bool fix_bottom) {
          if (n < 3) throw InputError("prism", "n", "must be >= 3");
          PrismParameters p;
          p.n = n;
          p.radius = radius;
          p.height = height;
          p.twist_offset = twist_offset;
          p.strut_mass = strut_mass;
          p.cable_mass = cable_mass;
          p.gravity = gravity;
          p.fix_bottom = fix_bottom;
          Structure s = make_regular_prism(p);
          validate(s, "prism");
          return std::make_shared<Structure>(std::move(s));
        },
        py::arg("n") = 3, py::arg("radius") = 1.0, py::arg("height") = 1.0, py::arg("twist_offset") = 0.0,
        py::arg("strut_mass") = 0.0, py::arg("cable_mass") = 0.0, py::arg("gravity") = false,
        py::arg("fix_bottom") = false,
        R"doc(The regular n-strut prism: bottom nodes 0..n-1 at height 0, top nodes n..2n-1 at
`height`, radius `radius`, top turned by pi/2 - pi/n + twist_offset (rad), the
equilibrium twist at offset 0. Elements: struts, verticals, bottom ring, top ring.)doc");

  m.def("prism_equilibrium_twist", &prism_equilibrium_twist, py::arg("n"), "pi/2 - pi/n (rad).");

  m.def("octahedron",
        [](double half_length, double strut_mass, double cable_mass, bool gravity, bool fix_bottom) {
          OctahedronParameters p;
          p.half_length = half_length;
          p.strut_mass = strut_mass;
          p.cable_mass = cable_mass;
          p.gravity = gravity;
          p.fix_bottom = fix_bottom;
          Structure s = make_expandable_octahedron(p);
          validate(s, "octahedron");
          return std::make_shared<Structure>(std::move(s));
        },
        py::arg("half_length") = 1.0, py::arg("strut_mass") = 0.0, py::arg("cable_mass") = 0.0,
        py::arg("gravity") = false, py::arg("fix_bottom") = false,
        "The expandable octahedron: 6 struts of half-length a, 24 cables, in equilibrium.");

  m.def("stress_families", &scenes::family_names, "Names of the stress-test perturbation families.");
  m.def("stress_levels",
        [](const std::string& family) {
          std::vector<std::pair<double, std::string>> v;
          for (const auto& l : scenes::family_levels(family)) v.emplace_back(l.value, l.label);
          return v;
        },
        py::arg("family"), "The (value, label) levels of a stress-test family.");
  m.def("stress_case",
        [](const Structure& base, const std::string& family, int level, int trial, std::uint64_t seed) {
          const auto levels = scenes::family_levels(family);
          if (level < 0 || level >= static_cast<int>(levels.size()))
            throw InputError("command line", "level", "must be within 0.." + std::to_string(levels.size() - 1) +
                                                          " for family " + family);
          Structure s = scenes::make_family_case(base, family, level, trial, seed);
          // As the stress test does: a perturbed scene that breaks a rule is rejected, not solved.
          validate(s, s.name);
          return std::make_shared<Structure>(std::move(s));
        },
        py::arg("base"), py::arg("family"), py::arg("level"), py::arg("trial") = 0, py::arg("seed") = 1,
        "The perturbed scene of one stress-test trial; deterministic in its arguments.\nValueError when it breaks a rule of the model (the stress test counts it as rejected).");
  m.def("stress_base_scenes",
        [](const std::string& data_dir) {
          std::vector<std::pair<std::string, std::shared_ptr<Structure>>> v;
          for (auto& b : scenes::base_scenes(data_dir))
            v.emplace_back(b.name, std::make_shared<Structure>(std::move(b.scene)));
          return v;
        },
        py::arg("data_dir"), "The stress test's base scenes: (name, Scene) pairs; `data_dir` holds characters/.");
}

}  // namespace tensegrity::python
