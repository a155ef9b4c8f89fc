// The aggregates a measurement may take of its rows within one filter step
// (`mean(x)`, `std(x)`, `rms(x)`, `diff_std(x)` in columns.measurements;
// log_reader.h).
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

// kDiffStd: the sample standard deviation of the changes from one value to
// the next, a high-pass measure of how a signal shakes (a surface's texture
// in an accelerometer at 100 Hz) that a slow drift of the signal within the
// step leaves out, where std(x) counts it.
enum class Aggregation { kMean, kStd, kRms, kDiffStd };

// Running moments of one step's values and of their changes from one value
// to the next (Welford: no cancellation).
struct Accumulator {
  long count = 0;
  double mean = 0.0;
  double m2 = 0.0;
  double sum_squares = 0.0;
  double last = 0.0;  // the last value added
  long changes = 0;
  double change_mean = 0.0;
  double change_m2 = 0.0;
  void add(double v) {
    if (count > 0) {
      const double change = v - last;
      ++changes;
      const double delta = change - change_mean;
      change_mean += delta / static_cast<double>(changes);
      change_m2 += delta * (change - change_mean);
    }
    last = v;
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
      case Aggregation::kDiffStd:
        return changes > 1 ? std::sqrt(std::max(0.0, change_m2 / static_cast<double>(changes - 1)))
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
