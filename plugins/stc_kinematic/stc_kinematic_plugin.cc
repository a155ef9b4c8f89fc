// `stc_kinematic`: pose model with per-mode slip constants k_i, m_i (paper eq. 3).
#include "skidimm/sdk/export.h"
#include "stc_kinematic/stc_kinematic_model.h"

namespace {

constexpr skidimm::sdk::ParameterDoc kParameters[] = {
    {"k", "scalar", "longitudinal efficiency in [0, 2] (-), per mode"},
    {"m", "scalar", "yaw efficiency in [0, 2] (-), per mode"},
    {"r", "scalar", "wheel radius (m), bank-level (shared:)"},
    {"b", "scalar", "track width (m), bank-level (shared:)"},
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
constexpr skidimm::sdk::VariableDoc kOutputs[] = {
    {"omega", "yaw rate m r (phi_dot_R - phi_dot_L) / b (rad/s), for a gyro", false},
};

constexpr skidimm::sdk::PluginInfo kInfo = {
    "stc_kinematic",
    "1.0.0",
    "Kinematic pose model [X, Y, theta] with per-mode slip constants k_i, m_i (paper eq. 3)",
    kParameters,
    4,
    kStates,
    3,
    kInputs,
    2,
    kOutputs,
    1};

}  // namespace

SKIDIMM_EXPORT_MOTION_MODEL(skidimm::plugins::StcKinematicModel, kInfo)
