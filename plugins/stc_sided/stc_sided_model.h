// StcSidedModel: the plugin class behind `stc_sided` (equations in
// stc_sided_predict.h). In a header so tests can run it in-process; the
// plugin .cc only exports it.
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

namespace skidimm {
namespace plugins {

class StcSidedModel final : public sdk::SizedMotionModel<stc_sided::kNumStates, stc_sided::kNumInputs> {
 public:
  using Parameters = Eigen::Matrix<double, stc_sided::kNumParameters, 1>;

  static std::unique_ptr<StcSidedModel> Create(const sdk::ParameterSet& params, std::string* error) {
    std::unique_ptr<StcSidedModel> model(new StcSidedModel());
    if (!params.check_only(
            {"eta_l", "eta_r", "alpha_l_outer", "alpha_l_inner", "alpha_r_outer", "alpha_r_inner", "x_icr", "r", "b"},
            error)) {
      return nullptr;
    }
    Parameters values;
    for (int i = 0; i < stc_sided::kNumParameters; ++i) {
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
    stc_sided::predict(x.data(), u.data(), p_.data(), dt, x_next->data());
    (*x_next)[stc_sided::kTheta] = sdk::wrap_angle((*x_next)[stc_sided::kTheta]);
    return x_next->allFinite();
  }

  bool jacobian_fixed(const State& x, const Input& u, double dt, Jacobian* jacobian) const override {
    Eigen::Matrix<double, 3, 3, Eigen::RowMajor> row_major;
    stc_sided::state_jacobian(x.data(), u.data(), p_.data(), dt, row_major.data());
    *jacobian = row_major;
    return jacobian->allFinite();
  }
  bool has_analytic_jacobian() const noexcept override { return true; }

  // d x_next / d [eta_l, eta_r, alpha_l_outer, alpha_l_inner, alpha_r_outer,
  // alpha_r_inner, x_icr, r, b], by Ceres jets
  // on stc_sided::predict.
  bool parameter_jacobian(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u,
                          double dt, Eigen::Ref<Eigen::MatrixXd> jacobian) const noexcept override {
    return sdk::autodiff_parameter_jacobian<stc_sided::kNumStates, stc_sided::kNumInputs, stc_sided::kNumParameters>(
        [](const auto* x_in, const auto* u_in, const auto* p, const auto& step, auto* out) {
          stc_sided::predict(x_in, u_in, p, step, out);
        },
        x, u, p_.data(), dt, jacobian);
  }

 private:
  StcSidedModel() {
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
    p_ << 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 0.0, 1.0, 1.0;
  }

  Parameters p_;
  std::vector<sdk::ParameterInfo> parameter_info_;
  const std::vector<std::string> state_names_{"X", "Y", "theta"};
  const std::vector<std::string> input_names_{"phi_dot_L", "phi_dot_R"};
};

}  // namespace plugins
}  // namespace skidimm

#endif  // SKIDIMM_PLUGINS_STC_SIDED_STC_SIDED_MODEL_H_
