// `ltc_linear`: per-mode linear terrain model, paper eq. 2.
#include "ltc_common/ltc_model.h"
#include "skidimm/sdk/export.h"

namespace {

using skidimm::sdk::ParameterDoc;
using skidimm::sdk::PluginInfo;

constexpr ParameterDoc kParameters[] = {
    {"A", "2x2", "state matrix of d[V,omega]/dt = A [V,omega] + B [phi_dot_L,phi_dot_R] (1/s)"},
    {"B", "2x2", "input matrix: row V in m/rad/s, row omega in 1/s"},
};

constexpr skidimm::sdk::VariableDoc kStates[] = {
    {"V", "forward speed (m/s)", false},
    {"omega", "yaw rate (rad/s)", false},
};
constexpr skidimm::sdk::VariableDoc kInputs[] = {
    {"phi_dot_L", "left wheel speed (rad/s)", false},
    {"phi_dot_R", "right wheel speed (rad/s)", false},
};

constexpr PluginInfo kInfo = {"ltc_linear",
                              "1.0.0",
                              "Linear terrain model [V, omega] driven by wheel speeds, per-mode A_i, B_i (paper eq. 2)",
                              kParameters,
                              2,
                              kStates,
                              2,
                              kInputs,
                              2};

using Model = skidimm::plugins::LtcModel<skidimm::sdk::ParameterScope::kMode>;

}  // namespace

SKIDIMM_EXPORT_MOTION_MODEL(Model, kInfo)
