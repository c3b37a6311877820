// numpy conversions and checks shared by the binding files.
#include <cmath>

#include "model/errors.hpp"
#include "python/src/bindings.hpp"

namespace tensegrity::python {

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


void check_tolerance(double tol) {
  if (!(std::isfinite(tol) && tol > 0)) throw InputError("command line", "--tol", "must be a finite number > 0");
}

}  // namespace tensegrity::python
