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

constexpr PluginInfo kInfo = {"ltc_shared", "1.0.0",
                              "Linear terrain model [V, omega] with one A, B shared by all modes; modes differ by Q_i",
                              kParameters, 2};

using Model = skidimm::plugins::LtcModel<skidimm::sdk::ParameterScope::kBank>;

}  // namespace

SKIDIMM_EXPORT_MOTION_MODEL(Model, kInfo)
