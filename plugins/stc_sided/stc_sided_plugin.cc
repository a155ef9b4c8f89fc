// `stc_sided`: pose model [X, Y, theta] with per-side tread efficiencies and
// tread ICRs (outer and inner) per mode (Mandow et al. 2007); equations in
// stc_sided_predict.h.
#include "skidimm/sdk/export.h"
#include "stc_sided/stc_sided_model.h"

namespace {

constexpr skidimm::sdk::ParameterDoc kParameters[] = {
    {"eta_l", "scalar", "left tread efficiency in [0, 2] (-), per mode"},
    {"eta_r", "scalar", "right tread efficiency in [0, 2] (-), per mode"},
    {"alpha_l_outer", "scalar", "left tread ICR at +alpha b/2 when it is the outer tread, in [0.1, 100] (-), per mode"},
    {"alpha_l_inner", "scalar", "left tread ICR at +alpha b/2 when it is the inner tread, in [0.1, 100] (-), per mode"},
    {"alpha_r_outer", "scalar",
     "right tread ICR at -alpha b/2 when it is the outer tread, in [0.1, 100] (-), per mode"},
    {"alpha_r_inner", "scalar",
     "right tread ICR at -alpha b/2 when it is the inner tread, in [0.1, 100] (-), per mode"},
    {"x_icr", "scalar", "longitudinal position of the vehicle ICR in [-2, 2] (m), per mode"},
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
    {"omega", "yaw rate of the tread ICR kinematics (rad/s), for a gyro", false},
};

constexpr skidimm::sdk::PluginInfo kInfo = {
    "stc_sided",
    "1.0.0",
    "Kinematic pose model [X, Y, theta] with per-side tread efficiencies and tread ICRs per mode (Mandow et al. 2007)",
    kParameters,
    9,
    kStates,
    3,
    kInputs,
    2,
    kOutputs,
    1};

}  // namespace

SKIDIMM_EXPORT_MOTION_MODEL(skidimm::plugins::StcSidedModel, kInfo)
