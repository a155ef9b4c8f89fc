// `stc_sided`: pose model [X, Y, theta] with per-side tread efficiencies and
// tread ICRs (outer and inner) per mode (Mandow et al. 2007); equations in
// stc_sided_predict.h.
#include "skidimm/sdk/export.h"
#include "stc_sided/stc_sided_docs.h"
#include "stc_sided/stc_sided_model.h"

namespace {

namespace docs = skidimm::plugins::stc_sided;

constexpr skidimm::sdk::PluginInfo kInfo = {
    "stc_sided",
    "1.0.0",
    "Kinematic pose model [X, Y, theta] with per-side tread efficiencies and tread ICRs per mode (Mandow et al. 2007)",
    docs::kParameterDocs,
    docs::kNumParameters,
    docs::kStateDocs,
    3,
    docs::kInputDocs,
    2,
    docs::kOutputDocs,
    1};

}  // namespace

SKIDIMM_EXPORT_MOTION_MODEL(skidimm::plugins::StcSidedModel, kInfo)
