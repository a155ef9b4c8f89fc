// Collapsing a Gaussian mixture to one Gaussian (moment matching), the way
// the IMM mixes (paper eq. 6-7) and combines (eq. 10-11), and the smoother
// collapses its mode pairs.
//
// Angle components (angle_mask) are averaged on the circle: offsets from the
// heaviest component's angle, wrapped to [-pi, pi), are averaged and added
// back, so 179 deg and -179 deg average to 180 deg, not 0. Deviations of the
// components from the mean are wrapped the same way.
//
// Mixing every target at once (pack_moments / unpack_moments): the IMM mixes
// N components into N targets with weights w_ij = p_ij mu_i / c_j. About one
// common reference r (the heaviest mode's state), with y_i = x_i - r wrapped
// for angles, target j's mixture is
//   x^{0j} = r + m_j,   m_j = sum_i w_ij y_i,
//   P^{0j} = sum_i w_ij (P_i + y_i y_i') - m_j m_j',
// so with row i of a moment matrix Y = mu_i [1, y_i', vech(P_i + y_i y_i')']
// (moment_columns(n) columns), row j of P' Y is c_j [1, m_j', vech(...)']:
// one N x N by N x C product mixes every target (O(N^2 n^2), no N^2 angle
// wraps), and its first column is the predicted probability c_j itself.
// This equals the per-target form around each target's heaviest component
// whenever the components' angles lie within a half circle of r and of that
// component (so that no offset wraps differently); in floating point the two
// differ by round-off, about eps |y|^2 / |P^{0j}| relative: below 1e-12 for the
// bundled banks (tests/core/imm_test.cc compares the IMM with the per-target
// reference to 1e-10 over long runs, angles across +-pi included).
#ifndef SKIDIMM_CORE_SRC_GAUSSIAN_MIXTURE_H_
#define SKIDIMM_CORE_SRC_GAUSSIAN_MIXTURE_H_

#include <Eigen/Core>
#include <vector>

#include "skidimm/sdk/angles.h"

namespace skidimm {

// mean = the weighted mean of `means` (one component per column, weights
// summing to 1); deviations.col(i) = means.col(i) - mean, wrapped for angles.
// Allocates nothing.
void weighted_mean(const std::vector<bool>& angle_mask, const Eigen::Ref<const Eigen::VectorXd>& weights,
                   const Eigen::Ref<const Eigen::MatrixXd>& means, Eigen::Ref<Eigen::VectorXd> mean,
                   Eigen::Ref<Eigen::MatrixXd> deviations);

// Columns of the moment matrix for an n-dimensional state: 1 + n + n(n+1)/2.
inline int moment_columns(int n) { return 1 + n + n * (n + 1) / 2; }

// Writes component (x, p) with weight w into `row` (moment_columns(n)
// entries, any stride) about `reference`; is_angle[d]: component d wraps.
// `offset` is workspace of the state's size. Allocates nothing.
template <typename Vector, typename Matrix, typename Reference, typename Row, typename Offset>
void pack_moments(const bool* is_angle, double w, const Vector& x, const Matrix& p, const Reference& reference,
                  Offset& offset, Row&& row) {
  const Eigen::Index n = x.size();
  for (Eigen::Index d = 0; d < n; ++d) {
    const double y = x[d] - reference[d];
    offset[d] = is_angle[d] && !(y >= -sdk::kPi && y < sdk::kPi) ? sdk::wrap_angle(y) : y;
  }
  row[0] = w;
  for (Eigen::Index d = 0; d < n; ++d) row[1 + d] = w * offset[d];
  Eigen::Index t = 1 + n;
  // For a state of fixed size the triangle is unrolled whole: its bounds
  // become constants (half or less of the instructions at 9 states; the same
  // operations).
#pragma GCC unroll 16
  for (Eigen::Index b = 0; b < n; ++b) {
#pragma GCC unroll 16
    for (Eigen::Index a = 0; a <= b; ++a) row[t++] = w * (p(a, b) + offset[a] * offset[b]);
  }
}

// The mixture whose weighted moments `row` holds (as pack_moments wrote
// them, summed with weights adding up to `total` > 0): mean and covariance.
// `offset` is workspace of the state's size. Allocates nothing.
template <typename Row, typename Reference, typename Vector, typename Matrix, typename Offset>
void unpack_moments(const bool* is_angle, const Row& row, double total, const Reference& reference, Offset& offset,
                    Vector& mean, Matrix& covariance) {
  const Eigen::Index n = mean.size();
  const double inverse = 1.0 / total;
  for (Eigen::Index d = 0; d < n; ++d) {
    offset[d] = row[1 + d] * inverse;
    const double value = reference[d] + offset[d];
    mean[d] = is_angle[d] && !(value >= -sdk::kPi && value < sdk::kPi) ? sdk::wrap_angle(value) : value;
  }
  Eigen::Index t = 1 + n;
  // Unrolled whole for a state of fixed size, as in pack_moments().
#pragma GCC unroll 16
  for (Eigen::Index b = 0; b < n; ++b) {
#pragma GCC unroll 16
    for (Eigen::Index a = 0; a <= b; ++a) {
      const double v = row[t++] * inverse - offset[a] * offset[b];
      covariance(a, b) = v;
      covariance(b, a) = v;
    }
  }
}

}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_GAUSSIAN_MIXTURE_H_
