// `stc_sided`: pose model [X, Y, theta] with per-side tread efficiencies and
// tread ICRs (outer and inner) per mode (Mandow et al. 2007); equations in
// stc_sided_predict.h.
#include "stc_sided/stc_sided_model.h"

SKIDIMM_EXPORT_FUNCTION_MODEL(skidimm::plugins::StcSided)
