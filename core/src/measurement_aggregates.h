// The aggregates a measurement may take of its rows within one filter step
// (`mean(x)`, `std(x)`, `rms(x)` in columns.measurements; log_reader.h).
// Private to core/src.
#ifndef SKIDIMM_CORE_SRC_MEASUREMENT_AGGREGATES_H_
#define SKIDIMM_CORE_SRC_MEASUREMENT_AGGREGATES_H_

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

namespace skidimm {
namespace internal {

enum class Aggregation { kMean, kStd, kRms };

// Running moments of the values of one step (Welford: no cancellation).
struct Accumulator {
  long count = 0;
  double mean = 0.0;
  double m2 = 0.0;
  double sum_squares = 0.0;
  void add(double v) {
    ++count;
    const double delta = v - mean;
    mean += delta / static_cast<double>(count);
    m2 += delta * (v - mean);
    sum_squares += v * v;
  }
  double value(Aggregation a) const {
    switch (a) {
      case Aggregation::kMean:
        return count > 0 ? mean : std::numeric_limits<double>::quiet_NaN();
      case Aggregation::kStd:
        return count > 1 ? std::sqrt(std::max(0.0, m2 / static_cast<double>(count - 1)))
                         : std::numeric_limits<double>::quiet_NaN();
      case Aggregation::kRms:
        return count > 0 ? std::sqrt(sum_squares / static_cast<double>(count))
                         : std::numeric_limits<double>::quiet_NaN();
    }
    return std::numeric_limits<double>::quiet_NaN();
  }
  void reset() { *this = Accumulator{}; }
};

// The aggregates a measurement may take of its rows in a step.
const std::vector<std::string>& aggregate_names();

// The aggregate a name of aggregate_names() stands for.
Aggregation aggregation_of(const std::string& name);

}  // namespace internal
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_MEASUREMENT_AGGREGATES_H_
