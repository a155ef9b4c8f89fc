// A motion model written as a parameter table and one templated function:
// the way to write a skidimm model.
//
// The author writes a plain struct (the "spec"):
//
//   struct SlipRatio {
//     static constexpr const char* kName = "slip_ratio";      // the bank's `model:`
//     static constexpr const char* kVersion = "0.1.0";
//     static constexpr const char* kDescription = "[V, omega, s] with a slip-ratio state";
//     static constexpr skidimm::sdk::VariableDoc kStates[] = {{"V", "forward speed (m/s)", false}, ...};
//     static constexpr skidimm::sdk::VariableDoc kInputs[] = {{"phi_dot_L", "left wheel speed (rad/s)", false}, ...};
//     static constexpr skidimm::sdk::ParameterSpec kParameters[] = {   // parameter_spec.h
//         {"tau", "time constant (s)", 1e-3, 10.0},                                    // per mode
//         {"r", "wheel radius (m)", 1e-3, 1.0, skidimm::sdk::ParameterScope::kBank},  // under shared:
//         {"A", "coupling (1/s)", skidimm::sdk::Shape{2, 2}},                         // a 2x2 matrix
//     };
//     // x: states, u: inputs, p: parameters (kParameters' order, matrices row-major); x_next: after dt.
//     template <typename T, typename P>
//     static void predict(const T* x, const double* u, const P* p, double dt, T* x_next) { ... }
//   };
//   SKIDIMM_EXPORT_FUNCTION_MODEL(SlipRatio)
//
// and the SDK generates the rest: the model class, Create() (every parameter
// read from the bank in its shape, unknown and missing keys, wrong shapes and
// values out of bounds refused with the key named, a missing bank-level one
// said to belong under `shared:`), get/set of the flat parameter vector, the
// PluginInfo `skidimm plugins` prints (states, inputs, outputs, each
// parameter with its shape, bounds and scope), the state Jacobian and the
// parameter Jacobian (for `skidimm fit`), both exact, by automatic
// differentiation with Ceres jets (header only: nothing to link).
//
// The two scalar types. In the filter's step T and P are double. For the
// state Jacobian T is a jet and P stays double, so arithmetic on parameters
// and inputs alone is done once, in plain doubles, and gives the same bits as
// in the step; for the parameter Jacobian both are the same jet. A P value
// becomes a T with T(value). A spec may instead write one type,
// `template <typename T> predict(const T* x, const double* u, const T* p, ...)`;
// its parameters are then turned into T for the state Jacobian.
//
// Optional parts of the spec, each detected by its presence:
//  * outputs, quantities the model predicts from its input alone besides
//    its state (a yaw rate for a gyro, a motor current; MotionModel::outputs()):
//
//      static constexpr skidimm::sdk::VariableDoc kOutputs[] = {{"omega", "yaw rate (rad/s)", false}};
//      template <typename P>
//      static void outputs(const double* u, const P* p, P* y);
//
//    and their parameter Jacobian, by jets, is generated too;
//  * hand-written derivatives, for a model whose automatic ones are too
//    slow (a matrix exponential, say), used instead of jets:
//
//      static void jacobian(const double* x, const double* u, const double* p, double dt,
//                           double* jacobian);            // row-major, state x state
//      static void parameter_jacobian(const double* x, const double* u, const double* p, double dt,
//                                     double* jacobian);  // row-major, state x flat parameters
//      static void output_parameter_jacobian(const double* u, const double* p,
//                                            double* jacobian);  // row-major, output x flat parameters
//
//    The conformance kit checks each against the automatic one
//    (testing/conformance.h, when given the FunctionModel in-process) and
//    against central differences (always);
//  * the process noise over a step, instead of intensity * dt:
//
//      static void process_noise(const double* intensity, const double* x, const double* u, const double* p,
//                                double dt, double* noise);  // n x n, row-major
//
//  * for a model linear in its state whose noise does not depend on where it
//    is, the promise that its state Jacobian and process noise depend on dt
//    and the parameters only (MotionModel::jacobian_and_noise_depend_only_on_dt;
//    the engine then reuses them while dt repeats):
//
//      static constexpr bool kJacobianAndNoiseDependOnlyOnDt = true;
//
// The filter asks for the state Jacobian and then the prediction at the same
// state; the jets that give the one give the other, so predict() right after
// jacobian() costs a comparison (LastEvaluation below). Angle states
// (VariableDoc::is_angle) are wrapped to [-pi, pi) after predict. Failures never cross the plugin boundary: an
// exception thrown by the spec becomes a rejected step with its text, and a value that is not finite (a state, a
// Jacobian entry, an output, a noise entry) a rejected step whose reason names the entry and the operating point, e.g.
// "jacobian() is not finite: entry (row 1 'omega', column 0 'V') = nan at x = [...], u = [...], dt = 0.02".
//
// Shapes from the bank. A model written in the bank file (linear_features:
// the bank's own states and inputs, a matrix A full or diagonal as the bank
// writes it) cannot list its states or shapes here. Its spec gives instead
// kMaxStates, kMaxInputs and kMaxParameters (bounds for the stack matrices,
// so nothing allocates per step), table rows shaped by the bank
// (BankShape, TextList: parameter_spec.h) and
//
//   static bool layout(const skidimm::sdk::ParameterSet& params, skidimm::sdk::Layout* layout, std::string* error);
//
// which says, from the mode's params, the shape of each row and which are
// held fixed (bank_layout.h). Its functions take the Layout first and see
// doubles only: predict(layout, x, u, p, dt, x_next), and optionally
// jacobian(layout, ...), parameter_jacobian(layout, ...) (state x every
// numeric entry of p, fixed ones included; their columns may be left
// alone, they are dropped; the buffer arrives zeroed, so only the entries
// that can be nonzero need writing), with it optionally
// parameter_jacobian_may_move(layout, entry, row) (whether entry `entry` of
// p can move state `row` at any point: a mode with parameter uncertainty then
// asks for those entries alone, MotionModel::parameter_jacobian_rows(), and
// only they arrive zeroed and are read: a spec never reads, += included, an
// entry it says cannot move) and
// process_noise(layout, intensity, ...). Jets
// need their sizes at compile time, so without a hand-written derivative
// the model says it has none and the engine and the fitter difference
// predict(). The rest is generated as above (bank_shaped_function_model.h);
// outputs are not offered.
//
// FunctionModel is a SizedMotionModel (sized_motion_model.h), or with shapes
// from the bank a MotionModel: the class form is the low-level ABI this
// generated code implements, not a second way to write a model.
#ifndef SKIDIMM_SDK_FUNCTION_MODEL_H_
#define SKIDIMM_SDK_FUNCTION_MODEL_H_

