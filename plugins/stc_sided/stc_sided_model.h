// StcSidedModel: the plugin class behind `stc_sided` (equations in
// stc_sided_predict.h), and StcTractionModel, behind `stc_traction`: the
// same kinematics with tread ICRs that move out as the turn tightens and the
// motor currents as outputs (stc_traction_equations.h).
// In a header so tests can run them in-process; the plugin .cc files only
// export them.
#ifndef SKIDIMM_PLUGINS_STC_SIDED_STC_SIDED_MODEL_H_
#define SKIDIMM_PLUGINS_STC_SIDED_STC_SIDED_MODEL_H_

#include <Eigen/Core>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "skidimm/sdk/angles.h"
#include "skidimm/sdk/autodiff_parameter_jacobian.h"
#include "skidimm/sdk/sized_motion_model.h"
#include "stc_sided/stc_sided_predict.h"
#include "stc_sided/stc_traction_equations.h"

namespace skidimm {
namespace plugins {

// kWithCurrents: false for stc_sided (output: omega), true for stc_traction
// (outputs: omega, i_L, i_R; six more parameters per mode).
template <bool kWithCurrents>
class StcSidedModelOf final : public sdk::SizedMotionModel<stc_sided::kNumStates, stc_sided::kNumInputs> {
 public:
  static constexpr int kNumParameters =
      kWithCurrents ? static_cast<int>(stc_sided::kNumTractionParameters) : static_cast<int>(stc_sided::kNumParameters);
  static constexpr int kNumOutputs = kWithCurrents ? static_cast<int>(stc_sided::kNumTractionOutputs) : 1;
  using Parameters = Eigen::Matrix<double, kNumParameters, 1>;

  static std::unique_ptr<StcSidedModelOf> Create(const sdk::ParameterSet& params, std::string* error) {
    std::unique_ptr<StcSidedModelOf> model(new StcSidedModelOf());
    std::vector<std::string> keys;
    for (const sdk::ParameterInfo& info : model->parameter_info_) keys.push_back(info.name);
    if (!params.check_only(keys, error)) return nullptr;
    Parameters values;
    for (int i = 0; i < kNumParameters; ++i) {
      if (!params.get_scalar(model->parameter_info_[static_cast<std::size_t>(i)].name, &values[i], error)) {
        return nullptr;
      }
    }
    if (!model->set_parameters(values, error)) return nullptr;
    return model;
  }

  const std::vector<std::string>& state_names() const noexcept override { return state_names_; }
  const std::vector<std::string>& input_names() const noexcept override { return input_names_; }
  bool is_angle(int state_index) const noexcept override { return state_index == stc_sided::kTheta; }

  const std::vector<sdk::ParameterInfo>& parameter_info() const noexcept override { return parameter_info_; }

  void get_parameters(Eigen::Ref<Eigen::VectorXd> values) const noexcept override { values = p_; }

  bool set_parameters(const Eigen::Ref<const Eigen::VectorXd>& values, std::string* error) noexcept override {
    if (!sdk::check_parameter_values(parameter_info_, values, error)) return false;
    p_ = values;
    return true;
  }

  bool predict_fixed(const State& x, const Input& u, double dt, State* x_next) const override {
    predict_pose(x.data(), u.data(), p_.data(), dt, x_next->data());
    (*x_next)[stc_sided::kTheta] = sdk::wrap_angle((*x_next)[stc_sided::kTheta]);
    return x_next->allFinite();
  }

  bool jacobian_fixed(const State& x, const Input& u, double dt, Jacobian* jacobian) const override {
    Eigen::Matrix<double, 3, 3, Eigen::RowMajor> row_major;
    if constexpr (kWithCurrents) {
      stc_sided::traction_state_jacobian(x.data(), u.data(), p_.data(), dt, row_major.data());
    } else {
      stc_sided::state_jacobian(x.data(), u.data(), p_.data(), dt, row_major.data());
    }
    *jacobian = row_major;
    return jacobian->allFinite();
  }
  bool has_analytic_jacobian() const noexcept override { return true; }

  // d x_next / d parameters (the order of parameter_info()), by Ceres jets
  // on the pose step; the current parameters do not move the pose.
  bool parameter_jacobian(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u,
                          double dt, Eigen::Ref<Eigen::MatrixXd> jacobian) const noexcept override {
    return sdk::autodiff_parameter_jacobian<stc_sided::kNumStates, stc_sided::kNumInputs, kNumParameters>(
        [](const auto* x_in, const auto* u_in, const auto* p, const auto& step, auto* out) {
          predict_pose(x_in, u_in, p, step, out);
        },
        x, u, p_.data(), dt, jacobian);
  }

