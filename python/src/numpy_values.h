// C++ values as numpy arrays, and numpy arrays as the engine reads them.
#ifndef SKIDIMM_PYTHON_NUMPY_VALUES_H_
#define SKIDIMM_PYTHON_NUMPY_VALUES_H_

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <Eigen/Core>
#include <string>
#include <utility>
#include <vector>

namespace skidimm {
namespace python {

// float64 in C order: what the engine reads (other arrays are converted once).
using DoubleArray = pybind11::array_t<double, pybind11::array::c_style | pybind11::array::forcecast>;

// A C++ vector handed to numpy without a copy: the array owns the vector.
template <typename T>
pybind11::array_t<T> adopt(std::vector<T>&& values) {
  auto* owner = new std::vector<T>(std::move(values));
  pybind11::capsule free_when_done(owner, [](void* p) { delete static_cast<std::vector<T>*>(p); });
  return pybind11::array_t<T>(static_cast<pybind11::ssize_t>(owner->size()), owner->data(), free_when_done);
}

pybind11::array_t<double> vector_array(const Eigen::VectorXd& v);
pybind11::array_t<double> matrix_array(const Eigen::MatrixXd& m);

// A numpy object array of n entries, every one NULL (numpy zero-fills the
// memory of object arrays it allocates) until the caller sets it.
pybind11::array object_array(pybind11::ssize_t n);

// A numpy object array of str.
pybind11::array text_array(const std::vector<std::string>& values);

}  // namespace python
}  // namespace skidimm

#endif  // SKIDIMM_PYTHON_NUMPY_VALUES_H_
