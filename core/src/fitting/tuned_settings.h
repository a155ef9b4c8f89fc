// How tuned settings print, and how they are applied to a tuner's banks.
// Private to the fitting library (tuned_settings.cc, tuning.cc).
#ifndef SKIDIMM_CORE_SRC_FITTING_TUNED_SETTINGS_H_
#define SKIDIMM_CORE_SRC_FITTING_TUNED_SETTINGS_H_

#include <string>

#include "kept_covariance_models.h"
#include "skidimm/fitting/tuning.h"

namespace skidimm {
namespace fitting {
namespace internal {

// A tuned value as TunedSettings::describe() and the tuner's progress lines
// print it: four significant digits.
std::string brief(double v);

// fitting::apply(), each mode's parameter covariance through `kept` (the
// bank's own).
void apply(const FittedValues& fitted, const TunedSettings& settings, Bank* bank, KeptCovarianceModels* kept);

}  // namespace internal
}  // namespace fitting
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_FITTING_TUNED_SETTINGS_H_
