// `ltc_shared`: one A, B for the whole bank, modes differ by process noise only
// (paper, section III-A, last paragraph).
#include "ltc_common/ltc_model.h"
#include "skidimm/sdk/export.h"

namespace {

using skidimm::sdk::ParameterDoc;
using skidimm::sdk::PluginInfo;

constexpr ParameterDoc kParameters[] = {
    {"A", "2x2", "bank-level (shared:) state matrix of eq. 2 (1/s)"},
    {"B", "2x2", "bank-level (shared:) input matrix of eq. 2"},
};

constexpr skidimm::sdk::VariableDoc kStates[] = {
    {"V", "forward speed (m/s)", false},
    {"omega", "yaw rate (rad/s)", false},
};
constexpr skidimm::sdk::VariableDoc kInputs[] = {
    {"phi_dot_L", "left wheel speed (rad/s)", false},
    {"phi_dot_R", "right wheel speed (rad/s)", false},
};

constexpr PluginInfo kInfo = {"ltc_shared",
                              "1.0.0",
                              "Linear terrain model [V, omega] with one A, B shared by all modes; modes differ by Q_i",
                              kParameters,
                              2,
                              kStates,
                              2,
                              kInputs,
                              2};

using Model = skidimm::plugins::LtcModel<skidimm::sdk::ParameterScope::kBank>;

}  // namespace

SKIDIMM_EXPORT_MOTION_MODEL(Model, kInfo)
