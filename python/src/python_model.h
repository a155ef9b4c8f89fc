// A motion model written in Python, usable as a mode of a bank next to
// compiled plugins (docs/python.md, "Motion models in Python").
//
// PythonMotionModel adapts an instance of a Python class (a subclass of
// skidimm.MotionModel) to the engine's sdk::MotionModel:
//
//   predict(x, u, dt) -> x_next           required
//   jacobian(x, u, dt) -> F               optional; else numeric differences of predict
//   process_noise(Q, x, u, dt) -> Qd      optional; else Q * dt
//   states, inputs, angles                names (empty: the bank's)
//   params                                the mode's parameters (dict); the
//   fit_parameters                        keys of params the fitter may change
//
// Threading: the engine calls a model from the thread running a step, with
// the GIL released by the bindings; each call here re-acquires it. This is
// the slow path: a few microseconds per call (measured in docs/python.md).
//
// Errors: the SDK's virtuals are noexcept, so an exception raised by the
// Python code is caught, kept (the first one), and the call returns false:
// the engine rejects that mode for the step, as for any failing model. Once
// one is kept, every Python model returns false at once, and the binding
// that started the C++ call re-raises it when the call returns
// (throw_if_python_model_raised), as the exception the model raised.
#ifndef SKIDIMM_PYTHON_PYTHON_MODEL_H_
#define SKIDIMM_PYTHON_PYTHON_MODEL_H_

#include <pybind11/pybind11.h>

#include <exception>
#include <memory>
#include <string>
#include <vector>

#include "skidimm/sdk/motion_model.h"
#include "skidimm/sdk/parameters.h"

namespace skidimm {
namespace python {

// Thrown (with the GIL held) when a Python model raised during a C++ call;
// the exception translator restores the model's own exception.
class PythonModelRaised : public std::exception {
 public:
  const char* what() const noexcept override { return "a Python motion model raised an exception"; }
  void restore() const;
};

// Forgets a kept exception (before a new C++ call). GIL held.
void clear_python_model_error();
// Throws PythonModelRaised if a Python model raised since the last clear. GIL held.
void throw_if_python_model_raised();

// The mode's parameters as Python values: a number for a 1x1 matrix, a 1-D
// array for a column, a 2-D array for a matrix, a list of str for text.
pybind11::dict parameters_to_dict(const sdk::ParameterSet& params);

class PythonMotionModel final : public sdk::MotionModel {
 public:
  // Instantiates `cls(params)` (GIL held). `bank_states`/`bank_inputs`/
  // `bank_angles` are used when the instance names none. Throws
  // pybind11::error_already_set if the constructor raises, Error if the
  // instance has no predict or inconsistent names.
  PythonMotionModel(const pybind11::object& cls, const std::string& model_name, const sdk::ParameterSet& params,
                    const std::vector<std::string>& bank_states, const std::vector<bool>& bank_angles,
                    const std::vector<std::string>& bank_inputs);
  ~PythonMotionModel() override;

  int state_dim() const noexcept override { return static_cast<int>(state_names_.size()); }
  int input_dim() const noexcept override { return static_cast<int>(input_names_.size()); }
  const std::vector<std::string>& state_names() const noexcept override { return state_names_; }
  const std::vector<std::string>& input_names() const noexcept override { return input_names_; }
  bool is_angle(int state_index) const noexcept override {
    return state_index >= 0 && state_index < state_dim() && angles_[static_cast<std::size_t>(state_index)];
  }

  const std::vector<sdk::ParameterInfo>& parameter_info() const noexcept override { return parameter_info_; }
  void get_parameters(Eigen::Ref<Eigen::VectorXd> values) const noexcept override;
  bool set_parameters(const Eigen::Ref<const Eigen::VectorXd>& values, std::string* error) noexcept override;

  bool predict(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
               Eigen::Ref<Eigen::VectorXd> x_next) const noexcept override;
  bool jacobian(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
                Eigen::Ref<Eigen::MatrixXd> jacobian) const noexcept override;
  bool has_analytic_jacobian() const noexcept override { return has_jacobian_; }
  bool process_noise(const Eigen::Ref<const Eigen::MatrixXd>& intensity, const Eigen::Ref<const Eigen::VectorXd>& x,
                     const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
                     Eigen::Ref<Eigen::MatrixXd> noise) const noexcept override;

  // The Python instance (GIL held to use it).
  const pybind11::object& instance() const { return *instance_; }

 private:
  struct FitKey {
    std::string key;
    std::vector<pybind11::ssize_t> shape;  // empty: a float
    int size = 1;
  };

  // Calls `method(args...)` and copies the result, `rows` x `cols`, into out.
  // The GIL must be held (the arguments are Python objects).
  template <typename Out, typename... Args>
  bool call(const pybind11::object& method, const char* what, Eigen::Index rows, Eigen::Index cols, Out out,
            Args&&... args) const noexcept;

  std::string model_name_;
  std::unique_ptr<pybind11::object> instance_;
  std::unique_ptr<pybind11::object> predict_, jacobian_, process_noise_;
  bool has_jacobian_ = false;
  std::vector<std::string> state_names_, input_names_;
  std::vector<bool> angles_;
  std::vector<FitKey> fit_keys_;
  std::vector<sdk::ParameterInfo> parameter_info_;
};

}  // namespace python
}  // namespace skidimm

#endif  // SKIDIMM_PYTHON_PYTHON_MODEL_H_