  // Outputs: omega, the yaw rate body_velocity() predicts (for a gyro), and
  // for stc_traction the motor currents i_L, i_R (stc_traction_equations.h).
  const std::vector<std::string>& output_names() const noexcept override { return output_names_; }
  bool outputs(const Eigen::Ref<const Eigen::VectorXd>& u, Eigen::Ref<Eigen::VectorXd> y) const noexcept override {
    const double wheels[stc_sided::kNumInputs] = {u[stc_sided::kPhiDotLeft], u[stc_sided::kPhiDotRight]};
    double values[kNumOutputs];
    compute_outputs(wheels, p_.data(), values);
    for (int k = 0; k < kNumOutputs; ++k) y[k] = values[k];
    return y.allFinite();
  }
  bool output_parameter_jacobian(const Eigen::Ref<const Eigen::VectorXd>& u,
                                 Eigen::Ref<Eigen::MatrixXd> jacobian) const noexcept override {
    return sdk::autodiff_output_parameter_jacobian<stc_sided::kNumInputs, kNumOutputs, kNumParameters>(
        [](const auto* u_in, const auto* p, auto* out) { compute_outputs(u_in, p, out); }, u, p_.data(), jacobian);
  }

 private:
  template <typename T>
  static void predict_pose(const T* x, const T* u, const T* p, const T& dt, T* x_next) {
    if constexpr (kWithCurrents) {
      stc_sided::traction_predict(x, u, p, dt, x_next);
    } else {
      stc_sided::predict(x, u, p, dt, x_next);
    }
  }

  template <typename T>
  static void compute_outputs(const T* u, const T* p, T* y) {
    if constexpr (kWithCurrents) {
      stc_sided::traction_outputs(u, p, y);
    } else {
      T v_x, v_y;
      stc_sided::body_velocity(u, p, &v_x, &v_y, &y[0]);
    }
  }

  StcSidedModelOf() {
    const double inf = std::numeric_limits<double>::infinity();
    using sdk::ParameterScope;
    using sdk::scalar_parameter_info;
    // Indexed by stc_sided::Parameter.
    parameter_info_ = {
        scalar_parameter_info("eta_l", "left tread efficiency: ground speed / (r phi_dot_L) (-)", 0.0, 2.0),
        scalar_parameter_info("eta_r", "right tread efficiency: ground speed / (r phi_dot_R) (-)", 0.0, 2.0),
        scalar_parameter_info("alpha_l_outer", "left tread ICR at +alpha b / 2 turning right (-; 1 = on the wheels)",
                              0.1, 100.0),
        scalar_parameter_info("alpha_l_inner", "left tread ICR at +alpha b / 2 turning left (-; 1 = on the wheels)",
                              0.1, 100.0),
        scalar_parameter_info("alpha_r_outer", "right tread ICR at -alpha b / 2 turning left (-; 1 = on the wheels)",
                              0.1, 100.0),
        scalar_parameter_info("alpha_r_inner", "right tread ICR at -alpha b / 2 turning right (-; 1 = on the wheels)",
                              0.1, 100.0),
        scalar_parameter_info("x_icr", "longitudinal position of the vehicle's ICR (m)", -2.0, 2.0),
        // Geometry is the robot's, not the ground's: one value for the whole bank.
        scalar_parameter_info("r", "wheel radius (m)", 1e-6, inf, ParameterScope::kBank),
        scalar_parameter_info("b", "track width (m)", 1e-6, inf, ParameterScope::kBank),
    };
    p_.template head<stc_sided::kNumParameters>() << 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 0.0, 1.0, 1.0;
    if constexpr (kWithCurrents) {
      // Indexed by stc_sided::TractionParameter.
      parameter_info_.insert(
          parameter_info_.end(),
          {scalar_parameter_info("k_skid_l",
                                 "how fast the left tread ICR moves out as the turn tightens: by 1 + k_skid_l s^2 (-)",
                                 0.0, 1e4),
           scalar_parameter_info("k_skid_r",
                                 "how fast the right tread ICR moves out as the turn tightens: by 1 + k_skid_r s^2 (-)",
                                 0.0, 1e4),
           scalar_parameter_info("i_straight", "motor current of each side driving straight (A)", 0.0, 1000.0),
           scalar_parameter_info("i_l_outer", "left side's extra current at the turn's peak, outer side (A)", 0.0,
                                 1000.0),
           scalar_parameter_info("i_l_inner", "left side's extra current at the turn's peak, inner side (A)", 0.0,
                                 1000.0),
           scalar_parameter_info("i_r_outer", "right side's extra current at the turn's peak, outer side (A)", 0.0,
                                 1000.0),
           scalar_parameter_info("i_r_inner", "right side's extra current at the turn's peak, inner side (A)", 0.0,
                                 1000.0),
           scalar_parameter_info("s_peak", "wheel-speed turn ratio where the turn current peaks (-)", 0.001, 1.0)});
      p_.template tail<8>() << 0.0, 0.0, 1.0, 1.0, 1.0, 1.0, 1.0, 0.1;
      output_names_ = {"omega", "i_L", "i_R"};
    }
  }

  Parameters p_;
  std::vector<sdk::ParameterInfo> parameter_info_;
  const std::vector<std::string> state_names_{"X", "Y", "theta"};
  const std::vector<std::string> input_names_{"phi_dot_L", "phi_dot_R"};
  std::vector<std::string> output_names_{"omega"};
};

using StcSidedModel = StcSidedModelOf<false>;
using StcTractionModel = StcSidedModelOf<true>;

}  // namespace plugins
}  // namespace skidimm

#endif  // SKIDIMM_PLUGINS_STC_SIDED_STC_SIDED_MODEL_H_
