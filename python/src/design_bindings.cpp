// tensegrity.design: the pipeline of `tensegrity design` (reports/design_pipeline.hpp)
// with the command's option checks in the command's order and its messages; the
// file written by DesignResult.save is the one `tensegrity design --out` writes.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <Eigen/Core>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "reports/design_pipeline.hpp"
#include "reports/fabrication_sheet.hpp"
#include "reports/naive_comparison_report.hpp"
#include "reports/output.hpp"
#include "design/naive_sweep.hpp"
#include "model/design.hpp"
#include "model/errors.hpp"
#include "model/scene_io.hpp"
#include "python/src/bindings.hpp"

namespace tensegrity::python {

namespace {

// Options are named "command line" in messages, as the program names them.
constexpr const char* kOptionsSource = "command line";
// The largest --settle-duration the command accepts (s).
constexpr double kMaxSettleDuration = 1e4;

// The options of `tensegrity design` but its output paths.
struct DesignArguments {
  double strain = 0.3;
  std::string material = reports::kDefaultMaterial;
  std::vector<std::string> material_dirs;
  double naive_fraction = std::nan("");
  std::string solver;
  double tol = 1e-8;
  double time_limit = 120.0;
  bool compare_naive = false;
  std::string naive_fractions;
  std::string settle = "relax";
  double settle_duration = 5.0;
};

// A finished design run: the design when one exists, else the command's reason.
struct PyDesign {
  bool ok = false;
  std::string input;    // names the input in messages
  std::string message;  // the command's last line on standard error
  std::string comparison_table;  // --compare-naive's table, "" without it
  reports::DesignOutcome outcome;

