// `linear_features`: dx/dt = A x + B u + c over the bank's own states and
// inputs, discretised exactly (linear_features_model.h).
#include "linear_features/linear_features_model.h"
#include "skidimm/sdk/export.h"

namespace {

using skidimm::sdk::ParameterDoc;
using skidimm::sdk::PluginInfo;

constexpr ParameterDoc kParameters[] = {
    {"A", "n x n or n", "state matrix (1/s), per mode: a matrix (full A) or a list (its diagonal); n = bank states"},
    {"B", "n x m", "input matrix, per mode: one row per bank state, one column per bank input"},
    {"c", "n, optional", "constant term of dx/dt, per mode; absent: zero and not fitted"},
    {"fixed", "text list, optional", "keys among A, B, c held at their given values and not fitted, e.g. [A]"},
};

constexpr PluginInfo kInfo = {
    "linear_features",
    "1.1.0",
    "Linear model dx/dt = A x + B u + c over the bank's own states and inputs, exact zero-order-hold step",
    kParameters,
    4,
    nullptr,
    0,
    nullptr,
    0};  // the bank's own states and inputs

}  // namespace

SKIDIMM_EXPORT_MOTION_MODEL(skidimm::plugins::LinearFeaturesModel, kInfo)
