// Collapsing a Gaussian mixture to one Gaussian (moment matching), the way
// the IMM mixes (paper eq. 6-7) and combines (eq. 10-11), and the smoother
// collapses its mode pairs.
//
// Angle components (angle_mask) are averaged on the circle: offsets from the
// heaviest component's angle, wrapped to [-pi, pi), are averaged and added
// back, so 179 deg and -179 deg average to 180 deg, not 0. Deviations of the
// components from the mean are wrapped the same way.
#ifndef SKIDIMM_GAUSSIAN_MIXTURE_H_
#define SKIDIMM_GAUSSIAN_MIXTURE_H_

#include <Eigen/Core>
#include <vector>

namespace skidimm {

// mean = the weighted mean of `means` (one component per column, weights
// summing to 1); deviations.col(i) = means.col(i) - mean, wrapped for angles.
// Allocates nothing.
void weighted_mean(const std::vector<bool>& angle_mask, const Eigen::Ref<const Eigen::VectorXd>& weights,
                   const Eigen::Ref<const Eigen::MatrixXd>& means, Eigen::Ref<Eigen::VectorXd> mean,
                   Eigen::Ref<Eigen::MatrixXd> deviations);

}  // namespace skidimm

#endif  // SKIDIMM_GAUSSIAN_MIXTURE_H_
