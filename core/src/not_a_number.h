// The quiet NaN that marks a value the core has not got (a missing
// measurement, an undefined metric), written once for every file that needs
// it. Private to core/src.
#ifndef SKIDIMM_CORE_SRC_NOT_A_NUMBER_H_
#define SKIDIMM_CORE_SRC_NOT_A_NUMBER_H_

#include <limits>

namespace skidimm {
namespace internal {

inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

}  // namespace internal
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_NOT_A_NUMBER_H_
