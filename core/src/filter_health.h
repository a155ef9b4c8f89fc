// Whether a mode filter's state and covariance are still numbers the next
// step can work with. A filter that fails this test has diverged (an outlier
// it applied, a covariance that lost positive definiteness to round-off in
// mixing, a model that blows up) and is reset by the IMM (imm_kernel.h);
// the smoother keeps the filtered estimate for a pair that fails it
// (imm_smoother.cc). Private to core/src.
//
// The bounds: a state component above 1e100 in magnitude or a variance above
// 1e200 is no physical quantity in any unit (the bank's own matrices are
// bounded at 1e15, bank_loader.cc) and is one squaring away from overflow:
// the combined covariance sums mu (P + d d') over modes, d up to 2e100, so it
// stays below 5e200 and finite whatever the modes hold. A negative variance
// or a non-finite entry is never a covariance.
#ifndef SKIDIMM_CORE_SRC_FILTER_HEALTH_H_
#define SKIDIMM_CORE_SRC_FILTER_HEALTH_H_

#include <Eigen/Core>

#include "all_finite.h"

namespace skidimm {
namespace internal {

constexpr double kMaxStateMagnitude = 1e100;
constexpr double kMaxVariance = 1e200;

// Every entry finite, every variance in [0, kMaxVariance], every state
// component within kMaxStateMagnitude. No allocation: a test per state
// component and variance, then one sum over P without a branch per entry
// (all_finite.h). The comparisons are false for NaN, so a NaN component or
// variance fails them too.
template <typename State, typename Covariance>
bool filter_is_healthy(const State& x, const Covariance& p) {
  const auto variances = p.diagonal().array();
  return (x.array().abs() <= kMaxStateMagnitude).all() && (variances >= 0.0).all() &&
         (variances <= kMaxVariance).all() && all_finite(p);
}

// What the IMM's output promises (docs/engine.md): a finite state and a
// finite covariance with no negative variance.
template <typename State, typename Covariance>
bool estimate_is_sound(const State& x, const Covariance& p) {
  return all_finite(x) && (p.diagonal().array() >= 0.0).all() && all_finite(p);
}

}  // namespace internal
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_FILTER_HEALTH_H_
