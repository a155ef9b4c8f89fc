// `stc_traction`: stc_sided's pose model [X, Y, theta] (per-side tread
// efficiencies and tread ICRs, Mandow et al. 2007) with ICRs that move out as
// the turn tightens, which also predicts each side's motor current, the one
// measurement that sees how hard the ground resists: equations in
// stc_sided/stc_sided_predict.h and stc_sided/stc_traction_equations.h.
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
    {"k_skid", "scalar",
     "tread ICRs move out by 1 + k_skid s^2 with the wheel-speed turn ratio s, in [0, 1e4] (-), per mode"},
    {"i_straight", "scalar", "motor current of each side driving straight in [0, 1000] (A), per mode"},
    {"i_l_outer", "scalar", "left side's extra current at the turn's peak as the outer side (A), per mode"},
    {"i_l_inner", "scalar", "left side's extra current at the turn's peak as the inner side (A), per mode"},
    {"i_r_outer", "scalar", "right side's extra current at the turn's peak as the outer side (A), per mode"},
    {"i_r_inner", "scalar", "right side's extra current at the turn's peak as the inner side (A), per mode"},
    {"s_peak", "scalar", "wheel-speed turn ratio where the turn current peaks, in [0.001, 1] (-), per mode"},
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
    {"i_L", "left motor current, a magnitude (A)", false},
    {"i_R", "right motor current, a magnitude (A)", false},
};

constexpr skidimm::sdk::PluginInfo kInfo = {
    "stc_traction",
    "1.0.0",
    "stc_sided's pose model [X, Y, theta] with turn-dependent skid, predicting each side's motor current (omega, i_L, "
    "i_R outputs)",
    kParameters,
    16,
    kStates,
    3,
    kInputs,
    2,
    kOutputs,
    3};

}  // namespace

SKIDIMM_EXPORT_MOTION_MODEL(skidimm::plugins::StcTractionModel, kInfo)
