// The function-model spec behind `stc_sided` (equations in
// stc_sided_predict.h). In a header so tests can run it in-process, and so
// stc_traction, which extends it, can share its states, inputs and
// parameter table; the plugin .cc only exports it.
#ifndef SKIDIMM_PLUGINS_STC_SIDED_STC_SIDED_MODEL_H_
#define SKIDIMM_PLUGINS_STC_SIDED_STC_SIDED_MODEL_H_

#include "skidimm/sdk/function_model.h"
#include "stc_common/stc_pose_spec.h"
#include "stc_sided/stc_sided_predict.h"

namespace skidimm {
namespace plugins {

struct StcSided {
  static constexpr const char* kName = "stc_sided";
  static constexpr const char* kVersion = "1.0.0";
  static constexpr const char* kDescription =
      "Kinematic pose model [X, Y, theta] with per-side tread efficiencies and tread ICRs per mode (Mandow et al. "
      "2007)";
  static constexpr const auto& kStates = StcPoseSpec::kStates;
  static constexpr const auto& kInputs = StcPoseSpec::kInputs;
  static constexpr sdk::VariableDoc kOutputs[] = {
      {"omega", "yaw rate of the tread ICR kinematics (rad/s), for a gyro", false},
  };
  // In stc_sided::Parameter order.
  static constexpr sdk::ParameterSpec kParameters[] = {
      {"eta_l", "left tread efficiency: ground speed / (r phi_dot_L) (-)", 0.0, 2.0},
      {"eta_r", "right tread efficiency: ground speed / (r phi_dot_R) (-)", 0.0, 2.0},
      {"alpha_l_outer",
       "left tread ICR at +alpha b / 2 when it is the outer tread, turning right (-; 1 = on the wheels)", 0.1, 100.0},
      {"alpha_l_inner",
       "left tread ICR at +alpha b / 2 when it is the inner tread, turning left (-; 1 = on the wheels)", 0.1, 100.0},
      {"alpha_r_outer",
       "right tread ICR at -alpha b / 2 when it is the outer tread, turning left (-; 1 = on the wheels)", 0.1, 100.0},
      {"alpha_r_inner",
       "right tread ICR at -alpha b / 2 when it is the inner tread, turning right (-; 1 = on the wheels)", 0.1, 100.0},
      {"x_icr", "longitudinal position of the vehicle's ICR (m)", -2.0, 2.0},
      StcPoseSpec::kWheelRadius,
      StcPoseSpec::kTrackWidth,
  };
  static_assert(sdk::flat_parameter_count(kParameters) == stc_sided::kNumParameters, "one row per parameter");
  static_assert(sdk::parameter_offset(kParameters, "b") == stc_sided::kTrack, "the table in Parameter order");

  template <typename T, typename P>
  static void predict(const T* x, const double* u, const P* p, double dt, T* x_next) {
    stc_sided::predict(x, u, p, dt, x_next);
  }

  // omega, the yaw rate body_velocity() predicts, for a gyro.
  template <typename P>
  static void outputs(const double* u, const P* p, P* y) {
    P v_x, v_y;
    stc_sided::body_velocity(u, p, &v_x, &v_y, &y[0]);
  }
};

using StcSidedModel = sdk::FunctionModel<StcSided>;

}  // namespace plugins
}  // namespace skidimm

#endif  // SKIDIMM_PLUGINS_STC_SIDED_STC_SIDED_MODEL_H_
