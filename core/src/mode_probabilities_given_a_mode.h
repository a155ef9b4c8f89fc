// The modes' probabilities given that some mode holds, for a bank with an
// unknown hypothesis (docs/engine.md, "Unknown hypothesis"): the modes then
// sum to 1 - mu_U, and the filters mix and combine their states with these
// weights instead, as the estimates of the modes given that one of them
// holds. The filter and the smoother both use it. Private to core/src.
#ifndef SKIDIMM_CORE_SRC_MODE_PROBABILITIES_GIVEN_A_MODE_H_
#define SKIDIMM_CORE_SRC_MODE_PROBABILITIES_GIVEN_A_MODE_H_

#include <Eigen/Core>

namespace skidimm {
namespace internal {

// *out = mu / sum(mu), or uniform when every mode has probability 0.
// Allocates nothing once *out has mu's size.
inline void given_a_mode(const Eigen::VectorXd& mu, Eigen::VectorXd* out) {
  const double total = mu.sum();
  if (total > 0.0) {
    *out = mu / total;
  } else {
    out->setConstant(mu.size(), 1.0 / static_cast<double>(mu.size()));
  }
}

}  // namespace internal
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_MODE_PROBABILITIES_GIVEN_A_MODE_H_
