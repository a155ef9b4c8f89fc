// What `skidimm plugins` says of stc_sided and stc_traction, in one place:
// stc_traction's parameters and outputs extend stc_sided's, so each plugin
// shows a leading part of the same lists (stc_sided_plugin.cc,
// stc_traction/stc_traction_plugin.cc).
#ifndef SKIDIMM_PLUGINS_STC_SIDED_STC_SIDED_DOCS_H_
#define SKIDIMM_PLUGINS_STC_SIDED_STC_SIDED_DOCS_H_

#include "skidimm/sdk/plugin_info.h"
#include "stc_sided/stc_traction_equations.h"

namespace skidimm {
namespace plugins {
namespace stc_sided {

// In the flat parameter order (Parameter, then TractionParameter).
inline constexpr sdk::ParameterDoc kParameterDocs[] = {
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
    {"k_skid_l", "scalar",
     "left tread ICR moves out by 1 + k_skid_l s^2 with the wheel-speed turn ratio s, in [0, 1e4] (-), per mode"},
    {"k_skid_r", "scalar",
     "right tread ICR moves out by 1 + k_skid_r s^2 with the wheel-speed turn ratio s, in [0, 1e4] (-), per mode"},
    {"i_straight", "scalar", "motor current of each side driving straight in [0, 1000] (A), per mode"},
    {"i_l_outer", "scalar", "left side's extra current at the turn's peak as the outer side (A), per mode"},
    {"i_l_inner", "scalar", "left side's extra current at the turn's peak as the inner side (A), per mode"},
    {"i_r_outer", "scalar", "right side's extra current at the turn's peak as the outer side (A), per mode"},
    {"i_r_inner", "scalar", "right side's extra current at the turn's peak as the inner side (A), per mode"},
    {"s_peak", "scalar", "wheel-speed turn ratio where the turn current peaks, in [0.001, 1] (-), per mode"},
};
static_assert(sizeof(kParameterDocs) / sizeof(kParameterDocs[0]) == kNumTractionParameters,
              "one doc per stc_traction parameter");

inline constexpr sdk::VariableDoc kStateDocs[] = {
    {"X", "position in the world frame (m)", false},
    {"Y", "position in the world frame (m)", false},
    {"theta", "heading (rad)", true},
};
inline constexpr sdk::VariableDoc kInputDocs[] = {
    {"phi_dot_L", "left wheel speed (rad/s)", false},
    {"phi_dot_R", "right wheel speed (rad/s)", false},
};
// In Output order; stc_sided has the first.
inline constexpr sdk::VariableDoc kOutputDocs[] = {
    {"omega", "yaw rate of the tread ICR kinematics (rad/s), for a gyro", false},
    {"i_L", "left motor current, a magnitude (A)", false},
    {"i_R", "right motor current, a magnitude (A)", false},
};

}  // namespace stc_sided
}  // namespace plugins
}  // namespace skidimm

#endif  // SKIDIMM_PLUGINS_STC_SIDED_STC_SIDED_DOCS_H_
