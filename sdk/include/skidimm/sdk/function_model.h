// A motion model written as one templated function and a parameter table.
//
// The author writes a plain struct (the "spec"):
//
//   struct SlipRatio {
//     static constexpr const char* kName = "slip_ratio";      // the bank's `model:`
//     static constexpr const char* kVersion = "0.1.0";
//     static constexpr const char* kDescription = "[V, omega, s] with a slip-ratio state";
//     static constexpr skidimm::sdk::VariableDoc kStates[] = {{"V", "forward speed (m/s)", false}, ...};
//     static constexpr skidimm::sdk::VariableDoc kInputs[] = {{"phi_dot_L", "left wheel speed (rad/s)", false}, ...};
//     static constexpr skidimm::sdk::ParameterSpec kParameters[] = {
//         {"tau", "time constant (s)", 1e-3, 10.0},                                    // per mode
//         {"r", "wheel radius (m)", 1e-3, 1.0, skidimm::sdk::ParameterScope::kBank},  // under shared:
//     };
//     // x: states, u: inputs, p: parameters in kParameters' order; x_next: the state after dt.
//     template <typename T>
//     static void predict(const T* x, const double* u, const T* p, double dt, T* x_next) { ... }
//   };
//   SKIDIMM_EXPORT_FUNCTION_MODEL(SlipRatio)
//
// and the SDK generates the rest: the SizedMotionModel class, Create() (every
// parameter read from the bank as a scalar, unknown and missing keys and
// values out of bounds refused with the key named), get/set of the flat
// parameter vector, the PluginInfo `skidimm plugins` prints (states, inputs,
// each parameter with its bounds and scope), the state Jacobian and the
// parameter Jacobian (for `skidimm fit`), both exact, by automatic
// differentiation with Ceres jets (header only: nothing to link). An
// exception thrown by predict becomes a rejected step with its text, as for
// any SizedMotionModel.
//
// Angle states (VariableDoc::is_angle) are wrapped to [-pi, pi) after
// predict. A spec may add its own state Jacobian, used instead of jets:
//
//     static void jacobian(const double* x, const double* u, const double* p, double dt,
//                          double* jacobian);  // row-major, state x state
//
// (the conformance kit checks it against differences like any other).
//
// Every parameter is a scalar. A model with matrix parameters derives from
// SizedMotionModel instead (sized_motion_model.h); FunctionModel is one such
// class.
#ifndef SKIDIMM_SDK_FUNCTION_MODEL_H_
#define SKIDIMM_SDK_FUNCTION_MODEL_H_

#include <ceres/jet.h>

#include <Eigen/Core>
#include <cmath>
#include <iterator>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

#include "skidimm/sdk/angles.h"
#include "skidimm/sdk/export.h"
#include "skidimm/sdk/parameters.h"
#include "skidimm/sdk/plugin_info.h"
#include "skidimm/sdk/sized_motion_model.h"

