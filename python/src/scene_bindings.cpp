// tensegrity.Scene: a scene built from numpy arrays passes the validation of a
// scene file (the same messages), and reads back as fresh numpy copies.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "model/errors.hpp"
#include "model/json_text.hpp"
#include "model/scene_io.hpp"
#include "python/src/bindings.hpp"

namespace tensegrity::python {

namespace {

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

// Node indices given as floats (or as unsigned integers beyond int64) would
// be truncated or wrapped by the cast: each must equal its integer value.
void require_integer_indices(const py::object& given, const std::string& source) {
  constexpr int kFlat = py::array::c_style | py::array::forcecast;
  const auto as_numbers = py::array_t<double, kFlat>::ensure(given);
  const auto as_indices = py::array_t<std::int64_t, kFlat>::ensure(given);
  if (!as_numbers || !as_indices || as_numbers.size() != as_indices.size()) return;
  const double* value = as_numbers.data();
  const std::int64_t* index = as_indices.data();
  for (py::ssize_t k = 0; k < as_indices.size(); ++k)
    if (value[k] != static_cast<double>(index[k]))
      throw InputError(source, "elements", "expected integer node indices, got " + message_number(value[k]));
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

void bind_scene(py::module_& m) {
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
             require_integer_indices(elements, source);
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
}

}  // namespace tensegrity::python
