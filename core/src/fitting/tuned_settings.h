// How tuned settings print. Private to the fitting library
// (tuned_settings.cc, tuning.cc).
#ifndef SKIDIMM_CORE_SRC_FITTING_TUNED_SETTINGS_H_
#define SKIDIMM_CORE_SRC_FITTING_TUNED_SETTINGS_H_

#include <string>

namespace skidimm {
namespace fitting {
namespace internal {

// A tuned value as TunedSettings::describe() and the tuner's progress lines
// print it: four significant digits.
std::string brief(double v);

}  // namespace internal
}  // namespace fitting
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_FITTING_TUNED_SETTINGS_H_
