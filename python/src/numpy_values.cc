#include "numpy_values.h"

#include <algorithm>

namespace skidimm {
namespace python {

namespace py = pybind11;

py::array_t<double> vector_array(const Eigen::VectorXd& v) {
  py::array_t<double> a(v.size());
  std::copy(v.data(), v.data() + v.size(), a.mutable_data());
  return a;
}

py::array_t<double> matrix_array(const Eigen::MatrixXd& m) {
  py::array_t<double> a({m.rows(), m.cols()});
  auto r = a.mutable_unchecked<2>();
  for (Eigen::Index i = 0; i < m.rows(); ++i) {
    for (Eigen::Index j = 0; j < m.cols(); ++j) r(i, j) = m(i, j);
  }
  return a;
}

py::array object_array(py::ssize_t n) { return py::array(py::dtype("O"), std::vector<py::ssize_t>{n}); }

py::array text_array(const std::vector<std::string>& values) {
  py::array out = object_array(static_cast<py::ssize_t>(values.size()));
  PyObject** data = static_cast<PyObject**>(out.mutable_data());
  for (std::size_t k = 0; k < values.size(); ++k) data[k] = py::str(values[k]).release().ptr();
  return out;
}

}  // namespace python
}  // namespace skidimm
