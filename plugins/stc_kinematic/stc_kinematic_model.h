// The function-model spec behind `stc_kinematic` (paper eq. 3; equations in
// stc_kinematic_predict.h). In a header so tests can run it in-process; the
// plugin .cc only exports it.
#ifndef SKIDIMM_PLUGINS_STC_KINEMATIC_STC_KINEMATIC_MODEL_H_
#define SKIDIMM_PLUGINS_STC_KINEMATIC_STC_KINEMATIC_MODEL_H_

#include "skidimm/sdk/function_model.h"
#include "stc_common/stc_pose_spec.h"
#include "stc_kinematic/stc_kinematic_predict.h"

namespace skidimm {
namespace plugins {

struct StcKinematic {
  static constexpr const char* kName = "stc_kinematic";
  static constexpr const char* kVersion = "1.0.0";
  static constexpr const char* kDescription =
      "Kinematic pose model [X, Y, theta] with per-mode slip constants k_i, m_i (paper eq. 3)";
  static constexpr const auto& kStates = StcPoseSpec::kStates;
  static constexpr const auto& kInputs = StcPoseSpec::kInputs;
  static constexpr sdk::VariableDoc kOutputs[] = {
      {"omega", "yaw rate m r (phi_dot_R - phi_dot_L) / b (rad/s), for a gyro", false},
  };
  static constexpr sdk::ParameterSpec kParameters[] = {
      {"k", "longitudinal efficiency: actual / requested forward speed (-)", 0.0, 2.0},
      {"m", "yaw efficiency: actual / requested yaw rate (-)", 0.0, 2.0},
      StcPoseSpec::kWheelRadius,
      StcPoseSpec::kTrackWidth,
  };
  enum { kK, kM, kR, kB };

  template <typename T, typename P>
  static void predict(const T* x, const double* u, const P* p, double dt, T* x_next) {
    stc_predict(x, u, p[kK], p[kM], p[kR], p[kB], dt, x_next);
  }

  // The yaw rate the model predicts from the wheel speeds, m r (phi_dot_R -
  // phi_dot_L) / b, for a gyro (`measurement.outputs: [omega]`).
  template <typename P>
  static void outputs(const double* u, const P* p, P* y) {
    P forward, yaw_rate;
    stc_requested_velocities(u, p[kR], p[kB], &forward, &yaw_rate);
    y[0] = p[kM] * yaw_rate;
  }
};

using StcKinematicModel = sdk::FunctionModel<StcKinematic>;

}  // namespace plugins
}  // namespace skidimm

#endif  // SKIDIMM_PLUGINS_STC_KINEMATIC_STC_KINEMATIC_MODEL_H_
