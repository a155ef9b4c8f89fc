// What every skid-steer pose plugin (stc_kinematic, stc_sided, stc_traction)
// declares alike: the pose states, the wheel-speed inputs and the robot's
// geometry rows of the parameter table. Written once, so the plugins cannot
// drift apart in names, docs, bounds or scope: a bank that mixes them (a
// kinematic mode beside sided ones) shares one r and one b.
#ifndef SKIDIMM_PLUGINS_STC_COMMON_STC_POSE_SPEC_H_
#define SKIDIMM_PLUGINS_STC_COMMON_STC_POSE_SPEC_H_

#include "skidimm/sdk/function_model.h"

namespace skidimm {
namespace plugins {

struct StcPoseSpec {
  static constexpr sdk::VariableDoc kStates[] = {
      {"X", "position in the world frame (m)", false},
      {"Y", "position in the world frame (m)", false},
      {"theta", "heading (rad)", true},
  };
  static constexpr sdk::VariableDoc kInputs[] = {
      {"phi_dot_L", "left wheel speed (rad/s)", false},
      {"phi_dot_R", "right wheel speed (rad/s)", false},
  };
  // Geometry is the robot's, not the ground's: one value for the whole bank.
  static constexpr sdk::ParameterSpec kWheelRadius{"r", "wheel radius (m)", 1e-6, sdk::kInfinity,
                                                   sdk::ParameterScope::kBank};
  static constexpr sdk::ParameterSpec kTrackWidth{"b", "track width (m)", 1e-6, sdk::kInfinity,
                                                  sdk::ParameterScope::kBank};
};

}  // namespace plugins
}  // namespace skidimm

#endif  // SKIDIMM_PLUGINS_STC_COMMON_STC_POSE_SPEC_H_
