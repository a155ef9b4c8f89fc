// `stc_traction`: stc_sided's pose model [X, Y, theta] (per-side tread
// efficiencies and tread ICRs, Mandow et al. 2007) with ICRs that move out as
// the turn tightens, which also predicts each side's motor current, the one
// measurement that sees how hard the ground resists: equations in
// stc_sided/stc_sided_predict.h and stc_sided/stc_traction_equations.h.
#include "skidimm/sdk/export.h"
#include "stc_sided/stc_sided_docs.h"
#include "stc_sided/stc_sided_model.h"

namespace {

namespace docs = skidimm::plugins::stc_sided;

constexpr skidimm::sdk::PluginInfo kInfo = {
    "stc_traction",
    "1.0.0",
    "stc_sided's pose model [X, Y, theta] with turn-dependent skid, predicting each side's motor current (omega, i_L, "
    "i_R outputs)",
    docs::kParameterDocs,
    docs::kNumTractionParameters,
    docs::kStateDocs,
    3,
    docs::kInputDocs,
    2,
    docs::kOutputDocs,
    docs::kNumTractionOutputs};

}  // namespace

SKIDIMM_EXPORT_MOTION_MODEL(skidimm::plugins::StcTractionModel, kInfo)
