// tensegrity._core: the library bound for Python with pybind11. Arrays cross as
// numpy arrays in the row-major shapes users expect ((n, 3) positions, (m, 2)
// elements); the solver logic stays in C++, and the GIL is released while it
// runs. InputError becomes ValueError carrying the command line's own message.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "cli/output.hpp"
#include "cli/renderer.hpp"
#include "model/character.hpp"
#include "model/design.hpp"
#include "model/errors.hpp"
#include "model/reference_scenes.hpp"
#include "model/scene_io.hpp"
#include "model/solution.hpp"
#include "model/verify.hpp"
#include "scenes/families.hpp"
#include "simulation/simulator.hpp"
#include "solvers/solver.hpp"

namespace py = pybind11;
using namespace tensegrity;

namespace {

// The command line prints "tensegrity: " before the InputError's text.
constexpr const char* kMessagePrefix = "tensegrity: ";

using RowMajorX3 = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;

py::array_t<double> positions_array(const Eigen::Matrix3Xd& p) {
  py::array_t<double> a({static_cast<py::ssize_t>(p.cols()), py::ssize_t{3}});
  auto v = a.mutable_unchecked<2>();
  for (Eigen::Index i = 0; i < p.cols(); ++i)
    for (int k = 0; k < 3; ++k) v(i, k) = p(k, i);
  return a;
}

py::array_t<double> vector_array(const Eigen::VectorXd& x) {
  py::array_t<double> a(static_cast<py::ssize_t>(x.size()));
  auto v = a.mutable_unchecked<1>();
  for (Eigen::Index i = 0; i < x.size(); ++i) v(i) = x(i);
  return a;
}

// The scene's JSON from arrays, so that a Scene built in Python passes through
// exactly the validation (and messages) of a scene file.
nlohmann::json scene_json_from_arrays(py::array_t<double, py::array::forcecast> positions,
                                      py::array_t<std::int64_t, py::array::forcecast> elements,
                                      const std::vector<std::string>& kinds, const py::object& fixed,
                                      const py::object& masses, const py::object& element_masses,
                                      const py::object& gravity, const std::string& name,
                                      const std::string& source) {
  if (positions.ndim() != 2 || positions.shape(1) != 3)
    throw InputError(source, "positions", "expected an array of shape (n, 3)");
  if (elements.ndim() != 2 || elements.shape(1) != 2)
    throw InputError(source, "elements", "expected an array of shape (m, 2)");
  const auto n = positions.shape(0);
  const auto m = elements.shape(0);
  if (static_cast<py::ssize_t>(kinds.size()) != m)
    throw InputError(source, "kinds", "expected " + std::to_string(m) + " kinds, one per element, got " +
                                          std::to_string(kinds.size()));
  auto per_item = [&](const py::object& o, py::ssize_t count, const char* item) -> std::optional<py::array> {
    if (o.is_none()) return std::nullopt;
    py::array a = py::array::ensure(o);
    if (!a || a.ndim() != 1 || a.shape(0) != count)
      throw InputError(source, item, "expected an array of length " + std::to_string(count));
    return a;
  };
  const auto fixed_a = per_item(fixed, n, "fixed");
  const auto mass_a = per_item(masses, n, "masses");
  const auto element_mass_a = per_item(element_masses, m, "element_masses");
  nlohmann::json j = {{"format", "tensegrity-scene"}, {"version", 1}};
  if (!name.empty()) j["name"] = name;
  if (!gravity.is_none()) {
    auto g = py::array_t<double, py::array::forcecast>::ensure(gravity);
    if (!g || g.ndim() != 1 || g.shape(0) != 3) throw InputError(source, "gravity", "expected 3 numbers");
    j["gravity"] = {g.at(0), g.at(1), g.at(2)};
  }
  auto p = positions.unchecked<2>();
  nlohmann::json nodes = nlohmann::json::array();
  for (py::ssize_t i = 0; i < n; ++i) {
    nlohmann::json node = {{"x", {p(i, 0), p(i, 1), p(i, 2)}}};
    // Values go through Python's own truth and float conversions, then the file rules.
    if (fixed_a) node["fixed"] = py::cast<bool>((*fixed_a)[py::int_(i)]);
    if (mass_a) node["mass"] = py::cast<double>((*mass_a)[py::int_(i)]);
    nodes.push_back(std::move(node));
  }
  auto e = elements.unchecked<2>();
  nlohmann::json elems = nlohmann::json::array();
  for (py::ssize_t k = 0; k < m; ++k) {
    nlohmann::json element = {{"kind", kinds[k]}, {"nodes", {e(k, 0), e(k, 1)}}};
    if (element_mass_a) element["mass"] = py::cast<double>((*element_mass_a)[py::int_(k)]);
    elems.push_back(std::move(element));
  }
  j["nodes"] = std::move(nodes);
  j["elements"] = std::move(elems);
  return j;
}

// A finished solve with what is needed to write its solution file.
struct PyResult {
  SolveResult result;
  std::shared_ptr<const Structure> scene;
  std::string solver;
  double tolerance = 1e-8;