namespace skidimm {
namespace sdk {

// One scalar parameter of a function model.
struct ParameterSpec {
  const char* key;          // its key under params: (or shared:), and its name
  const char* description;  // one line, with units
  double lower_bound;
  double upper_bound;
  ParameterScope scope = ParameterScope::kMode;
};

namespace internal {

// Whether Spec has `static void jacobian(const double* x, const double* u,
// const double* p, double dt, double* jacobian)` (row-major, state x state).
template <typename Spec, typename = void>
struct HasHandWrittenJacobian : std::false_type {};
template <typename Spec>
struct HasHandWrittenJacobian<Spec, std::void_t<decltype(Spec::jacobian(
                                        static_cast<const double*>(nullptr), static_cast<const double*>(nullptr),
                                        static_cast<const double*>(nullptr), 0.0, static_cast<double*>(nullptr)))>>
    : std::true_type {};

}  // namespace internal

template <typename Spec>
class FunctionModel final
    : public SizedMotionModel<static_cast<int>(std::size(Spec::kStates)), static_cast<int>(std::size(Spec::kInputs))> {
 public:
  static constexpr int kStates = static_cast<int>(std::size(Spec::kStates));
  static constexpr int kInputs = static_cast<int>(std::size(Spec::kInputs));
  static constexpr int kNumParameters = static_cast<int>(std::size(Spec::kParameters));
  using Base = SizedMotionModel<kStates, kInputs>;
  using typename Base::Input;
  using typename Base::Jacobian;
  using typename Base::State;
  using Parameters = Eigen::Matrix<double, kNumParameters, 1>;

  static std::unique_ptr<FunctionModel> Create(const ParameterSet& params, std::string* error) {
    auto model = std::make_unique<FunctionModel>();
    for (const std::string& key : params.keys()) {
      bool known = false;
      for (const ParameterSpec& p : Spec::kParameters) known = known || key == p.key;
      if (!known) {
        std::string list;
        for (const ParameterSpec& p : Spec::kParameters) list += (list.empty() ? "" : ", ") + std::string(p.key);
        if (error != nullptr) *error = "unknown parameter '" + key + "' (this model takes: " + list + ")";
        return nullptr;
      }
    }
    Eigen::VectorXd values(kNumParameters);
    for (int i = 0; i < kNumParameters; ++i) {
      if (!params.get_scalar(Spec::kParameters[i].key, &values[i], error)) return nullptr;
    }
    if (!model->set_parameters(values, error)) return nullptr;
    return model;
  }

  FunctionModel() {
    for (const VariableDoc& v : Spec::kStates) states_.emplace_back(v.name);
    for (const VariableDoc& v : Spec::kInputs) inputs_.emplace_back(v.name);
    for (const ParameterSpec& p : Spec::kParameters) {
      info_.push_back(scalar_parameter_info(p.key, p.description, p.lower_bound, p.upper_bound, p.scope));
    }
  }

  const std::vector<std::string>& state_names() const noexcept override { return states_; }
  const std::vector<std::string>& input_names() const noexcept override { return inputs_; }
  bool is_angle(int i) const noexcept override { return i >= 0 && i < kStates && Spec::kStates[i].is_angle; }
  const std::vector<ParameterInfo>& parameter_info() const noexcept override { return info_; }
  void get_parameters(Eigen::Ref<Eigen::VectorXd> values) const noexcept override { values = p_; }
  bool set_parameters(const Eigen::Ref<const Eigen::VectorXd>& values, std::string* error) noexcept override {
    if (!check_parameter_values(info_, values, error)) return false;
    p_ = values;
    return true;
  }

  // Angle states (is_angle in kStates) are wrapped to [-pi, pi) after the
  // function, so the function itself need not wrap.
  bool predict_fixed(const State& x, const Input& u, double dt, State* x_next) const override {
    Spec::predict(x.data(), input_data(u), p_.data(), dt, x_next->data());
    for (int i = 0; i < kStates; ++i) {
      if (Spec::kStates[i].is_angle) (*x_next)[i] = wrap_angle((*x_next)[i]);
    }
    return true;
  }

  // d predict / d x: the spec's own `jacobian` if it has one, else exact by
  // one pass of jets seeded on the states.
  bool jacobian_fixed(const State& x, const Input& u, double dt, Jacobian* jacobian) const override {
    if constexpr (internal::HasHandWrittenJacobian<Spec>::value) {
      Eigen::Matrix<double, kStates, kStates, Eigen::RowMajor> row_major;
      Spec::jacobian(x.data(), input_data(u), p_.data(), dt, row_major.data());
      *jacobian = row_major;
      return jacobian->allFinite();
    }
    using Jet = ceres::Jet<double, kStates>;
    Jet x_jet[kStates], p_jet[kNumParameters > 0 ? kNumParameters : 1], out[kStates];
    for (int i = 0; i < kStates; ++i) x_jet[i] = Jet(x[i], i);
    for (int i = 0; i < kNumParameters; ++i) p_jet[i] = Jet(p_[i]);
    Spec::predict(x_jet, input_data(u), static_cast<const Jet*>(p_jet), dt, out);
    for (int r = 0; r < kStates; ++r) (*jacobian).row(r) = out[r].v.transpose();
    return jacobian->allFinite();
  }
  bool has_analytic_jacobian() const noexcept override { return true; }

  // d predict / d parameters, exact, for fitting.
  bool parameter_jacobian(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u,
                          double dt, Eigen::Ref<Eigen::MatrixXd> jacobian) const noexcept override {
    if constexpr (kNumParameters == 0) {
      return true;
    } else {
      try {
        using Jet = ceres::Jet<double, kNumParameters>;
        Jet x_jet[kStates], p_jet[kNumParameters], out[kStates];
        for (int i = 0; i < kStates; ++i) x_jet[i] = Jet(x[i]);
        for (int i = 0; i < kNumParameters; ++i) p_jet[i] = Jet(p_[i], i);
        const Input u_fixed = input_of(u);
        Spec::predict(static_cast<const Jet*>(x_jet), input_data(u_fixed), static_cast<const Jet*>(p_jet), dt, out);
        for (int r = 0; r < kStates; ++r) {
          for (int c = 0; c < kNumParameters; ++c) jacobian(r, c) = out[r].v[c];
        }
      } catch (const std::exception& e) {
        report_failure("predict threw: ", e.what());
        return false;
      } catch (...) {
        report_failure("predict threw an exception that is not a std::exception");
        return false;
      }
      return jacobian.allFinite();
    }
  }

  // What `skidimm plugins` shows; built once, with static storage in the plugin.
  static const PluginInfo& info() {
    static const Docs docs;
    return docs.info;
  }

 private:
  struct Docs {
    Docs() {
      for (const ParameterSpec& p : Spec::kParameters) {
        std::string text = std::string(p.description) + ", in [" + number(p.lower_bound) + ", " +
                           number(p.upper_bound) + "], " +
                           (p.scope == ParameterScope::kBank ? "bank-level (shared:)" : "per mode");
        descriptions.push_back(std::move(text));
      }
      for (int i = 0; i < kNumParameters; ++i) {
        parameters.push_back({Spec::kParameters[i].key, "scalar", descriptions[static_cast<std::size_t>(i)].c_str()});
      }
      info = {Spec::kName,
              Spec::kVersion,
              Spec::kDescription,
              parameters.data(),
              kNumParameters,
              Spec::kStates,
              kStates,
              kInputs > 0 ? Spec::kInputs : nullptr,
              kInputs};
    }
    static std::string number(double v) {
      if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
      std::string text = std::to_string(v);
      while (text.size() > 1 && text.back() == '0') text.pop_back();
      if (!text.empty() && text.back() == '.') text.pop_back();
      return text;
    }
    std::vector<std::string> descriptions;
    std::vector<ParameterDoc> parameters;
    PluginInfo info{};
  };

  static Input input_of(const Eigen::Ref<const Eigen::VectorXd>& u) {
    Input fixed;
    for (int i = 0; i < kInputs; ++i) fixed[i] = u[i];
    return fixed;
  }
  static const double* input_data(const Input& u) {
    if constexpr (kInputs == 0) {
      return nullptr;
    } else {
      return u.data();
    }
  }

  Parameters p_ = Parameters::Zero();
  std::vector<std::string> states_, inputs_;
  std::vector<ParameterInfo> info_;
};

}  // namespace sdk
}  // namespace skidimm

// Exports FunctionModel<Spec> as the plugin Spec::kName. Once per plugin, at
// global scope.
#define SKIDIMM_EXPORT_FUNCTION_MODEL(Spec)                                              \
  namespace skidimm_function_model_exports {                                             \
  const ::skidimm::sdk::PluginInfo& kInfo = ::skidimm::sdk::FunctionModel<Spec>::info(); \
  }                                                                                      \
  SKIDIMM_EXPORT_MOTION_MODEL(::skidimm::sdk::FunctionModel<Spec>, skidimm_function_model_exports::kInfo)

#endif  // SKIDIMM_SDK_FUNCTION_MODEL_H_
