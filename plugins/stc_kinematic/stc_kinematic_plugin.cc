// `stc_kinematic`: pose model with per-mode slip constants k_i, m_i (paper eq. 3).
#include "stc_kinematic/stc_kinematic_model.h"

SKIDIMM_EXPORT_FUNCTION_MODEL(skidimm::plugins::StcKinematic)