#include <ceres/jet.h>

#include <Eigen/Core>
#include <array>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <iterator>
#include <memory>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "skidimm/sdk/angles.h"
#include "skidimm/sdk/bank_layout.h"
#include "skidimm/sdk/export.h"
#include "skidimm/sdk/failure.h"
#include "skidimm/sdk/parameter_spec.h"
#include "skidimm/sdk/parameters.h"
#include "skidimm/sdk/plugin_info.h"
#include "skidimm/sdk/sized_motion_model.h"

namespace skidimm {
namespace sdk {
namespace internal {

// --- What a spec has ---

template <typename Spec, typename = void>
struct HasParameterTable : std::false_type {};
template <typename Spec>
struct HasParameterTable<Spec, std::void_t<decltype(Spec::kParameters)>> : std::true_type {};

template <typename Spec, typename = void>
struct HasOutputTable : std::false_type {};
template <typename Spec>
struct HasOutputTable<Spec, std::void_t<decltype(Spec::kOutputs)>> : std::true_type {};

// predict(const T* x, const double* u, const P* p, double dt, T* x_next) callable.
template <typename Spec, typename T, typename P, typename = void>
struct PredictTakes : std::false_type {};
template <typename Spec, typename T, typename P>
struct PredictTakes<Spec, T, P,
                    std::void_t<decltype(Spec::predict(std::declval<const T*>(), std::declval<const double*>(),
                                                       std::declval<const P*>(), 0.0, std::declval<T*>()))>>
    : std::true_type {};

template <typename Spec, typename = void>
struct HasHandWrittenJacobian : std::false_type {};
template <typename Spec>
struct HasHandWrittenJacobian<
    Spec, std::void_t<decltype(Spec::jacobian(std::declval<const double*>(), std::declval<const double*>(),
                                              std::declval<const double*>(), 0.0, std::declval<double*>()))>>
    : std::true_type {};

template <typename Spec, typename = void>
struct HasHandWrittenParameterJacobian : std::false_type {};
template <typename Spec>
struct HasHandWrittenParameterJacobian<
    Spec, std::void_t<decltype(Spec::parameter_jacobian(std::declval<const double*>(), std::declval<const double*>(),
                                                        std::declval<const double*>(), 0.0, std::declval<double*>()))>>
    : std::true_type {};

template <typename Spec, typename = void>
struct HasHandWrittenOutputParameterJacobian : std::false_type {};
template <typename Spec>
struct HasHandWrittenOutputParameterJacobian<
    Spec, std::void_t<decltype(Spec::output_parameter_jacobian(
              std::declval<const double*>(), std::declval<const double*>(), std::declval<double*>()))>>
    : std::true_type {};

template <typename Spec, typename = void>
struct HasProcessNoise : std::false_type {};
template <typename Spec>
struct HasProcessNoise<Spec,
                       std::void_t<decltype(Spec::process_noise(
                           std::declval<const double*>(), std::declval<const double*>(), std::declval<const double*>(),
                           std::declval<const double*>(), 0.0, std::declval<double*>()))>> : std::true_type {};

// A spec's kJacobianAndNoiseDependOnlyOnDt, false when it has none.
template <typename Spec, typename = void>
struct JacobianAndNoiseDependOnlyOnDt : std::false_type {};
template <typename Spec>
struct JacobianAndNoiseDependOnlyOnDt<Spec, std::void_t<decltype(Spec::kJacobianAndNoiseDependOnlyOnDt)>>
    : std::bool_constant<Spec::kJacobianAndNoiseDependOnlyOnDt> {};

// Whether all `count` values are finite, without a branch per value: x * 0
// is 0 for a finite x and NaN otherwise, and one NaN makes the sum NaN.
// (A plain loop: Eigen's vectorized sum into a stack array of a runtime
// length makes GCC 12 warn of reads past its end.)
inline bool all_finite(const double* values, int count) {
  // Four sums, so that each addition need not wait for the last (a
  // parameter Jacobian of 9 x 45 is checked at every step of a filter with
  // parameter uncertainty).
  double sum[4] = {0.0, 0.0, 0.0, 0.0};
  int i = 0;
  for (; i + 4 <= count; i += 4) {
    for (int k = 0; k < 4; ++k) sum[k] += values[i + k] * 0.0;
  }
  for (; i < count; ++i) sum[0] += values[i] * 0.0;
  const double total = (sum[0] + sum[1]) + (sum[2] + sum[3]);
  return total == total;
}
template <int kCount>
bool all_finite(const double* values) {
  return all_finite(values, kCount);
}

// A row-major rows x cols matrix, as the spec's hand-written parts fill it
// (a single column is stored the same either way; Eigen wants it ColMajor).
template <int kRows, int kCols>
using RowMajorMatrix = Eigen::Matrix<double, kRows, kCols, (kCols == 1 ? Eigen::ColMajor : Eigen::RowMajor)>;

inline constexpr std::array<ParameterSpec, 0> kNoParameters{};
inline constexpr std::array<VariableDoc, 0> kNoOutputs{};

template <typename Spec>
constexpr const auto& parameter_table() {
  if constexpr (HasParameterTable<Spec>::value) {
    return Spec::kParameters;
  } else {
    return kNoParameters;
  }
}

template <typename Spec>
constexpr const auto& output_table() {
  if constexpr (HasOutputTable<Spec>::value) {
    return Spec::kOutputs;
  } else {
    return kNoOutputs;
  }
}

// "A[r,c]" for a matrix entry, "w[i]" for a vector entry, "k" for a number.
inline std::string flat_name(const ParameterSpec& p, int r, int c) {
  if (p.is_scalar()) return p.key;
  if (p.is_vector()) return std::string(p.key) + "[" + std::to_string(r) + "]";
  return std::string(p.key) + "[" + std::to_string(r) + "," + std::to_string(c) + "]";
}

// "scalar", "3-vector", "2x2"; for a row shaped by the bank, its own text.
inline std::string shape_text(const ParameterSpec& p) {
  if (p.kind != ParameterKind::kNumbers) return p.shape_text;
  if (p.is_scalar()) return "scalar";
  if (p.is_vector()) return std::to_string(p.shape.rows) + "-vector";
  return std::to_string(p.shape.rows) + "x" + std::to_string(p.shape.cols);
}

inline std::string bound_text(double v) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g", v);
  return text;
}

// What `skidimm plugins` says of a parameter: its description, bounds (if
// any) and scope.
inline std::string parameter_doc_text(const ParameterSpec& p) {
  std::string text = p.description;
  if (!std::isinf(p.lower_bound) || !std::isinf(p.upper_bound)) {
    text += std::string(p.is_scalar() ? ", in [" : ", each in [") + bound_text(p.lower_bound) + ", " +
            bound_text(p.upper_bound) + "]";
  }
  return text + (p.scope == ParameterScope::kBank ? std::string(", ") + kBankLevelDoc : ", per mode");
}

// True if every row of the table has its shape at compile time.
template <typename Table>
constexpr bool all_compile_time_shapes(const Table& table) {
  for (const ParameterSpec& p : table) {
    if (p.kind != ParameterKind::kNumbers) return false;
  }
  return true;
}

// The PluginInfo `skidimm plugins` shows for a spec: its table, and its
// states, inputs and outputs unless the bank gives them (layout()). Text
// with static storage in the plugin, built once.
template <typename Spec>
struct PluginDocs {
  PluginDocs() {
    for (const ParameterSpec& p : parameter_table<Spec>()) {
      shapes.push_back(shape_text(p));
      descriptions.push_back(parameter_doc_text(p));
    }
    for (std::size_t i = 0; i < shapes.size(); ++i) {
      parameters.push_back({parameter_table<Spec>()[i].key, shapes[i].c_str(), descriptions[i].c_str()});
    }
    info.name = Spec::kName;
    info.version = Spec::kVersion;
    info.description = Spec::kDescription;
    info.parameters = parameters.empty() ? nullptr : parameters.data();
    info.num_parameters = static_cast<int>(parameters.size());
    if constexpr (!HasLayout<Spec>::value) {
      constexpr int kInputs = static_cast<int>(std::size(Spec::kInputs));
      constexpr int kOutputs = static_cast<int>(std::size(output_table<Spec>()));
      info.states = Spec::kStates;
      info.num_states = static_cast<int>(std::size(Spec::kStates));
      info.inputs = kInputs > 0 ? Spec::kInputs : nullptr;
      info.num_inputs = kInputs;
      info.outputs = kOutputs > 0 ? std::data(output_table<Spec>()) : nullptr;
      info.num_outputs = kOutputs;
    }
  }
  std::vector<std::string> shapes, descriptions;
  std::vector<ParameterDoc> parameters;
  PluginInfo info{};
};

// --- How a generated model refuses a step ---

// Reports `why` with the operating point: x (n states) and u (m inputs) and
// dt, or only u when x is null (outputs); false.
inline bool report_at(FailureText& why, const double* x, int n, const double* u, int m, double dt) noexcept {
  if (x != nullptr) {
    why << " at x = ";
    why.list(x, n);
    why << ", u = ";
  } else {
    why << " at u = ";
  }
  why.list(u, m);
  if (x != nullptr) why << ", dt = " << dt;
  why.report();
  return false;
}

}  // namespace internal

template <typename Spec>
class FunctionModel<Spec, internal::CompileTimeShapes> final
    : public SizedMotionModel<static_cast<int>(std::size(Spec::kStates)), static_cast<int>(std::size(Spec::kInputs))> {
 public:
  static constexpr int kStates = static_cast<int>(std::size(Spec::kStates));
  static constexpr int kInputs = static_cast<int>(std::size(Spec::kInputs));
  static constexpr int kOutputs = static_cast<int>(std::size(internal::output_table<Spec>()));
  static constexpr int kNumParameters = flat_parameter_count(internal::parameter_table<Spec>());
  using Base = SizedMotionModel<kStates, kInputs>;
  using typename Base::Covariance;
  using typename Base::Input;
  using typename Base::Jacobian;
  using typename Base::State;
  using Parameters = std::array<double, (kNumParameters > 0 ? kNumParameters : 1)>;
  // Which derivatives the spec writes by hand (the conformance kit compares
  // each with the automatic one).
  static constexpr bool kHandWrittenJacobian = internal::HasHandWrittenJacobian<Spec>::value;
  static constexpr bool kHandWrittenParameterJacobian = internal::HasHandWrittenParameterJacobian<Spec>::value;
  static constexpr bool kHandWrittenOutputParameterJacobian =
      internal::HasHandWrittenOutputParameterJacobian<Spec>::value;
  // Row-major forms the spec's hand-written parts fill.
  using RowMajorJacobian = internal::RowMajorMatrix<kStates, kStates>;

  static_assert(internal::PredictTakes<Spec, double, double>::value,
                "the spec needs `template <typename T, typename P> static void predict(const T* x, const double* u, "
                "const P* p, double dt, T* x_next)` (or the same with one type T)");
  static_assert(!internal::HasOutputTable<Spec>::value || kOutputs > 0, "kOutputs, when given, cannot be empty");
  static_assert(internal::all_compile_time_shapes(internal::parameter_table<Spec>()),
                "BankShape and TextList rows need the shapes from the bank: give the spec a layout() "
                "(bank_layout.h)");

  static std::unique_ptr<FunctionModel> Create(const ParameterSet& params, std::string* error) {
    auto fail = [error](const std::string& message) {
      if (error != nullptr) *error = message;
      return std::unique_ptr<FunctionModel>();
    };
    for (const std::string& key : params.keys()) {
      bool known = false;
      for (const ParameterSpec& p : table()) known = known || key == p.key;
      if (!known) {
        std::string list;
        for (const ParameterSpec& p : table()) list += (list.empty() ? "" : ", ") + std::string(p.key);
        return fail("unknown parameter '" + key + "' (this model takes: " + (list.empty() ? "none" : list) + ")");
      }
    }
    auto model = std::make_unique<FunctionModel>();
    Eigen::VectorXd values(kNumParameters);
    Eigen::Index at = 0;
    for (const ParameterSpec& p : table()) {
      std::string why;
      Eigen::MatrixXd value(1, 1);
      const bool read = p.is_scalar() ? params.get_scalar(p.key, &value(0, 0), &why)
                                      : params.get_matrix(p.key, p.shape.rows, p.shape.cols, &value, &why);
      if (!read) {
        if (params.find_text(p.key) != nullptr) {
          why = "parameter '" + std::string(p.key) + "' must be " +
                (p.is_scalar() ? std::string("a number") : "a " + internal::shape_text(p) + " of numbers") +
                ", not text";
        } else if (!params.contains(p.key) && p.scope == ParameterScope::kBank) {
          why += ": model " + std::string(Spec::kName) + " takes it from the bank's 'shared:' block, " +
                 "one value for every mode";
        }
        return fail(why);
      }
      for (int r = 0; r < p.shape.rows; ++r) {
        for (int c = 0; c < p.shape.cols; ++c) values[at++] = value(r, c);
      }
    }
    if (!model->set_parameters(values, error)) return nullptr;
    return model;
  }

  FunctionModel() {
    for (const VariableDoc& v : Spec::kStates) states_.emplace_back(v.name);
    for (const VariableDoc& v : Spec::kInputs) inputs_.emplace_back(v.name);
    for (const VariableDoc& v : internal::output_table<Spec>()) outputs_.emplace_back(v.name);
    for (const ParameterSpec& p : table()) {
      for (int r = 0; r < p.shape.rows; ++r) {
        for (int c = 0; c < p.shape.cols; ++c) {
          ParameterInfo info;
          info.name = internal::flat_name(p, r, c);
          info.key = p.key;
          info.description = p.description;
          info.lower_bound = p.lower_bound;
          info.upper_bound = p.upper_bound;
          info.scope = p.scope;
          info_.push_back(std::move(info));
        }
      }
    }
    p_.fill(0.0);
    evaluation_id_ = next_evaluation_id();
  }

  // --- Names and parameters ---
  const std::vector<std::string>& state_names() const noexcept override { return states_; }
  const std::vector<std::string>& input_names() const noexcept override { return inputs_; }
  const std::vector<std::string>& output_names() const noexcept override { return outputs_; }
  bool is_angle(int i) const noexcept override { return i >= 0 && i < kStates && Spec::kStates[i].is_angle; }
  const std::vector<ParameterInfo>& parameter_info() const noexcept override { return info_; }
  void get_parameters(Eigen::Ref<Eigen::VectorXd> values) const noexcept override {
    for (int i = 0; i < kNumParameters; ++i) values[i] = p_[static_cast<std::size_t>(i)];
  }
  bool set_parameters(const Eigen::Ref<const Eigen::VectorXd>& values, std::string* error) noexcept override {
    if (!check_parameter_values(info_, values, error)) return false;
    for (int i = 0; i < kNumParameters; ++i) p_[static_cast<std::size_t>(i)] = values[i];
    evaluation_id_ = next_evaluation_id();
    return true;
  }
  // The flat parameters, in table order, as the spec's functions see them.
  const double* parameters() const noexcept { return p_.data(); }

  // --- Dynamics ---
  // After an automatic jacobian() at the same point, the prediction its jets
  // computed along (see LastEvaluation); else the spec's predict in doubles.
  // A spec that writes its own Jacobian leaves no jets to reuse, and skips
  // the look-up (a thread-local access, slow in a dlopened plugin).
  bool predict_fixed(const State& x, const Input& u, double dt, State* x_next) const override {
    if constexpr (!kHandWrittenJacobian) {
      const LastEvaluation& last = last_evaluation();
      if (last.matches(evaluation_id_, x, u, dt)) {
        *x_next = Eigen::Map<const State>(last.next);
        return finite_prediction(x, u, dt, x_next);
      }
    }
    Spec::predict(x.data(), input_data(u), p_.data(), dt, x_next->data());
    return finite_prediction(x, u, dt, x_next);
  }

  // d predict / d x: the spec's own `jacobian` if it has one, else exact by
  // one pass of jets seeded on the states.
  bool jacobian_fixed(const State& x, const Input& u, double dt, Jacobian* jacobian) const override {
    if constexpr (kHandWrittenJacobian) {
      RowMajorJacobian row_major;
      Spec::jacobian(x.data(), input_data(u), p_.data(), dt, row_major.data());
      *jacobian = row_major;
    } else {
      automatic_jacobian(x, u, dt, jacobian);
    }
    return finite_jacobian(*jacobian, x.data(), input_data(u), dt);
  }
  bool has_analytic_jacobian() const noexcept override { return true; }
  bool jacobian_and_noise_depend_only_on_dt() const noexcept override {
    return internal::JacobianAndNoiseDependOnlyOnDt<Spec>::value;
  }

  // The Jacobian by jets, whether or not the spec writes its own (the
  // conformance kit compares the two).
  void automatic_jacobian(const State& x, const Input& u, double dt, Jacobian* jacobian) const {
    using Jet = ceres::Jet<double, kStates>;
    Jet x_jet[kStates], out[kStates];
    for (int i = 0; i < kStates; ++i) {
      x_jet[i].a = x[i];
      x_jet[i].v = Eigen::Matrix<double, kStates, 1>::Unit(i);
    }
    predict_with_double_parameters(x_jet, input_data(u), out, dt);
    LastEvaluation& last = last_evaluation();
    for (int r = 0; r < kStates; ++r) {
      last.next[r] = out[r].a;
      for (int c = 0; c < kStates; ++c) (*jacobian)(r, c) = out[r].v[c];
    }
    last.remember(evaluation_id_, x, u, dt);
  }

  // Without the spec's own, intensity * dt (MotionModel's default), written
  // straight into the caller's matrix: no copies to fixed size and back.
  bool process_noise(const Eigen::Ref<const Eigen::MatrixXd>& intensity, const Eigen::Ref<const Eigen::VectorXd>& x,
                     const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
                     Eigen::Ref<Eigen::MatrixXd> noise) const noexcept override {
    if constexpr (internal::HasProcessNoise<Spec>::value) {
      return Base::process_noise(intensity, x, u, dt, noise);
    } else {
      for (int c = 0; c < kStates; ++c) {
        for (int r = 0; r < kStates; ++r) noise(r, c) = intensity(r, c) * dt;
      }
      return true;
    }
  }

  bool process_noise_fixed(const Covariance& intensity, const State& x, const Input& u, double dt,
                           Covariance* noise) const override {
    if constexpr (internal::HasProcessNoise<Spec>::value) {
      RowMajorJacobian intensity_row_major = intensity, noise_row_major;
      Spec::process_noise(intensity_row_major.data(), x.data(), input_data(u), p_.data(), dt, noise_row_major.data());
      *noise = noise_row_major;
      for (int r = 0; r < kStates; ++r) {
        for (int c = 0; c < kStates; ++c) {
          if (std::isfinite((*noise)(r, c))) continue;
          FailureText why;
          why << "process_noise() is not finite: entry (row " << r << " '" << Spec::kStates[r].name << "', column " << c
              << " '" << Spec::kStates[c].name << "') = " << (*noise)(r, c);
          return report_at(why, x.data(), input_data(u), dt);
        }
      }
      return true;
    } else {
      return Base::process_noise_fixed(intensity, x, u, dt, noise);
    }
  }

  // d predict / d parameters: the spec's own if it has one, else exact by jets.
  bool parameter_jacobian(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u,
                          double dt, Eigen::Ref<Eigen::MatrixXd> jacobian) const noexcept override {
    if constexpr (kNumParameters == 0) {
      return true;
    } else {
      const State x_fixed = x;
      const Input u_fixed = input_of(u);
      internal::RowMajorMatrix<kStates, kNumParameters> fixed;
      try {
        if constexpr (kHandWrittenParameterJacobian) {
          Spec::parameter_jacobian(x_fixed.data(), input_data(u_fixed), p_.data(), dt, fixed.data());
        } else {
          automatic_parameter_jacobian(x_fixed, u_fixed, dt, &fixed);
        }
      } catch (const std::exception& e) {
        return internal::caught("the parameter Jacobian threw: ", e.what());
      } catch (...) {
        return internal::caught("the parameter Jacobian threw an exception that is not a std::exception", nullptr);
      }
      for (int r = 0; r < kStates; ++r) {
        for (int c = 0; c < kNumParameters; ++c) {
          if (!std::isfinite(fixed(r, c))) {
            FailureText why;
            why << "parameter_jacobian() is not finite: entry (row " << r << " '" << Spec::kStates[r].name
                << "', column " << c << " '" << info_[static_cast<std::size_t>(c)].name.c_str()
                << "') = " << fixed(r, c);
            return report_at(why, x_fixed.data(), input_data(u_fixed), dt);
          }
          jacobian(r, c) = fixed(r, c);
        }
      }
      return true;
    }
  }

  template <typename Matrix>
  void automatic_parameter_jacobian(const State& x, const Input& u, double dt, Matrix* jacobian) const {
    if constexpr (kNumParameters > 0) {
      using Jet = ceres::Jet<double, kNumParameters>;
      Jet x_jet[kStates], p_jet[kNumParameters], out[kStates];
      for (int i = 0; i < kStates; ++i) x_jet[i] = Jet(x[i]);
      for (int i = 0; i < kNumParameters; ++i) p_jet[i] = Jet(p_[static_cast<std::size_t>(i)], i);
      Spec::predict(static_cast<const Jet*>(x_jet), input_data(u), static_cast<const Jet*>(p_jet), dt, out);
      for (int r = 0; r < kStates; ++r) {
        for (int c = 0; c < kNumParameters; ++c) (*jacobian)(r, c) = out[r].v[c];
      }
    }
  }

  // --- Outputs ---
  bool outputs(const Eigen::Ref<const Eigen::VectorXd>& u, Eigen::Ref<Eigen::VectorXd> y) const noexcept override {
    if constexpr (kOutputs == 0) {
      return false;
    } else {
      const Input u_fixed = input_of(u);
      double values[kOutputs];
      try {
        Spec::outputs(input_data(u_fixed), p_.data(), values);
      } catch (const std::exception& e) {
        return internal::caught("outputs() threw: ", e.what());
      } catch (...) {
        return internal::caught("outputs() threw an exception that is not a std::exception", nullptr);
      }
      for (int k = 0; k < kOutputs; ++k) {
        if (!std::isfinite(values[k])) {
          FailureText why;
          why << "outputs() gave a value that is not finite: " << output_table()[k].name << " = " << values[k] << " (y["
              << k << "])";
          return report_at(why, nullptr, input_data(u_fixed), 0.0);
        }
        y[k] = values[k];
      }
      return true;
    }
  }

  bool output_parameter_jacobian(const Eigen::Ref<const Eigen::VectorXd>& u,
                                 Eigen::Ref<Eigen::MatrixXd> jacobian) const noexcept override {
    if constexpr (kOutputs == 0) {
      return false;
    } else if constexpr (kNumParameters == 0) {
      return true;
    } else {
      const Input u_fixed = input_of(u);
      internal::RowMajorMatrix<kOutputs, kNumParameters> fixed;
      try {
        if constexpr (kHandWrittenOutputParameterJacobian) {
          Spec::output_parameter_jacobian(input_data(u_fixed), p_.data(), fixed.data());
        } else {
          automatic_output_parameter_jacobian(u_fixed, &fixed);
        }
      } catch (const std::exception& e) {
        return internal::caught("the output parameter Jacobian threw: ", e.what());
      } catch (...) {
        return internal::caught("the output parameter Jacobian threw an exception that is not a std::exception",
                                nullptr);
      }
      for (int r = 0; r < kOutputs; ++r) {
        for (int c = 0; c < kNumParameters; ++c) {
          if (!std::isfinite(fixed(r, c))) {
            FailureText why;
            why << "output_parameter_jacobian() is not finite: entry (row " << r << " '" << output_table()[r].name
                << "', column " << c << " '" << info_[static_cast<std::size_t>(c)].name.c_str()
                << "') = " << fixed(r, c);
            return report_at(why, nullptr, input_data(u_fixed), 0.0);
          }
          jacobian(r, c) = fixed(r, c);
        }
      }
      return true;
    }
  }

  template <typename Matrix>
  void automatic_output_parameter_jacobian(const Input& u, Matrix* jacobian) const {
    if constexpr (kOutputs > 0 && kNumParameters > 0) {
      using Jet = ceres::Jet<double, kNumParameters>;
      Jet p_jet[kNumParameters], out[kOutputs];
      for (int i = 0; i < kNumParameters; ++i) p_jet[i] = Jet(p_[static_cast<std::size_t>(i)], i);
      Spec::outputs(input_data(u), static_cast<const Jet*>(p_jet), out);
      for (int r = 0; r < kOutputs; ++r) {
        for (int c = 0; c < kNumParameters; ++c) (*jacobian)(r, c) = out[r].v[c];
      }
    }
  }

  // What `skidimm plugins` shows; built once, with static storage in the plugin.
  static const PluginInfo& info() {
    static const internal::PluginDocs<Spec> docs;
    return docs.info;
  }

  static constexpr const auto& table() { return internal::parameter_table<Spec>(); }
  static constexpr const auto& output_table() { return internal::output_table<Spec>(); }

 private:
  // Checks a prediction (naming the first entry that is not finite) and wraps its angles.
  static bool finite_prediction(const State& x, const Input& u, double dt, State* x_next) {
    if (!internal::all_finite<kStates>(x_next->data())) {
      for (int i = 0; i < kStates; ++i) {
        if (std::isfinite((*x_next)[i])) continue;
        FailureText why;
        why << "predict() gave a state that is not finite: " << Spec::kStates[i].name << " = " << (*x_next)[i]
            << " (x_next[" << i << "])";
        return report_at(why, x.data(), input_data(u), dt);
      }
    }
    for (int i = 0; i < kStates; ++i) {
      if (Spec::kStates[i].is_angle) (*x_next)[i] = wrap_angle((*x_next)[i]);
    }
    return true;
  }

  // The prediction the last automatic Jacobian computed along, on this
  // thread. The filter asks for the Jacobian and then the prediction at the
  // same state, input and step (ekf.h); the jets' values are that
  // prediction, so predict() takes them instead of evaluating the spec
  // again, as Ceres' AutoDiffCostFunction returns the residuals of its jet
  // evaluation. They are the same bits as the spec's predict in doubles,
  // except where it divides a value that depends on the state: a jet
  // divides by multiplying with the reciprocal, which can differ in the last
  // bit. Keyed by an id no other model or parameter vector ever had (a new
  // one per set_parameters()), so a stale entry can never match; per
  // thread, so models stay shareable between threads.
  struct LastEvaluation {
    // Plain arrays: a thread_local without a constructor is a plain TLS
    // access, with no guard to test on every call.
    std::uint64_t id;  // 0: none
    double x[kStates], next[kStates], u[kInputs > 0 ? kInputs : 1], dt;

    bool matches(std::uint64_t model_id, const State& x_now, const Input& u_now, double dt_now) const {
      return id == model_id && std::memcmp(&dt, &dt_now, sizeof(double)) == 0 &&
             std::memcmp(x, x_now.data(), sizeof(x)) == 0 &&
             (kInputs == 0 || std::memcmp(u, input_data(u_now), sizeof(double) * kInputs) == 0);
    }
    void remember(std::uint64_t model_id, const State& x_now, const Input& u_now, double dt_now) {
      id = model_id;
      std::memcpy(x, x_now.data(), sizeof(x));
      if (kInputs > 0) std::memcpy(u, input_data(u_now), sizeof(double) * kInputs);
      dt = dt_now;
    }
  };
  static LastEvaluation& last_evaluation() {
    static thread_local LastEvaluation last;
    return last;
  }
  static std::uint64_t next_evaluation_id() {
    static std::atomic<std::uint64_t> next{1};
    return next.fetch_add(1, std::memory_order_relaxed);
  }

  // The spec's predict with T (double or a jet) states and double
  // parameters; a one-type spec gets its parameters as T.
  template <typename T>
  void predict_with_double_parameters(const T* x, const double* u, T* out, double dt) const {
    if constexpr (internal::PredictTakes<Spec, T, double>::value) {
      Spec::predict(x, u, p_.data(), dt, out);
    } else {
      T p[kNumParameters > 0 ? kNumParameters : 1];
      for (int i = 0; i < kNumParameters; ++i) p[i] = T(p_[static_cast<std::size_t>(i)]);
      Spec::predict(x, u, static_cast<const T*>(p), dt, out);
    }
  }

  // True if every entry is finite; else reports the first that is not.
  // (One pass without branches; the search runs only on failure.)
  static bool finite_jacobian(const Jacobian& jacobian, const double* x, const double* u, double dt) {
    return internal::all_finite<kStates * kStates>(jacobian.data()) || report_not_finite_jacobian(jacobian, x, u, dt);
  }
  static bool report_not_finite_jacobian(const Jacobian& jacobian, const double* x, const double* u, double dt) {
    for (int r = 0; r < kStates; ++r) {
      for (int c = 0; c < kStates; ++c) {
        if (std::isfinite(jacobian(r, c))) continue;
        FailureText why;
        why << "jacobian() is not finite: entry (row " << r << " '" << Spec::kStates[r].name << "', column " << c
            << " '" << Spec::kStates[c].name << "') = " << jacobian(r, c);
        return report_at(why, x, u, dt);
      }
    }
    return false;
  }

  // Reports `why` with the operating point (x is null for outputs); false.
  static bool report_at(FailureText& why, const double* x, const double* u, double dt) noexcept {
    return internal::report_at(why, x, kStates, u, kInputs, dt);
  }

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

  Parameters p_;
  std::uint64_t evaluation_id_ = 0;  // this model with these parameters (LastEvaluation)
  std::vector<std::string> states_, inputs_, outputs_;
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

// The same form for a spec whose shapes come from the bank (its layout()).
#include "skidimm/sdk/bank_shaped_function_model.h"

#endif  // SKIDIMM_SDK_FUNCTION_MODEL_H_
