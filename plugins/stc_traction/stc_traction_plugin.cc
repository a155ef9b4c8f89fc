// `stc_traction`: stc_sided's pose model [X, Y, theta] (per-side tread
// efficiencies and tread ICRs, Mandow et al. 2007) with ICRs that move out as
// the turn tightens, which also predicts each side's motor current, the one
// measurement that sees how hard the ground resists: equations in
// stc_sided/stc_sided_predict.h and stc_traction_equations.h.
#include "stc_traction/stc_traction_model.h"

SKIDIMM_EXPORT_FUNCTION_MODEL(skidimm::plugins::StcTraction)
