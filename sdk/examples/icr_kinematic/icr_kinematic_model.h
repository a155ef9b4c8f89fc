// IcrKinematicModel: the plugin class. A header so the test can use it
// in-process; icr_kinematic_plugin.cc exports it.
#ifndef ICR_KINEMATIC_MODEL_H_
#define ICR_KINEMATIC_MODEL_H_

#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "icr_kinematic_predict.h"
#include "skidimm/sdk/angles.h"
#include "skidimm/sdk/sized_motion_model.h"

namespace icr_kinematic {

enum ParameterIndex { kYLeft = 0, kYRight, kXVehicle, kEfficiency, kRadius, kNumParameters };

class IcrKinematicModel final : public skidimm::sdk::SizedMotionModel<3, 2> {
 public:
  static std::unique_ptr<IcrKinematicModel> Create(const skidimm::sdk::ParameterSet& params, std::string* error) {
    double values[kNumParameters] = {};
    const char* keys[kNumParameters] = {"y_icr_l", "y_icr_r", "x_icr_v", "efficiency", "r"};
    if (!params.check_only({"y_icr_l", "y_icr_r", "x_icr_v", "efficiency", "r"}, error)) return nullptr;
    for (int i = 0; i < kNumParameters; ++i) {
      if (!params.get_scalar(keys[i], &values[i], error)) return nullptr;
    }
    std::unique_ptr<IcrKinematicModel> model(new IcrKinematicModel());
    if (!model->set_parameters(Eigen::Map<const Eigen::Matrix<double, kNumParameters, 1>>(values), error)) {
      return nullptr;
    }
    return model;
  }

  const std::vector<std::string>& state_names() const noexcept override { return state_names_; }
  const std::vector<std::string>& input_names() const noexcept override { return input_names_; }
  bool is_angle(int state_index) const noexcept override { return state_index == kTheta; }
  const std::vector<skidimm::sdk::ParameterInfo>& parameter_info() const noexcept override { return info_; }

  void get_parameters(Eigen::Ref<Eigen::VectorXd> values) const noexcept override {
    values << p_.y_left, p_.y_right, p_.x_vehicle, p_.efficiency, p_.r;
  }

  bool set_parameters(const Eigen::Ref<const Eigen::VectorXd>& values, std::string* error) noexcept override {
    if (!skidimm::sdk::check_parameter_values(info_, values, error)) return false;
    p_ =
        IcrParameters<double>{values[kYLeft], values[kYRight], values[kXVehicle], values[kEfficiency], values[kRadius]};
    return true;
  }

  bool predict_fixed(const State& x, const Input& u, double dt, State* x_next) const override {
    icr_predict(x.data(), u.data(), p_, dt, x_next->data());
    (*x_next)[kTheta] = skidimm::sdk::wrap_angle((*x_next)[kTheta]);
    return x_next->allFinite();
  }

  bool jacobian_fixed(const State& x, const Input& u, double dt, Jacobian* jacobian) const override {
    double v_x, v_y, omega;
    icr_body_velocity(u.data(), p_, &v_x, &v_y, &omega);
    const double c = std::cos(x[kTheta]);
    const double s = std::sin(x[kTheta]);
    jacobian->setIdentity();
    (*jacobian)(kX, kTheta) = (-v_x * s - v_y * c) * dt;
    (*jacobian)(kY, kTheta) = (v_x * c - v_y * s) * dt;
    return jacobian->allFinite();
  }
  bool has_analytic_jacobian() const noexcept override { return true; }

 private:
  IcrKinematicModel() {
    using skidimm::sdk::ParameterScope;
    using skidimm::sdk::scalar_parameter_info;
    const double inf = std::numeric_limits<double>::infinity();
    info_ = {
        scalar_parameter_info("y_icr_l", "lateral position of the left tread's ICR (m)", 1e-3, 10.0),
        scalar_parameter_info("y_icr_r", "lateral position of the right tread's ICR (m)", -10.0, -1e-3),
        scalar_parameter_info("x_icr_v", "longitudinal position of the vehicle's ICR (m)", -10.0, 10.0),
        scalar_parameter_info("efficiency", "tread speed over r * wheel speed (-)", 0.0, 2.0),
        scalar_parameter_info("r", "wheel radius (m)", 1e-6, inf, ParameterScope::kBank),
    };
  }

  IcrParameters<double> p_{0.3, -0.3, 0.0, 1.0, 0.1};
  std::vector<skidimm::sdk::ParameterInfo> info_;
  const std::vector<std::string> state_names_{"X", "Y", "theta"};
  const std::vector<std::string> input_names_{"phi_dot_L", "phi_dot_R"};
};

}  // namespace icr_kinematic

#endif  // ICR_KINEMATIC_MODEL_H_
