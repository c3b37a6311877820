// The simulation of a design and the renderer, with the checks and messages
// of `tensegrity simulate` and `tensegrity render`.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "reports/renderer.hpp"
#include "model/design.hpp"
#include "model/errors.hpp"
#include "simulation/simulator.hpp"
#include "python/src/bindings.hpp"

namespace tensegrity::python {

void bind_simulate(py::module_& m) {
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
           const std::string& view, int width, int height, const std::string& title, bool reference,
           const std::string& colour_by, bool labels, bool legend) {
          constexpr int kMinPixels = 64, kMaxPixels = 8192;
          if (width < kMinPixels || width > kMaxPixels)
            throw InputError("command line", "--width", "must be within 64..8192");
          if (height < kMinPixels || height > kMaxPixels)
            throw InputError("command line", "--height", "must be within 64..8192");
          reports::RenderOptions options;
          options.view = view;
          options.width = width;
          options.height = height;
          options.title = title;
          options.colour_by = colour_by;
          options.labels = labels;
          options.legend = legend;
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
          reports::RenderData data;
          data.forces = f;
          // As `render SCENE SOLUTION`: the shape before form finding behind a result.
          if (!positions.is_none() && reference) data.reference = scene.positions;
          py::gil_scoped_release release;
          reports::render_structure(scene, p, data, options, path);
        },
        py::arg("scene"), py::arg("positions"), py::arg("forces"), py::arg("path"), py::arg("view"),
        py::arg("width"), py::arg("height"), py::arg("title"), py::arg("reference"), py::arg("colour_by"),
        py::arg("labels"), py::arg("legend"));
}

}  // namespace tensegrity::python