  const Design& design() const {
    if (!ok) throw std::runtime_error(message);
    return outcome.design;
  }
};

std::string six_digits(double v) {
  std::ostringstream s;
  s.precision(6);
  s << v;
  return s.str();
}

// The line `tensegrity design` ends a successful run with.
std::string design_summary(const PyDesign& r) {
  const Design& d = r.design();
  int struts = 0, cables = 0;
  for (const auto& el : d.structure.elements) (el.kind == ElementKind::Strut ? struts : cables)++;
  const auto [lo, hi] = r.outcome.strain_range;
  return "design: " + d.structure.name + ": " + std::to_string(struts) + " struts, " + std::to_string(cables) +
         " cables, cable strain " + six_digits(100 * lo) + "% .. " + six_digits(100 * hi) +
         "%, relative residual " + six_digits(d.solution.stats.relative_residual);
}

// FROM:TO:N of --naive-fractions, checked as the command checks it.
std::vector<double> parse_fraction_grid(const std::string& spec) {
  const std::string item = "--naive-fractions";
  double from = 0, to = 0;
  int n = 0;
  char tail = 0;
  if (std::sscanf(spec.c_str(), "%lf:%lf:%d%c", &from, &to, &n, &tail) != 3)
    throw InputError(kOptionsSource, item, "expected FROM:TO:N (e.g. 0.5:0.95:10), got '" + spec + "'");
  for (double f : {from, to})
    if (!std::isfinite(f) || !(f > 0.0) || f > 1.0)
      throw InputError(kOptionsSource, item, "fractions must lie in (0, 1], got '" + spec + "'");
  if (n < 1 || n > 1000) throw InputError(kOptionsSource, item, "N must be 1..1000, got '" + spec + "'");
  return fraction_grid(from, to, n);
}

// `scene` given: designs it, named `input` in messages; else reads the file
// `input` (scene, character or design), as the command does.
PyDesign run_design(const std::shared_ptr<Structure>& scene, const std::string& input, const DesignArguments& a) {
  reports::DesignRequest req;
  req.material = a.material;
  req.material_dirs = a.material_dirs;
  // The program finds the checkout's materials beside itself; the module, where it was built from.
  req.material_dirs.push_back(TENSEGRITY_MATERIALS_DIR);
  req.strain = a.strain;
  req.naive_fraction = a.naive_fraction;
  req.tol = a.tol;
  req.time_limit = a.time_limit;
  reports::check_design_request(req);
  const bool naive = !std::isnan(a.naive_fraction);
  const bool compare = a.compare_naive || !a.naive_fractions.empty();
  if (compare && naive)
    throw InputError(kOptionsSource, "--compare-naive",
                     "compares the stiffness design with naive ones; it cannot be combined with --naive-fraction");
  std::vector<double> fractions;
  if (!a.naive_fractions.empty()) fractions = parse_fraction_grid(a.naive_fractions);
  SettleOptions settle_options;
  if (a.settle == "simulate") settle_options.method = SettleMethod::Simulate;
  else if (a.settle != "relax")
    throw InputError(kOptionsSource, "--settle", "expected relax or simulate, got '" + a.settle + "'");
  if (!std::isfinite(a.settle_duration) || !(a.settle_duration > 0.0) || a.settle_duration > kMaxSettleDuration)
    throw InputError(kOptionsSource, "--settle-duration", "must be a number of seconds in (0, 1e4]");
  settle_options.duration = a.settle_duration;
  SolveOptions options;
  options.tolerance = a.tol;
  options.time_limit_s = a.time_limit;
  const auto solver = reports::checked_solver(a.solver, options);  // unknown names fail before any work

  PyDesign out;
  out.input = input;
  py::gil_scoped_release release;
  const Structure structure = scene ? *scene : reports::read_design_input(input);
  out.outcome = reports::design_structure(structure, input, req, *solver);
  if (!out.outcome.ok) {
    const std::string& item = out.outcome.failure_item;
    out.message = kMessagePrefix + input + ": " + (item.empty() ? "" : item + ": ") + out.outcome.failure_reason +
                  "; no design written";
    return out;
  }
  out.ok = true;
  if (compare) {
    Design& d = out.outcome.design;
    if (fractions.empty()) fractions = default_fraction_grid(d);
    const NaiveComparison c = naive_fraction_sweep(d, fractions, settle_options);
    out.comparison_table = reports::naive_comparison_table(c, settle_options.method);
    d.info["naive_comparison"] = reports::naive_comparison_json(c, settle_options.method);
  }
  return out;
}

py::object json_to_python(const nlohmann::json& j) { return py::module_::import("json").attr("loads")(j.dump()); }

}  // namespace

void bind_design(py::module_& m) {
  py::class_<PyDesign>(m, "DesignResult", R"doc(
The outcome of `design`: a buildable design (ok) or the reason none exists.

ok: True when a design that verifies was made; otherwise `message` is the
command's last line ("tensegrity: INPUT: ITEM: REASON; no design written") and
everything else raises RuntimeError with it, as the command writes no file.)doc")
      .def_readonly("ok", &PyDesign::ok)
      .def_readonly("message", &PyDesign::message, "Why no design exists ('' when ok).")
      .def_readonly("comparison_table", &PyDesign::comparison_table,
                    "The --compare-naive table the command prints on standard error ('' without it).")
      .def_property_readonly("scene", [](const PyDesign& r) { return std::make_shared<Structure>(r.design().structure); },
                             "The Scene at the designed geometry.")
      .def_property_readonly("positions", [](const PyDesign& r) { return positions_array(r.design().structure.positions); },
                             "(n, 3) designed node positions in m.")
      .def_property_readonly("forces", [](const PyDesign& r) { return vector_array(r.design().solution.forces); },
                             "(m,) designed axial forces in N, positive = tension.")
      .def_property_readonly("rest_lengths",
                             [](const PyDesign& r) { return vector_array(r.design().solution.rest_lengths.value()); },
                             "(m,) rest lengths in m (a strut's is its length).")
      .def_property_readonly("lengths", [](const PyDesign& r) {
                               r.design();
                               return vector_array(r.outcome.rest.lengths);
                             },
                             "(m,) element lengths at the designed geometry in m.")
      .def_property_readonly("strains", [](const PyDesign& r) { return vector_array(r.design().strains); },
                             "(m,) cable strains l / L - 1 (0 for struts).")
      .def_property_readonly("cable_materials", [](const PyDesign& r) { return r.design().cable_material; },
                             "Per element, the cable's material name ('' for struts).")
      .def_property_readonly("info", [](const PyDesign& r) { return json_to_python(r.design().info); },
                             "The design file's \"design\" record: mode, stage reports, comparison.")
      .def("save", [](const PyDesign& r, const std::filesystem::path& path) { write_design_file(r.design(), path.string()); },
           py::arg("path"), "Writes the design file, the one `tensegrity design --out` writes.")
      .def("save_sheet",
           [](const PyDesign& r, const std::filesystem::path& path) {
             const std::string sheet = reports::fabrication_sheet_csv(r.design(), r.outcome.rest.lengths);
             write_text_file_atomically(path.string(), sheet);
           },
           py::arg("path"), "Writes the fabrication sheet (CSV), the command's --sheet file.")
      .def("save_cut_list",
           [](const PyDesign& r, const std::filesystem::path& path) {
             reports::write_cut_list(r.design(), r.outcome.rest.lengths, path.string());
           },
           py::arg("path"), "Writes the cut list: .pdf on A4 pages (printable), .svg or .png on one page.")
      .def("sheet_csv",
           [](const PyDesign& r) { return reports::fabrication_sheet_csv(r.design(), r.outcome.rest.lengths); },
           "The fabrication sheet's text.")
      .def("to_json", [](const PyDesign& r) { return design_to_json(r.design()).dump(2); },
           "The design file's text.")
      .def("summary", &design_summary, "The line the command prints on standard error after a design.")
      .def("__bool__", [](const PyDesign& r) { return r.ok; })
      .def("__repr__", [](const PyDesign& r) {
        return "<tensegrity.DesignResult " + (r.ok ? design_summary(r) : r.message) + ">";
      });

  m.def("_design",
        [](std::shared_ptr<Structure> scene, py::object positions, const std::string& input, double strain, const std::string& material,
           const std::vector<std::string>& material_dirs, double naive_fraction, const std::string& solver, double tol,
           double time_limit, bool compare_naive, const std::string& naive_fractions, const std::string& settle,
           double settle_duration) {
          DesignArguments a;
          a.strain = strain;
          a.material = material;
          a.material_dirs = material_dirs;
          a.naive_fraction = naive_fraction;
          a.solver = solver;
          a.tol = tol;
          a.time_limit = time_limit;
          a.compare_naive = compare_naive;
          a.naive_fractions = naive_fractions;
          a.settle = settle;
          a.settle_duration = settle_duration;
          if (scene && !positions.is_none()) {  // a solve's result: its scene at the solved geometry
            auto p = py::array_t<double, py::array::forcecast>::ensure(positions);
            if (!p || p.ndim() != 2 || p.shape(0) != scene->num_nodes() || p.shape(1) != 3)
              throw InputError("arrays", "positions", "expected shape (" + std::to_string(scene->num_nodes()) + ", 3)");
            scene = std::make_shared<Structure>(*scene);
            for (int i = 0; i < scene->num_nodes(); ++i)
              for (int k = 0; k < 3; ++k) scene->positions(k, i) = p.at(i, k);
          }
          return run_design(scene, input, a);
        },
        py::arg("scene").none(true), py::arg("positions"), py::arg("input"), py::arg("strain"), py::arg("material"),
        py::arg("material_dirs"), py::arg("naive_fraction"), py::arg("solver"), py::arg("tol"),
        py::arg("time_limit"), py::arg("compare_naive"), py::arg("naive_fractions"), py::arg("settle"),
        py::arg("settle_duration"));
}

}  // namespace tensegrity::python