  Solution solution() const { return to_solution(result, *scene, solver); }
};

py::dict stats_dict(const SolveResult& r) {
  py::dict d;
  d["iterations"] = r.stats.iterations;
  d["seconds"] = r.stats.seconds;
  d["residual"] = r.stats.residual;
  d["relative_residual"] = r.stats.relative_residual;
  d["geometry_change"] = r.stats.geometry_change;
  d["message"] = r.message;
  d["native_code"] = r.native_code;
  return d;
}

py::dict trace_dict(const std::vector<TracePoint>& trace) {
  const auto count = static_cast<py::ssize_t>(trace.size());
  py::array_t<double> seconds(count), residual(count), relative(count), change(count), objective(count);
  py::array_t<std::int64_t> iteration(count), evaluations(count);
  for (py::ssize_t i = 0; i < count; ++i) {
    const TracePoint& t = trace[static_cast<std::size_t>(i)];
    seconds.mutable_at(i) = t.seconds;
    iteration.mutable_at(i) = t.iteration;
    evaluations.mutable_at(i) = t.evaluations;
    residual.mutable_at(i) = t.residual;
    relative.mutable_at(i) = t.relative_residual;
    change.mutable_at(i) = t.geometry_change;
    objective.mutable_at(i) = t.objective;
  }
  py::dict d;
  d["seconds"] = seconds;
  d["iteration"] = iteration;
  d["evaluations"] = evaluations;
  d["residual"] = residual;
  d["relative_residual"] = relative;
  d["geometry_change"] = change;
  d["objective"] = objective;
  return d;
}

PyResult run_solve(const Structure& scene, const std::string& solver_name, double tol, double time_limit,
                   int max_iterations, bool skip_if_in_equilibrium, bool verbose,
                   const std::map<std::string, std::string>& backend_options) {
  SolveOptions options;
  options.tolerance = tol;
  options.time_limit_s = time_limit;
  options.max_iterations = max_iterations;
  DriverControls controls;
  controls.skip_if_in_equilibrium = skip_if_in_equilibrium;
  options.verbose = verbose;
  options.backend_options = backend_options;
  const auto solver = cli::checked_solver(solver_name, options);
  PyResult out;
  out.scene = std::make_shared<const Structure>(scene);
  out.solver = std::string(solver->name());
  out.tolerance = tol;
  {
    py::gil_scoped_release release;
    out.result = solver->Solve(*out.scene, options, controls);
  }
  return out;
}

PyResult run_forces(const Structure& scene, double tol) {
  SolveOptions options;
  options.tolerance = tol;
  std::string why;
  if (!options.IsValid(&why)) throw InputError("command line", "--tol", why);
  PyResult out;
  out.scene = std::make_shared<const Structure>(scene);
  out.solver = "stress-qp";
  out.tolerance = tol;
  {
    py::gil_scoped_release release;
    out.result = solve_forces_only(*out.scene, options);
  }
  return out;
}

void check_tolerance(double tol) {
  if (!(std::isfinite(tol) && tol > 0)) throw InputError("command line", "--tol", "must be a finite number > 0");
}

std::string scene_repr(const Structure& s) {
  int struts = 0;
  for (const Element& e : s.elements) struts += e.kind == ElementKind::Strut;
  return "<tensegrity.Scene '" + s.name + "': " + std::to_string(s.num_nodes()) + " nodes (" +
         std::to_string(s.num_nodes() - s.num_free_nodes()) + " fixed), " + std::to_string(struts) +
         " struts, " + std::to_string(s.num_elements() - struts) + " cables" +
         (s.has_gravity() ? ", gravity" : "") + ">";
}

}  // namespace

