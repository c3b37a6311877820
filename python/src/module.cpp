// tensegrity._core: the library bound for Python with pybind11. Arrays cross as
// numpy arrays in the row-major shapes users expect ((n, 3) positions, (m, 2)
// elements); the solver logic stays in C++, and the GIL is released while it
// runs. InputError becomes ValueError carrying the command line's own message.
#include <pybind11/pybind11.h>

#include <exception>
#include <string>

#include "reports/output.hpp"
#include "model/errors.hpp"
#include "python/src/bindings.hpp"

namespace py = pybind11;
using namespace tensegrity;
using namespace tensegrity::python;

PYBIND11_MODULE(_core, m) {
  m.doc() = "Compiled core of the tensegrity package (form finding of tensegrity structures).";

  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const OptionError& e) {
      PyErr_SetString(PyExc_ValueError, reports::option_error_line(e).c_str());
    } catch (const UnknownNameError& e) {
      PyErr_SetString(PyExc_ValueError, reports::unknown_name_line(e).c_str());
    } catch (const InputError& e) {
      PyErr_SetString(PyExc_ValueError, (std::string(kMessagePrefix) + e.what()).c_str());
    }
  });

  bind_scene(m);
  bind_generators(m);
  bind_solve(m);
  bind_design(m);
  bind_simulate(m);
}
