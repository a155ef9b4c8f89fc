// `ltc_linear`: per-mode linear terrain model, paper eq. 2 (ltc_common/ltc_model.h).
#include "ltc_common/ltc_model.h"

SKIDIMM_EXPORT_FUNCTION_MODEL(skidimm::plugins::LtcLinear)
