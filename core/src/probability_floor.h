// The mode probability floor (`mode_probability_floor`, docs/engine.md),
// applied so that it is a true lower bound after renormalisation. Raising
// every probability to the floor and dividing by the new sum (the obvious
// way) leaves the raised ones below the floor: 0.333 with three modes gave
// 0.20. Here the modes below the floor get exactly the floor and the others
// share what is left in proportion to their probabilities; a mode that this
// scaling pushes below the floor joins the floored ones, at most N passes.
// Private to core/src (the filter and the smoother use it).
#ifndef SKIDIMM_CORE_SRC_PROBABILITY_FLOOR_H_
#define SKIDIMM_CORE_SRC_PROBABILITY_FLOOR_H_

#include <Eigen/Core>

namespace skidimm {
namespace internal {

// mu: probabilities summing to 1; floor * mu.size() < 1 (the bank loader
// refuses more). Afterwards every entry is >= floor and they sum to 1 (to
// round-off). No allocation.
inline void apply_probability_floor(double floor, Eigen::Ref<Eigen::VectorXd> mu) {
  if (!(floor > 0.0)) return;
  const Eigen::Index n = mu.size();
  for (Eigen::Index pass = 0; pass < n; ++pass) {
    Eigen::Index floored = 0;
    double free_mass = 0.0;
    for (Eigen::Index j = 0; j < n; ++j) {
      if (mu[j] <= floor) {
        ++floored;
      } else {
        free_mass += mu[j];
      }
    }
    if (floored == 0) return;
    const double remaining = 1.0 - static_cast<double>(floored) * floor;
    if (!(free_mass > 0.0 && remaining > 0.0)) {  // cannot happen when floor * n < 1
      mu.setConstant(1.0 / static_cast<double>(n));
      return;
    }
    const double scale = remaining / free_mass;
    bool settled = true;
    for (Eigen::Index j = 0; j < n; ++j) {
      if (mu[j] <= floor) {
        mu[j] = floor;
      } else {
        mu[j] *= scale;
        settled = settled && mu[j] > floor;
      }
    }
    if (settled) return;
  }
}

}  // namespace internal
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_PROBABILITY_FLOOR_H_
