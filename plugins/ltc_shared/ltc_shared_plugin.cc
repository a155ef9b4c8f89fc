// `ltc_shared`: one A, B for the whole bank, modes differ by process noise only
// (paper, section III-A, last paragraph; ltc_common/ltc_model.h).
#include "ltc_common/ltc_model.h"

SKIDIMM_EXPORT_FUNCTION_MODEL(skidimm::plugins::LtcShared)
