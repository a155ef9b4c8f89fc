// Exports IcrKinematicModel as the skidimm plugin `icr_kinematic`.
#include "icr_kinematic_model.h"
#include "skidimm/sdk/export.h"

namespace {

constexpr skidimm::sdk::ParameterDoc kParameters[] = {
    {"y_icr_l", "scalar", "lateral position of the left tread's ICR (m, > 0), per mode"},
    {"y_icr_r", "scalar", "lateral position of the right tread's ICR (m, < 0), per mode"},
    {"x_icr_v", "scalar", "longitudinal position of the vehicle's ICR (m), per mode"},
    {"efficiency", "scalar", "tread speed over r * wheel speed (-), per mode"},
    {"r", "scalar", "wheel radius (m), bank-level (shared:)"},
};

constexpr skidimm::sdk::VariableDoc kStates[] = {
    {"X", "position in the world frame (m)", false},
    {"Y", "position in the world frame (m)", false},
    {"theta", "heading (rad)", true},
};
constexpr skidimm::sdk::VariableDoc kInputs[] = {
    {"phi_dot_L", "left wheel speed (rad/s)", false},
    {"phi_dot_R", "right wheel speed (rad/s)", false},
};

constexpr skidimm::sdk::PluginInfo kInfo = {"icr_kinematic",
                                            "0.1.0",
                                            "ICR-based skid-steer kinematics [X, Y, theta] (Mandow et al. 2007)",
                                            kParameters,
                                            5,
                                            kStates,
                                            3,
                                            kInputs,
                                            2};

}  // namespace

SKIDIMM_EXPORT_MOTION_MODEL(icr_kinematic::IcrKinematicModel, kInfo)