PYBIND11_MODULE(_core, m) {
  m.doc() = "Compiled core of the tensegrity package (form finding of tensegrity structures).";

  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const OptionError& e) {
      PyErr_SetString(PyExc_ValueError, cli::option_error_line(e).c_str());
    } catch (const InputError& e) {
      PyErr_SetString(PyExc_ValueError, (std::string(kMessagePrefix) + e.what()).c_str());
    }
  });

  py::class_<Structure, std::shared_ptr<Structure>>(m, "Scene", R"doc(
A tensegrity scene: nodes (positions in m, fixed flags, masses in kg), elements
(node pairs, each a strut or a cable, optional masses in kg) and gravity (m/s^2).

Scene(positions, elements, kinds, fixed=None, masses=None, element_masses=None,
      gravity=None, name=None)

positions: (n, 3) floats; elements: (m, 2) node indices (0-based); kinds: m
strings "strut" or "cable". The scene is checked by the same rules as a scene
file; a broken rule raises ValueError with the command line's message.
Arrays read from a Scene are copies.)doc")
      .def(py::init([](py::object positions, py::object elements, std::vector<std::string> kinds,
                       py::object fixed, py::object masses, py::object element_masses, py::object gravity,
                       std::optional<std::string> name) {
             const std::string source = name && !name->empty() ? *name : std::string("Scene");
             auto pos = py::array_t<double, py::array::forcecast>::ensure(positions);
             auto elems = py::array_t<std::int64_t, py::array::forcecast>::ensure(elements);
             if (!pos) throw InputError(source, "positions", "expected an array of numbers of shape (n, 3)");
             if (!elems) throw InputError(source, "elements", "expected an array of integers of shape (m, 2)");
             const auto j = scene_json_from_arrays(pos, elems, kinds, fixed, masses, element_masses, gravity,
                                                   name.value_or(""), source);
             return std::make_shared<Structure>(scene_from_json(j, source));
           }),
           py::arg("positions"), py::arg("elements"), py::arg("kinds"), py::arg("fixed") = py::none(),
           py::arg("masses") = py::none(), py::arg("element_masses") = py::none(),
           py::arg("gravity") = py::none(), py::arg("name") = py::none())
      .def_property_readonly("name", [](const Structure& s) { return s.name; })
      .def_property_readonly("num_nodes", &Structure::num_nodes)
      .def_property_readonly("num_elements", &Structure::num_elements)
      .def_property_readonly("positions", [](const Structure& s) { return positions_array(s.positions); },
                             "(n, 3) node positions in m (a copy).")
      .def_property_readonly(
          "elements",
          [](const Structure& s) {
            py::array_t<std::int64_t> a({static_cast<py::ssize_t>(s.num_elements()), py::ssize_t{2}});
            auto v = a.mutable_unchecked<2>();
            for (int k = 0; k < s.num_elements(); ++k) {
              v(k, 0) = s.elements[k].a;
              v(k, 1) = s.elements[k].b;
            }
            return a;
          },
          "(m, 2) node indices of the elements (int64, a copy).")
      .def_property_readonly(
          "kinds",
          [](const Structure& s) {
            std::vector<std::string> k;
            for (const Element& e : s.elements) k.emplace_back(to_string(e.kind));
            return k;
          },
          "List of m strings, 'strut' or 'cable'.")
      .def_property_readonly(
          "fixed",
          [](const Structure& s) {
            py::array_t<bool> a(static_cast<py::ssize_t>(s.num_nodes()));
            for (int i = 0; i < s.num_nodes(); ++i) a.mutable_at(i) = s.fixed[i];
            return a;
          },
          "(n,) bool: contact nodes, which never move.")
      .def_property_readonly("masses", [](const Structure& s) { return vector_array(s.node_mass); },
                             "(n,) node masses in kg (own mass only).")
      .def_property_readonly(
          "element_masses",
          [](const Structure& s) {
            Eigen::VectorXd x(s.num_elements());
            for (int k = 0; k < s.num_elements(); ++k) x(k) = s.elements[k].mass;
            return vector_array(x);
          },
          "(m,) element masses in kg.")
      .def_property_readonly("gravity", [](const Structure& s) { return vector_array(s.gravity); },
                             "(3,) gravity in m/s^2 (zeros: no gravity).")
      .def_property_readonly("lumped_masses", [](const Structure& s) { return vector_array(s.lumped_mass()); },
                             "(n,) node mass plus half of each touching element's mass (kg).")
      .def("save", [](const Structure& s, const std::filesystem::path& path) { write_scene_file(s, path.string()); }, py::arg("path"),
           "Writes the scene file (format tensegrity-scene, version 1).")
      .def("to_json", [](const Structure& s) { return scene_to_json(s).dump(2); },
           "The scene file's text.")
      .def("__repr__", &scene_repr)
      .def("__len__", &Structure::num_nodes)
      .def(py::pickle([](const Structure& s) { return scene_to_json(s).dump(); },
                      [](const std::string& text) {
                        return std::make_shared<Structure>(
                            scene_from_json(nlohmann::json::parse(text), "pickled scene"));
                      }));

  m.def("scene_from_json", [](const std::string& text, const std::string& source) {
        nlohmann::json j;
        try {
          j = nlohmann::json::parse(text);
        } catch (const nlohmann::json::parse_error& e) {
          throw InputError(source, "", std::string("malformed JSON: ") + e.what());
        }
        return std::make_shared<Structure>(scene_from_json(j, source));
      },
      py::arg("text"), py::arg("source") = "string",
      "A Scene from the text of a scene file; `source` names it in error messages.");

  m.def("load_scene",
        [](const std::filesystem::path& path) { return std::make_shared<Structure>(read_scene_file(path.string())); },
        py::arg("path"), "Reads and validates a scene file (*.scene.json); ValueError on bad input.");

  py::class_<Verification>(m, "Verification", "Independent re-check of a solution by the contract's formulas.")
      .def_readonly("residual", &Verification::residual, "Max net force on a free node (N).")
      .def_readonly("relative_residual", &Verification::relative_residual)
      .def_readonly("load_scale", &Verification::load_scale, "N")
      .def_readonly("geometry_change", &Verification::geometry_change, "m")
      .def_readonly("wrong_signs", &Verification::wrong_signs)
      .def_readonly("moved_fixed_nodes", &Verification::moved_fixed_nodes)
      .def_readonly("all_finite", &Verification::all_finite)
      .def_readonly("equilibrium_ok", &Verification::equilibrium_ok)
      .def_readonly("ok", &Verification::ok, "True when every condition holds (the CLI's 'verified').")
      .def_readonly("problems", &Verification::problems)
      .def("__bool__", [](const Verification& v) { return v.ok; })
      .def("__repr__", [](const Verification& v) {
        char buf[256];
        std::snprintf(buf, sizeof buf, "<tensegrity.Verification %s: relative residual %.3g, %d wrong signs>",
                      v.ok ? "verified" : "NOT verified", v.relative_residual, v.wrong_signs);
        return std::string(buf);
      });

  py::class_<PyResult>(m, "Result", "The outcome of a solve: status, positions, forces, stats and trace.")
      .def_property_readonly("status", [](const PyResult& r) { return std::string(to_string(r.result.status)); },
                             "The solution file's status word ('converged', 'max_iterations', ...).")
      .def_property_readonly("converged", [](const PyResult& r) { return r.result.status == Status::Converged; })
      .def_property_readonly("solver", [](const PyResult& r) { return r.solver; })
      .def_property_readonly("message", [](const PyResult& r) { return r.result.message; })
      .def_property_readonly("scene", [](const PyResult& r) { return std::make_shared<Structure>(*r.scene); })
      .def_property_readonly("positions", [](const PyResult& r) { return positions_array(r.result.positions); },
                             "(n, 3) solved node positions in m.")
      .def_property_readonly("forces", [](const PyResult& r) { return vector_array(r.result.forces); },
                             "(m,) axial forces in N, positive = tension.")
      .def_property_readonly("stats", [](const PyResult& r) { return stats_dict(r.result); },
                             "iterations, seconds, residual, relative_residual, geometry_change, message, native_code.")
      .def_property_readonly("trace", [](const PyResult& r) { return trace_dict(r.result.trace); },
                             "Per-iteration record, a dict of equal-length numpy arrays.")
      .def("verify",
           [](const PyResult& r, std::optional<double> tol) {
             const double t = tol.value_or(r.tolerance);
             check_tolerance(t);
             return verify(*r.scene, r.result.positions, r.result.forces, t);
           },
           py::arg("tol") = py::none(), "Independent re-check (model/verify) at `tol` (default: the solve's).")
      .def("save", [](const PyResult& r, const std::filesystem::path& path) { write_solution_file(r.solution(), path.string()); },
           py::arg("path"), "Writes the solution file, byte for byte what `tensegrity solve --out` writes.")
      .def("to_json", [](const PyResult& r) { return solution_to_json(r.solution()).dump(2); })
      .def("summary", [](const PyResult& r) { return cli::summary_line(*r.scene, r.solver, r.result); },
           "The one-line summary the command line prints on standard error.")
      .def("__repr__", [](const PyResult& r) {
        return "<tensegrity.Result " + cli::summary_line(*r.scene, r.solver, r.result) + ">";
      });

  m.def("solvers", &solver_names, "Names of the backends, as `tensegrity solvers` lists them.");
  m.def("default_solver", &default_solver_name, "The backend used when none is named.");

  m.def("_solve",
        [](const Structure& scene, const std::string& solver, double tol, double time_limit, int max_iterations,
           bool skip_if_in_equilibrium, bool verbose, const std::map<std::string, std::string>& options) {
          return run_solve(scene, solver, tol, time_limit, max_iterations, skip_if_in_equilibrium, verbose, options);
        },
        py::arg("scene"), py::arg("solver"), py::arg("tol"), py::arg("time_limit"), py::arg("max_iterations"),
        py::arg("skip_if_in_equilibrium"), py::arg("verbose"), py::arg("options"));

  m.def("_check_solver",
        [](const std::string& solver, double tol, double time_limit, int max_iterations,
           const std::map<std::string, std::string>& options) {
          SolveOptions o;
          o.tolerance = tol;
          o.time_limit_s = time_limit;
          o.max_iterations = max_iterations;
          o.backend_options = options;
          return std::string(cli::checked_solver(solver, o)->name());
        },
        py::arg("solver"), py::arg("tol"), py::arg("time_limit"), py::arg("max_iterations"), py::arg("options"));

  m.def("_forces", &run_forces, py::arg("scene"), py::arg("tol"));

  m.def("_check_solution_file",
        [](const Structure& scene, const std::string& path, double tol) {
          check_tolerance(tol);
          const Solution sol = read_solution_file(path, scene);
          return verify(scene, sol.positions, sol.forces, tol);
        },
        py::arg("scene"), py::arg("path"), py::arg("tol"));

  m.def("_check_arrays",
        [](const Structure& scene, py::array_t<double, py::array::forcecast> positions,
           py::array_t<double, py::array::forcecast> forces, double tol) {
          check_tolerance(tol);
          if (positions.ndim() != 2 || positions.shape(0) != scene.num_nodes() || positions.shape(1) != 3)
            throw InputError("arrays", "positions", "expected shape (" + std::to_string(scene.num_nodes()) + ", 3)");
          if (forces.ndim() != 1 || forces.shape(0) != scene.num_elements())
            throw InputError("arrays", "forces", "expected shape (" + std::to_string(scene.num_elements()) + ",)");
          Eigen::Matrix3Xd p(3, scene.num_nodes());
          for (int i = 0; i < scene.num_nodes(); ++i)
            for (int k = 0; k < 3; ++k) p(k, i) = positions.at(i, k);
          Eigen::VectorXd f(scene.num_elements());
          for (int k = 0; k < scene.num_elements(); ++k) f(k) = forces.at(k);
          return verify(scene, p, f, tol);
        },
        py::arg("scene"), py::arg("positions"), py::arg("forces"), py::arg("tol"));

  m.def("_read_solution",
        [](const Structure& scene, const std::string& path) {
          const Solution sol = read_solution_file(path, scene);
          py::dict d;
          d["status"] = std::string(to_string(sol.status));
          d["solver"] = sol.solver;
          d["positions"] = positions_array(sol.positions);
          d["forces"] = vector_array(sol.forces);
          py::dict stats;
          stats["iterations"] = sol.stats.iterations;
          stats["seconds"] = sol.stats.seconds;
          stats["residual"] = sol.stats.residual;
          stats["relative_residual"] = sol.stats.relative_residual;
          stats["geometry_change"] = sol.stats.geometry_change;
          d["stats"] = stats;
          return d;
        },
        py::arg("scene"), py::arg("path"));

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

  m.def("_simulate",
        [](const std::filesystem::path& design_path, double dt, int steps, py::object gravity, double damping,
           double stiffness_damping, const std::map<int, std::array<double, 3>>& drags, py::object drag_stiffness,
           int every, double tol) {
          // The checks and messages of `tensegrity simulate` (cli/simulate_command.cpp).
          if (!(std::isfinite(dt) && dt > 0)) throw InputError("command line", "--dt", "must be a finite number > 0");
          if (steps < 0) throw InputError("command line", "--steps", "must be >= 0");
          if (every < 1) throw InputError("command line", "--every", "must be >= 1");
          if (!(damping >= 0 && std::isfinite(damping))) throw InputError("command line", "--damping", "must be >= 0");
          if (!(stiffness_damping >= 0 && std::isfinite(stiffness_damping)))
            throw InputError("command line", "--stiffness-damping", "must be >= 0");
          const std::string path = design_path.string();
          const ElasticModel model = make_elastic_model(read_design_file(path));
          const Structure& s = model.structure;
          const int n = s.num_nodes();
          if (!(s.lumped_mass().sum() > 0.0)) throw InputError(path, "mass", "the design has no mass to simulate");
          Eigen::Vector3d g = s.gravity;
          if (!gravity.is_none()) {
            const auto v = py::cast<std::array<double, 3>>(gravity);
            for (int k = 0; k < 3; ++k) {
              if (!std::isfinite(v[k])) throw InputError("command line", "--gravity", "is not a finite number");
              g(k) = v[k];
            }
          }
          double k_drag = drag_stiffness.is_none() ? model.force_scale / (0.05 * model.length_scale)
                                                   : py::cast<double>(drag_stiffness);
          if (!(std::isfinite(k_drag) && k_drag > 0)) throw InputError("command line", "--drag-stiffness", "must be > 0");
          std::vector<DragSpring> springs;
          for (const auto& [node, target] : drags) {
            if (node < 0 || node >= n)
              throw InputError("command line", "--drag",
                               "node " + std::to_string(node) + " is out of range [0, " + std::to_string(n) + ")");
            springs.push_back({node, Eigen::Vector3d(target[0], target[1], target[2]), k_drag});
          }
          SimulationOptions so;
          so.time_step = dt;
          so.mass_damping = damping;
          so.stiffness_damping = stiffness_damping;
          so.tolerance = tol;
          std::vector<double> times, kinetic, potential;
          std::vector<int> step_numbers, newton;
          std::vector<bool> converged;
          std::vector<Eigen::Matrix3Xd> frames;
          std::vector<Eigen::VectorXd> forces;
          {
            py::gil_scoped_release release;
            Simulator sim(model, g, so);
            auto keep = [&](int step, const StepReport* r) {
              step_numbers.push_back(step);
              times.push_back(sim.time());
              frames.push_back(sim.positions());
              forces.push_back(sim.element_forces());
              kinetic.push_back(sim.kinetic_energy());
              potential.push_back(sim.potential_energy());
              newton.push_back(r ? r->newton_iterations : 0);
              converged.push_back(r ? r->converged : true);
            };
            keep(0, nullptr);
            for (int k = 1; k <= steps; ++k) {
              sim.set_drags(springs);
              const StepReport r = sim.step();
              if (k % every == 0 || k == steps) keep(k, &r);
            }
          }
          const auto count = static_cast<py::ssize_t>(frames.size());
          py::array_t<double> positions({count, static_cast<py::ssize_t>(n), py::ssize_t{3}});
          py::array_t<double> element_forces({count, static_cast<py::ssize_t>(s.num_elements())});
          auto p = positions.mutable_unchecked<3>();
          auto f = element_forces.mutable_unchecked<2>();
          for (py::ssize_t t = 0; t < count; ++t) {
            for (int i = 0; i < n; ++i)
              for (int k = 0; k < 3; ++k) p(t, i, k) = frames[t](k, i);
            for (int e = 0; e < s.num_elements(); ++e) f(t, e) = forces[t](e);
          }
          py::dict d;
          d["step"] = py::array(py::cast(step_numbers));
          d["time"] = py::array(py::cast(times));
          d["positions"] = positions;
          d["forces"] = element_forces;
          d["kinetic_energy"] = py::array(py::cast(kinetic));
          d["potential_energy"] = py::array(py::cast(potential));
          d["newton_iterations"] = py::array(py::cast(newton));
          d["converged"] = py::array(py::cast(converged));
          return d;
        },
        py::arg("design"), py::arg("dt"), py::arg("steps"), py::arg("gravity"), py::arg("damping"),
        py::arg("stiffness_damping"), py::arg("drags"), py::arg("drag_stiffness"), py::arg("every"), py::arg("tol"));

  m.def("_render",
        [](const Structure& scene, py::object positions, py::object forces, const std::string& path,
           const std::string& view, int width, int height, const std::string& title) {
          constexpr int kMinPixels = 64, kMaxPixels = 8192;
          if (width < kMinPixels || width > kMaxPixels)
            throw InputError("command line", "--width", "must be within 64..8192");
          if (height < kMinPixels || height > kMaxPixels)
            throw InputError("command line", "--height", "must be within 64..8192");
          cli::RenderOptions options;
          options.view = view;
          options.width = width;
          options.height = height;
          options.title = title;
          Eigen::Matrix3Xd p = scene.positions;
          if (!positions.is_none()) {
            auto a = py::array_t<double, py::array::forcecast>::ensure(positions);
            if (!a || a.ndim() != 2 || a.shape(0) != scene.num_nodes() || a.shape(1) != 3)
              throw InputError("arrays", "positions", "expected shape (" + std::to_string(scene.num_nodes()) + ", 3)");
            for (int i = 0; i < scene.num_nodes(); ++i)
              for (int k = 0; k < 3; ++k) p(k, i) = a.at(i, k);
          }
          std::optional<Eigen::VectorXd> f;
          if (!forces.is_none()) {
            auto a = py::array_t<double, py::array::forcecast>::ensure(forces);
            if (!a || a.ndim() != 1 || a.shape(0) != scene.num_elements())
              throw InputError("arrays", "forces", "expected shape (" + std::to_string(scene.num_elements()) + ",)");
            f = Eigen::VectorXd(scene.num_elements());
            for (int k = 0; k < scene.num_elements(); ++k) (*f)(k) = a.at(k);
          }
          py::gil_scoped_release release;
          cli::render_scene(scene, p, f, options, path);
        },
        py::arg("scene"), py::arg("positions"), py::arg("forces"), py::arg("path"), py::arg("view"),
        py::arg("width"), py::arg("height"), py::arg("title"));
}
