// StcKinematicModel: the plugin class behind `stc_kinematic` (paper eq. 3).
// In a header so tests can run it in-process; the plugin .cc only exports it.
#ifndef SKIDIMM_PLUGINS_STC_KINEMATIC_STC_KINEMATIC_MODEL_H_
#define SKIDIMM_PLUGINS_STC_KINEMATIC_STC_KINEMATIC_MODEL_H_

#include <Eigen/Core>
#include <limits>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

#include "skidimm/sdk/angles.h"
#include "skidimm/sdk/autodiff_parameter_jacobian.h"
#include "skidimm/sdk/sized_motion_model.h"
#include "stc_kinematic/stc_kinematic_predict.h"

namespace skidimm {
namespace plugins {

enum StcParameterIndex { kK = 0, kM = 1, kR = 2, kB = 3, kNumStcParameters = 4 };

class StcKinematicModel final : public sdk::SizedMotionModel<3, 2> {
 public:
  static std::unique_ptr<StcKinematicModel> Create(const sdk::ParameterSet& params, std::string* error) {
    StcParameters p{};
    if (!params.check_only({"k", "m", "r", "b"}, error) || !params.get_scalar("k", &p.k, error) ||
        !params.get_scalar("m", &p.m, error) || !params.get_scalar("r", &p.r, error) ||
        !params.get_scalar("b", &p.b, error)) {
      return nullptr;
    }
    std::unique_ptr<StcKinematicModel> model(new StcKinematicModel());
    Eigen::Matrix<double, kNumStcParameters, 1> values(p.k, p.m, p.r, p.b);
    if (!model->set_parameters(values, error)) return nullptr;
    return model;
  }

  const std::vector<std::string>& state_names() const noexcept override { return state_names_; }
  const std::vector<std::string>& input_names() const noexcept override { return input_names_; }
  bool is_angle(int state_index) const noexcept override { return state_index == kTheta; }

  const std::vector<sdk::ParameterInfo>& parameter_info() const noexcept override { return parameter_info_; }

  void get_parameters(Eigen::Ref<Eigen::VectorXd> values) const noexcept override {
    values[kK] = p_.k;
    values[kM] = p_.m;
    values[kR] = p_.r;
    values[kB] = p_.b;
  }

  bool set_parameters(const Eigen::Ref<const Eigen::VectorXd>& values, std::string* error) noexcept override {
    if (!sdk::check_parameter_values(parameter_info_, values, error)) return false;
    p_ = StcParameters{values[kK], values[kM], values[kR], values[kB]};
    return true;
  }

  // The EKF asks for the Jacobian and then the prediction at the same state:
  // sin and cos of its heading are computed once for both (HeadingTrig).
  bool predict_fixed(const State& x, const Input& u, double dt, State* x_next) const override {
    const HeadingTrig& trig = heading_trig(x[kTheta]);
    stc_predict_trig(x.data(), u.data(), trig.sin, trig.cos, p_.k, p_.m, p_.r, p_.b, dt, x_next->data());
    (*x_next)[kTheta] = sdk::wrap_angle((*x_next)[kTheta]);
    return x_next->allFinite();
  }

  bool jacobian_fixed(const State& x, const Input& u, double dt, Jacobian* jacobian) const override {
    Eigen::Matrix<double, 3, 3, Eigen::RowMajor> row_major;
    const HeadingTrig& trig = heading_trig(x[kTheta]);
    stc_jacobian_trig(u.data(), trig.sin, trig.cos, p_, dt, row_major.data());
    *jacobian = row_major;
    return jacobian->allFinite();
  }
  bool has_analytic_jacobian() const noexcept override { return true; }

  // d x_next / d [k, m, r, b], by Ceres jets on stc_predict.
  bool parameter_jacobian(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u,
                          double dt, Eigen::Ref<Eigen::MatrixXd> jacobian) const noexcept override {
    const double parameters[kNumStcParameters] = {p_.k, p_.m, p_.r, p_.b};
    return sdk::autodiff_parameter_jacobian<3, 2, kNumStcParameters>(
        [](const auto* x_in, const auto* u_in, const auto* p, const auto& step, auto* out) {
          stc_predict(x_in, u_in, p[kK], p[kM], p[kR], p[kB], step, out);
        },
        x, u, parameters, dt, jacobian);
  }

  // Output: the yaw rate the model predicts from the wheel speeds, m r
  // (phi_dot_R - phi_dot_L) / b, for a gyro (`measurement.outputs: [omega]`).
  const std::vector<std::string>& output_names() const noexcept override { return output_names_; }
  bool outputs(const Eigen::Ref<const Eigen::VectorXd>& u, Eigen::Ref<Eigen::VectorXd> y) const noexcept override {
    const double wheels[2] = {u[kStcPhiDotLeft], u[kStcPhiDotRight]};
    double forward = 0.0, yaw_rate = 0.0;
    stc_requested_velocities(wheels, p_.r, p_.b, &forward, &yaw_rate);
    y[0] = p_.m * yaw_rate;
    return std::isfinite(y[0]);
  }
  bool output_parameter_jacobian(const Eigen::Ref<const Eigen::VectorXd>& u,
                                 Eigen::Ref<Eigen::MatrixXd> jacobian) const noexcept override {
    const double parameters[kNumStcParameters] = {p_.k, p_.m, p_.r, p_.b};
    return sdk::autodiff_output_parameter_jacobian<2, 1, kNumStcParameters>(
        [](const auto* u_in, const auto* p, auto* out) {
          using T = std::remove_reference_t<decltype(*out)>;
          T forward, yaw_rate;
          stc_requested_velocities(u_in, p[kR], p[kB], &forward, &yaw_rate);
          out[0] = p[kM] * yaw_rate;
        },
        u, parameters, jacobian);
  }

 private:
  StcKinematicModel() {
    const double inf = std::numeric_limits<double>::infinity();
    using sdk::ParameterScope;
    using sdk::scalar_parameter_info;
    parameter_info_ = {
        scalar_parameter_info("k", "longitudinal efficiency: actual / requested forward speed (-)", 0.0, 2.0),
        scalar_parameter_info("m", "yaw efficiency: actual / requested yaw rate (-)", 0.0, 2.0),
        // Geometry is the robot's, not the terrain's: one value for the whole bank.
        scalar_parameter_info("r", "wheel radius (m)", 1e-6, inf, ParameterScope::kBank),
        scalar_parameter_info("b", "track width (m)", 1e-6, inf, ParameterScope::kBank),
    };
  }

  // sin and cos of the last heading this thread asked for: the same state's
  // Jacobian and prediction follow each other. A pure function of theta, so
  // the cache cannot change a result; per thread, so models stay shareable.
  struct HeadingTrig {
    double theta = 0.0;
    double sin = 0.0;
    double cos = 1.0;
  };
  static const HeadingTrig& heading_trig(double theta) noexcept {
    static thread_local HeadingTrig last;
    if (!(theta == last.theta)) {  // a NaN heading is recomputed (and stays NaN)
      last.sin = std::sin(theta);
      last.cos = std::cos(theta);
      last.theta = theta;
    }
    return last;
  }

  StcParameters p_{1.0, 1.0, 1.0, 1.0};
  std::vector<sdk::ParameterInfo> parameter_info_;
  const std::vector<std::string> state_names_{"X", "Y", "theta"};
  const std::vector<std::string> input_names_{"phi_dot_L", "phi_dot_R"};
  const std::vector<std::string> output_names_{"omega"};
};

}  // namespace plugins
}  // namespace skidimm

#endif  // SKIDIMM_PLUGINS_STC_KINEMATIC_STC_KINEMATIC_MODEL_H_
