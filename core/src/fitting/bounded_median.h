// The median of a stream of values in bounded memory: exact while at most
// `kept` values have come, then the median of a systematic sample (every
// stride-th value, the stride doubling each time the sample fills). Fits use
// it to compare one window or row with the typical one, which needs the
// median's size, not its last digit, and must not hold a value per row of a
// log of a million rows.
#ifndef SKIDIMM_FITTING_BOUNDED_MEDIAN_H_
#define SKIDIMM_FITTING_BOUNDED_MEDIAN_H_

#include <algorithm>
#include <cstddef>
#include <vector>

namespace skidimm {
namespace fitting {
namespace internal {

class BoundedMedian {
 public:
  // `kept`: at most this many values held (even).
  explicit BoundedMedian(std::size_t kept = 1 << 16) : kept_limit_(kept) {}

  void add(double value) {
    if (seen_++ % stride_ != 0) return;
    if (kept_.size() == kept_limit_) {
      // Keep every other value: the sample of the doubled stride so far.
      for (std::size_t i = 0; i < kept_limit_ / 2; ++i) kept_[i] = kept_[2 * i];
      kept_.resize(kept_limit_ / 2);
      stride_ *= 2;
      if ((seen_ - 1) % stride_ != 0) return;
    }
    kept_.push_back(value);
  }
  bool empty() const { return kept_.empty(); }
  // The (upper) median of the values kept; reorders them.
  double median() {
    const auto middle = kept_.begin() + static_cast<std::ptrdiff_t>(kept_.size() / 2);
    std::nth_element(kept_.begin(), middle, kept_.end());
    return *middle;
  }

 private:
  std::size_t kept_limit_;
  std::vector<double> kept_;
  std::size_t seen_ = 0;
  std::size_t stride_ = 1;
};

}  // namespace internal
}  // namespace fitting
}  // namespace skidimm

#endif  // SKIDIMM_FITTING_BOUNDED_MEDIAN_H_
