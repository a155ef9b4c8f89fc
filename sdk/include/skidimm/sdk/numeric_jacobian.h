// Central-difference Jacobian of a model's prediction with respect to x.
//
// Used as MotionModel's default jacobian() and by the conformance kit to check
// analytic Jacobians. Angle components of the output are differenced with
// wrapping, so a prediction that crosses +-pi does not produce a 2*pi spike.
#ifndef SKIDIMM_SDK_NUMERIC_JACOBIAN_H_
#define SKIDIMM_SDK_NUMERIC_JACOBIAN_H_

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <limits>

#include "skidimm/sdk/angles.h"

namespace skidimm {
namespace sdk {

// The step central differences take for an argument of value `a`:
// cbrt(eps) balances truncation and round-off error, relative to |a| where
// it exceeds 1. Rounding alone then errs by up to about eps |f| / h in a
// derivative of f (each evaluation rounds by eps |f| / 2).
inline double central_difference_step(double a) {
  return std::cbrt(std::numeric_limits<double>::epsilon()) * std::max(1.0, std::abs(a));
}

// predict(x, x_next) -> bool. `is_angle(i)` says which outputs wrap.
// Returns false if any evaluation fails or is non-finite.
namespace internal {

template <typename Vector, typename Matrix, typename Predict, typename IsAngle>
bool central_differences(const Predict& predict, const IsAngle& is_angle, const Vector& x, Vector& x_perturbed,
                         Vector& plus, Vector& minus, Matrix& jacobian) {
  const Eigen::Index n = x.size();
  x_perturbed = x;
  for (Eigen::Index j = 0; j < n; ++j) {
    const double h = central_difference_step(x[j]);
    x_perturbed[j] = x[j] + h;
    if (!predict(x_perturbed, plus)) return false;
    x_perturbed[j] = x[j] - h;
    if (!predict(x_perturbed, minus)) return false;
    x_perturbed[j] = x[j];
    for (Eigen::Index i = 0; i < jacobian.rows(); ++i) {
      double difference = plus[i] - minus[i];
      if (is_angle(static_cast<int>(i))) difference = wrap_angle(difference);
      jacobian(i, j) = difference / (2.0 * h);
    }
  }
  return jacobian.allFinite();
}

}  // namespace internal

// Dynamic-size form, for any MotionModel.
template <typename Predict, typename IsAngle>
bool numeric_state_jacobian(const Predict& predict, const IsAngle& is_angle, const Eigen::Ref<const Eigen::VectorXd>& x,
                            Eigen::Ref<Eigen::MatrixXd> jacobian) {
  const Eigen::VectorXd x_copy = x;
  Eigen::VectorXd x_perturbed(x.size()), plus(x.size()), minus(x.size());
  return internal::central_differences(predict, is_angle, x_copy, x_perturbed, plus, minus, jacobian);
}

// Fixed-size form: allocates nothing.
template <typename Predict, typename IsAngle, int kN>
bool numeric_state_jacobian_fixed(const Predict& predict, const IsAngle& is_angle,
                                  const Eigen::Matrix<double, kN, 1>& x, Eigen::Matrix<double, kN, kN>* jacobian) {
  Eigen::Matrix<double, kN, 1> x_perturbed, plus, minus;
  return internal::central_differences(predict, is_angle, x, x_perturbed, plus, minus, *jacobian);
}

}  // namespace sdk
}  // namespace skidimm

#endif  // SKIDIMM_SDK_NUMERIC_JACOBIAN_H_
