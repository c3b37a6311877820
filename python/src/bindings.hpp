#pragma once
// Pieces of the tensegrity._core module shared by its binding files: numpy
// conversions, the solve result bound as tensegrity.Result, and one function
// per subject that adds its classes and functions to the module.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <Eigen/Core>
#include <memory>
#include <string>

#include "model/solution.hpp"
#include "model/structure.hpp"
#include "solvers/solver.hpp"

namespace tensegrity::python {

namespace py = pybind11;

// The command line prints "tensegrity: " before the InputError's text.
inline constexpr const char* kMessagePrefix = "tensegrity: ";

// (n, 3) float64 array of the columns of p (a copy).
py::array_t<double> positions_array(const Eigen::Matrix3Xd& p);
// (n,) float64 array (a copy).
py::array_t<double> vector_array(const Eigen::VectorXd& x);
// InputError with the command line's --tol message unless tol is finite and > 0.
void check_tolerance(double tol);

// A finished solve with what is needed to write its solution file.
struct PyResult {
  SolveResult result;
  std::shared_ptr<const Structure> scene;
  std::string solver;
  double tolerance = 1e-8;

  Solution solution() const { return to_solution(result, *scene, solver); }
};

// Scene, load_scene, scene_from_json (scene_bindings.cpp).
void bind_scene(py::module_& m);
// build_character, chain, prism, octahedron and the stress-test families (generator_bindings.cpp).
void bind_generators(py::module_& m);
// Verification, Result, solvers and the solve, forces and check entry points (solve_bindings.cpp).
void bind_solve(py::module_& m);
// The design pipeline of `tensegrity design` (design_bindings.cpp).
void bind_design(py::module_& m);
// The simulation of a design and the renderer (simulate_bindings.cpp).
void bind_simulate(py::module_& m);

}  // namespace tensegrity::python
