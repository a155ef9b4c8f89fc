// `linear_features`: dx/dt = A x + B u + c over the bank's own states and
// inputs, discretised exactly (linear_features_model.h).
#include "linear_features/linear_features_model.h"

SKIDIMM_EXPORT_FUNCTION_MODEL(skidimm::plugins::LinearFeatures)
