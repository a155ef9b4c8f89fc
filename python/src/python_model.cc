#include "python_model.h"

#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <optional>

#include "skidimm/errors.h"

namespace skidimm {
namespace python {

namespace py = pybind11;

namespace {

// The first exception a Python model raised since the last clear. Only
// touched with the GIL held, which serialises every access.
std::optional<py::error_already_set>& pending_error() {
  static auto* pending = new std::optional<py::error_already_set>();  // never destroyed: outlives the interpreter
  return *pending;
}

py::array_t<double> vector_to_array(const Eigen::Ref<const Eigen::VectorXd>& v) {
  py::array_t<double> a(v.size());
  std::copy(v.data(), v.data() + v.size(), a.mutable_data());
  return a;
}

py::array_t<double> matrix_to_array(const Eigen::Ref<const Eigen::MatrixXd>& m) {
  py::array_t<double> a({m.rows(), m.cols()});
  auto r = a.mutable_unchecked<2>();
  for (Eigen::Index i = 0; i < m.rows(); ++i) {
    for (Eigen::Index j = 0; j < m.cols(); ++j) r(i, j) = m(i, j);
  }
  return a;
}

std::vector<std::string> names_of(const py::object& instance, const char* attribute) {
  if (!py::hasattr(instance, attribute) || instance.attr(attribute).is_none()) return {};
  std::vector<std::string> out;
  for (const py::handle item : instance.attr(attribute)) out.push_back(py::str(item));
  return out;
}

// Whether `instance` defines `name` itself (not the skidimm.MotionModel base's placeholder).
bool overrides(const py::object& instance, const char* name) {
  if (!py::hasattr(instance, name)) return false;
  const py::object method = instance.attr(name);
  return !py::hasattr(method, "__skidimm_default__");
}

}  // namespace

void PythonModelRaised::restore() const {
  auto& pending = pending_error();
  if (pending) {
    py::error_already_set error = *pending;
    pending.reset();
    error.restore();
  } else {
    PyErr_SetString(PyExc_RuntimeError, what());
  }
}

void clear_python_model_error() { pending_error().reset(); }

void throw_if_python_model_raised() {
  if (pending_error()) throw PythonModelRaised();
}

py::dict parameters_to_dict(const sdk::ParameterSet& params) {
  py::dict out;
  for (const std::string& key : params.keys()) {
    if (const Eigen::MatrixXd* m = params.find(key)) {
      if (m->size() == 1) {
        out[py::str(key)] = py::float_((*m)(0, 0));
      } else if (m->cols() == 1) {
        out[py::str(key)] = vector_to_array(m->col(0));
      } else {
        out[py::str(key)] = matrix_to_array(*m);
      }
    } else if (const std::vector<std::string>* text = params.find_text(key)) {
      out[py::str(key)] = py::cast(*text);
    }
  }
  return out;
}

PythonMotionModel::PythonMotionModel(const py::object& cls, const std::string& model_name,
                                     const sdk::ParameterSet& params, const std::vector<std::string>& bank_states,
                                     const std::vector<bool>& bank_angles, const std::vector<std::string>& bank_inputs)
    : model_name_(model_name) {
  instance_ = std::make_unique<py::object>(cls(parameters_to_dict(params)));
  const py::object& self = *instance_;
  if (!overrides(self, "predict")) {
    throw Error("Python model '" + model_name + "' (" + py::str(cls).cast<std::string>() +
                ") defines no predict(x, u, dt)");
  }
  predict_ = std::make_unique<py::object>(self.attr("predict"));
  has_jacobian_ = overrides(self, "jacobian");
  if (has_jacobian_) jacobian_ = std::make_unique<py::object>(self.attr("jacobian"));
  if (overrides(self, "process_noise")) process_noise_ = std::make_unique<py::object>(self.attr("process_noise"));

  state_names_ = names_of(self, "states");
  input_names_ = names_of(self, "inputs");
  const std::vector<std::string> angle_names = names_of(self, "angles");
  if (state_names_.empty()) {  // the bank's names, like linear_features
    state_names_ = bank_states;
    angles_ = bank_angles;
  } else {
    angles_.assign(state_names_.size(), false);
    for (const std::string& a : angle_names) {
      const auto it = std::find(state_names_.begin(), state_names_.end(), a);
      if (it == state_names_.end()) throw Error("Python model '" + model_name + "': angle '" + a + "' is not a state");
      angles_[static_cast<std::size_t>(it - state_names_.begin())] = true;
    }
  }
  if (input_names_.empty()) input_names_ = bank_inputs;

  // Fitted parameters: each key of `fit_parameters`, flattened row-major.
  for (const std::string& key : names_of(self, "fit_parameters")) {
    const py::object value = self.attr("params")[py::str(key)];
    FitKey k{key, {}, 1};
    if (!py::isinstance<py::float_>(value) && !py::isinstance<py::int_>(value)) {
      // Written in place by set_parameters: it must be a C-contiguous float64 array.
      if (!py::isinstance<py::array>(value) || !py::array(value).dtype().is(py::dtype::of<double>()) ||
          !(py::array(value).flags() & py::array::c_style)) {
        throw Error("Python model '" + model_name + "': fit parameter '" + key +
                    "' must be a float or a C-contiguous float64 numpy array");
      }
      const py::array a = value;
      k.shape.assign(a.shape(), a.shape() + a.ndim());
      k.size = static_cast<int>(a.size());
    }
    if (k.shape.empty()) {
      parameter_info_.push_back(sdk::scalar_parameter_info(key, "", -std::numeric_limits<double>::infinity(),
                                                           std::numeric_limits<double>::infinity()));
    } else {
      for (int i = 0; i < k.size; ++i) {
        sdk::ParameterInfo info;
        info.key = key;
        info.name = key + "[" + std::to_string(i) + "]";
        if (k.shape.size() == 2) {
          info.name = key + "[" + std::to_string(i / k.shape[1]) + "," + std::to_string(i % k.shape[1]) + "]";
        }
        parameter_info_.push_back(info);
      }
    }
    fit_keys_.push_back(k);
  }
}

PythonMotionModel::~PythonMotionModel() {
  if (!Py_IsInitialized()) {  // at exit: leak rather than touch a finished interpreter
    (void)instance_.release();
    (void)predict_.release();
    (void)jacobian_.release();
    (void)process_noise_.release();
    return;
  }
  py::gil_scoped_acquire gil;
  predict_.reset();
  jacobian_.reset();
  process_noise_.reset();
  instance_.reset();
}

template <typename Out, typename... Args>
bool PythonMotionModel::call(const py::object& method, const char* what, Eigen::Index rows, Eigen::Index cols, Out out,
                             Args&&... args) const noexcept {
  // The GIL is held by the caller (it made the arguments).
  try {
    const py::object result = method(std::forward<Args>(args)...);
    const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(result);
    if (!a || a.size() != rows * cols || (cols > 1 && a.ndim() != 2)) {
      PyErr_SetString(PyExc_ValueError, (model_name_ + "." + what + "() must return " + std::to_string(rows) +
                                         (cols > 1 ? "x" + std::to_string(cols) + " numbers" : " numbers"))
                                            .c_str());
      throw py::error_already_set();
    }
    const double* data = a.data();
    for (Eigen::Index i = 0; i < rows; ++i) {
      for (Eigen::Index j = 0; j < cols; ++j) out(i, j) = data[i * cols + j];
    }
    return true;
  } catch (py::error_already_set& e) {
    pending_error() = e;
  } catch (const std::exception& e) {
    PyErr_SetString(PyExc_RuntimeError, (model_name_ + "." + what + "(): " + e.what()).c_str());
    pending_error() = py::error_already_set();
  }
  return false;
}

bool PythonMotionModel::predict(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u,
                                double dt, Eigen::Ref<Eigen::VectorXd> x_next) const noexcept {
  py::gil_scoped_acquire gil;  // before the arguments are made
  if (pending_error()) return false;
  return call(
      *predict_, "predict", x.size(), 1, [&](Eigen::Index i, Eigen::Index) -> double& { return x_next[i]; },
      vector_to_array(x), vector_to_array(u), dt);
}

bool PythonMotionModel::jacobian(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u,
                                 double dt, Eigen::Ref<Eigen::MatrixXd> jacobian) const noexcept {
  if (!has_jacobian_) return sdk::MotionModel::jacobian(x, u, dt, jacobian);
  py::gil_scoped_acquire gil;
  if (pending_error()) return false;
  return call(
      *jacobian_, "jacobian", x.size(), x.size(),
      [&](Eigen::Index i, Eigen::Index j) -> double& { return jacobian(i, j); }, vector_to_array(x), vector_to_array(u),
      dt);
}

bool PythonMotionModel::process_noise(const Eigen::Ref<const Eigen::MatrixXd>& intensity,
                                      const Eigen::Ref<const Eigen::VectorXd>& x,
                                      const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
                                      Eigen::Ref<Eigen::MatrixXd> noise) const noexcept {
  if (!process_noise_) return sdk::MotionModel::process_noise(intensity, x, u, dt, noise);
  py::gil_scoped_acquire gil;
  if (pending_error()) return false;
  return call(
      *process_noise_, "process_noise", intensity.rows(), intensity.cols(),
      [&](Eigen::Index i, Eigen::Index j) -> double& { return noise(i, j); }, matrix_to_array(intensity),
      vector_to_array(x), vector_to_array(u), dt);
}

void PythonMotionModel::get_parameters(Eigen::Ref<Eigen::VectorXd> values) const noexcept {
  py::gil_scoped_acquire gil;
  try {
    Eigen::Index at = 0;
    for (const FitKey& k : fit_keys_) {
      const py::object value = instance_->attr("params")[py::str(k.key)];
      if (k.shape.empty()) {
        values[at++] = value.cast<double>();
      } else {
        const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(value);
        for (int i = 0; i < k.size; ++i) values[at++] = a.data()[i];
      }
    }
  } catch (py::error_already_set& e) {
    if (!pending_error()) pending_error() = e;
  } catch (const std::exception&) {
    values.setConstant(std::numeric_limits<double>::quiet_NaN());
  }
}

bool PythonMotionModel::set_parameters(const Eigen::Ref<const Eigen::VectorXd>& values, std::string* error) noexcept {
  if (!sdk::check_parameter_values(parameter_info_, values, error)) return false;
  py::gil_scoped_acquire gil;
  try {
    py::object params = instance_->attr("params");
    Eigen::Index at = 0;
    for (const FitKey& k : fit_keys_) {
      if (k.shape.empty()) {
        params[py::str(k.key)] = py::float_(values[at++]);
      } else {
        // In place, so that references the model holds to the array see the new values.
        py::array a = params[py::str(k.key)].cast<py::array>();
        if (!a.dtype().is(py::dtype::of<double>()) || !(a.flags() & py::array::c_style) || a.size() != k.size) {
          throw Error("parameter '" + k.key + "' is no longer a C-contiguous float64 array of its first shape");
        }
        double* data = static_cast<double*>(a.mutable_data());
        for (int i = 0; i < k.size; ++i) data[i] = values[at++];
      }
    }
    return true;
  } catch (const std::exception& e) {
    if (error != nullptr) *error = std::string("Python model '") + model_name_ + "': " + e.what();
    PyErr_Clear();
    return false;
  }
}

}  // namespace python
}  // namespace skidimm
