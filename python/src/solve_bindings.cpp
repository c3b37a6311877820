// tensegrity.Result and the entry points of solve, forces and check; the
// solvers run with the GIL released.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <Eigen/Core>
#include <cstdint>
#include <cstdio>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "reports/prestress_factor.hpp"
#include "reports/output.hpp"
#include "model/errors.hpp"
#include "model/scene_io.hpp"
#include "model/solution.hpp"
#include "model/status.hpp"
#include "model/verify.hpp"
#include "python/src/bindings.hpp"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace tensegrity::python {

namespace {

// Fixes glibc's mmap and trim thresholds at the top of their adaptive range, so
// that the buffers a solve frees are reused by the next allocation instead of
// going back to the kernel and coming back as fresh zeroed pages. Dask's nanny
// starts every worker with MALLOC_TRIM_THRESHOLD_=65536, which switches the
// adaptation off: each factorization's large buffers are then mmapped and
// unmapped anew. Returns false where the C library has no such setting.
bool keep_freed_memory_for_reuse() {
#if defined(__GLIBC__)
  // glibc's own upper bound for its adaptive mmap threshold (4 MiB x sizeof(long)).
  constexpr int kWorkerMmapThresholdBytes = 32 * 1024 * 1024;
  // glibc's adaptive rule keeps the trim threshold at twice the mmap threshold.
  constexpr int kWorkerTrimThresholdBytes = 2 * kWorkerMmapThresholdBytes;
  return mallopt(M_MMAP_THRESHOLD, kWorkerMmapThresholdBytes) == 1 &&
         mallopt(M_TRIM_THRESHOLD, kWorkerTrimThresholdBytes) == 1;
#else
  return false;
#endif
}

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

// Backend details carried through pickling as the JSON the solution file holds.
struct StoredDetails : SolverDetails {
  explicit StoredDetails(nlohmann::json j) : json(std::move(j)) {}
  nlohmann::json to_json() const override { return json; }
  nlohmann::json json;
};

// A Result as plain Python values (pickle, and so Dask's transfers): the
// scene as its file's JSON, the numbers as arrays, the details as JSON.
py::tuple result_state(const PyResult& r) {
  py::list details;
  for (const auto& d : r.result.details)
    if (d) details.append(d->to_json().dump());
  const SolveResult& x = r.result;
  const py::tuple stats = py::make_tuple(x.stats.iterations, x.stats.seconds, x.stats.residual,
                                         x.stats.relative_residual, x.stats.geometry_change);
  return py::make_tuple(scene_to_json(*r.scene).dump(), r.solver, r.tolerance, std::string(to_string(x.status)),
                        x.message, x.native_code, positions_array(x.positions), vector_array(x.forces), stats,
                        trace_dict(x.trace), details);
}

PyResult result_from_state(const py::tuple& t) {
  constexpr py::ssize_t kStateSize = 11;
  if (t.size() != kStateSize) throw std::runtime_error("tensegrity.Result: not a pickled Result");
  PyResult r;
  r.scene = std::make_shared<const Structure>(
      scene_from_json(nlohmann::json::parse(t[0].cast<std::string>()), "pickled Result"));
  r.solver = t[1].cast<std::string>();
  r.tolerance = t[2].cast<double>();
  SolveResult& x = r.result;
  const std::optional<Status> status = status_from_string(t[3].cast<std::string>());
  if (!status) throw std::runtime_error("tensegrity.Result: unknown status in a pickled Result");
  x.status = *status;
  x.message = t[4].cast<std::string>();
  x.native_code = t[5].cast<int>();
  const auto positions = t[6].cast<py::array_t<double, py::array::c_style | py::array::forcecast>>();
  x.positions.resize(3, positions.shape(0));
  for (py::ssize_t i = 0; i < positions.shape(0); ++i)
    for (int k = 0; k < 3; ++k) x.positions(k, i) = positions.at(i, k);
  const auto forces = t[7].cast<py::array_t<double, py::array::c_style | py::array::forcecast>>();
  x.forces.resize(forces.shape(0));
  for (py::ssize_t e = 0; e < forces.shape(0); ++e) x.forces(e) = forces.at(e);
  const auto stats = t[8].cast<py::tuple>();
  x.stats.iterations = stats[0].cast<int>();
  x.stats.seconds = stats[1].cast<double>();
  x.stats.residual = stats[2].cast<double>();
  x.stats.relative_residual = stats[3].cast<double>();
  x.stats.geometry_change = stats[4].cast<double>();
  const auto trace = t[9].cast<py::dict>();
  const auto column = [&trace](const char* name) {
    return trace[name].cast<py::array_t<double, py::array::c_style | py::array::forcecast>>();
  };
  const auto seconds = column("seconds"), iteration = column("iteration"), evaluations = column("evaluations"),
             residual = column("residual"), relative = column("relative_residual"), change = column("geometry_change"),
             objective = column("objective");
  for (py::ssize_t i = 0; i < seconds.shape(0); ++i) {
    TracePoint p;
    p.seconds = seconds.at(i);
    p.iteration = static_cast<int>(iteration.at(i));
    p.evaluations = static_cast<int>(evaluations.at(i));
    p.residual = residual.at(i);
    p.relative_residual = relative.at(i);
    p.geometry_change = change.at(i);
    p.objective = objective.at(i);
    x.trace.push_back(p);
  }
  for (const py::handle d : t[10].cast<py::list>())
    x.details.push_back(std::make_shared<const StoredDetails>(nlohmann::json::parse(d.cast<std::string>())));
  return r;
}

PyResult run_solve(const Structure& scene, const std::string& solver_name, double tol, double time_limit,
                   int max_iterations, double prestress_factor, bool skip_if_in_equilibrium, bool verbose,
                   const std::map<std::string, std::string>& backend_options) {
  SolveOptions options;
  options.tolerance = tol;
  options.time_limit_s = time_limit;
  options.max_iterations = max_iterations;
  options.prestress_factor = reports::checked_prestress_factor(prestress_factor);
  DriverControls controls;
  controls.skip_if_in_equilibrium = skip_if_in_equilibrium;
  options.verbose = verbose;
  options.backend_options = backend_options;
  const auto solver = reports::checked_solver(solver_name, options);
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

}  // namespace

void bind_solve(py::module_& m) {
  py::class_<Verification>(m, "Verification", "Independent re-check of a solution by the formulas of docs/FORMATS.md.")
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
      .def(py::pickle(&result_state, &result_from_state))
      .def("summary", [](const PyResult& r) { return reports::summary_line(*r.scene, r.solver, r.result); },
           "The one-line summary the command line prints on standard error.")
      .def("__repr__", [](const PyResult& r) {
        return "<tensegrity.Result " + reports::summary_line(*r.scene, r.solver, r.result) + ">";
      });

  m.def("solvers", &solver_names, "Names of the backends, as `tensegrity solvers` lists them.");
  m.def("default_solver", &default_solver_name, "The backend used when none is named.");
  m.attr("DEFAULT_PRESTRESS_FACTOR") = kDefaultPrestressFactor;

  m.def("_solve",
        [](const Structure& scene, const std::string& solver, double tol, double time_limit, int max_iterations,
           double prestress_factor, bool skip_if_in_equilibrium, bool verbose,
           const std::map<std::string, std::string>& options) {
          return run_solve(scene, solver, tol, time_limit, max_iterations, prestress_factor, skip_if_in_equilibrium,
                           verbose, options);
        },
        py::arg("scene"), py::arg("solver"), py::arg("tol"), py::arg("time_limit"), py::arg("max_iterations"),
        py::arg("prestress_factor"), py::arg("skip_if_in_equilibrium"), py::arg("verbose"), py::arg("options"));

  m.def("_check_solver",
        [](const std::string& solver, double tol, double time_limit, int max_iterations, double prestress_factor,
           const std::map<std::string, std::string>& options) {
          SolveOptions o;
          o.tolerance = tol;
          o.time_limit_s = time_limit;
          o.max_iterations = max_iterations;
          o.prestress_factor = reports::checked_prestress_factor(prestress_factor);
          o.backend_options = options;
          return std::string(reports::checked_solver(solver, o)->name());
        },
        py::arg("solver"), py::arg("tol"), py::arg("time_limit"), py::arg("max_iterations"),
        py::arg("prestress_factor"), py::arg("options"));

  m.def("_forces", &run_forces, py::arg("scene"), py::arg("tol"));

  m.def("_keep_freed_memory_for_reuse", &keep_freed_memory_for_reuse,
        "Sets this process's malloc to keep and reuse freed buffers (for sweep worker processes).");

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
}

}  // namespace tensegrity::python
