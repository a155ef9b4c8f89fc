#include "measurement_aggregates.h"

namespace skidimm {
namespace internal {

const std::vector<std::string>& aggregate_names() {
  static const std::vector<std::string> names{"mean", "std", "rms", "diff_std"};
  return names;
}

Aggregation aggregation_of(const std::string& name) {
  if (name == "std") return Aggregation::kStd;
  if (name == "rms") return Aggregation::kRms;
  if (name == "diff_std") return Aggregation::kDiffStd;
  return Aggregation::kMean;
}

}  // namespace internal
}  // namespace skidimm
