// What the assessment protocols (skidimm/fitting/tuning.h: Protocol,
// grouped_folds, protocol_folds) leave to train a fold on. Private to the
// fitting library (assessment_protocols.cc, tuning.cc).
#ifndef SKIDIMM_CORE_SRC_FITTING_ASSESSMENT_PROTOCOLS_H_
#define SKIDIMM_CORE_SRC_FITTING_ASSESSMENT_PROTOCOLS_H_

#include <vector>

namespace skidimm {
namespace fitting {
namespace internal {

// The members of `within` not in `excluded`.
std::vector<int> complement(const std::vector<int>& excluded, const std::vector<int>& within);

}  // namespace internal
}  // namespace fitting
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_FITTING_ASSESSMENT_PROTOCOLS_H_
