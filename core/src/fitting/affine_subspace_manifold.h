// The parameters a fit may still move once it holds what the logs do not
// excite: x = x0 + E y, with E an orthonormal basis (ambient x tangent) of
// the directions the logs do determine. Holding whole directions rather than
// single parameters keeps the held part of x where it started whichever
// basis of the unexcited subspace an SVD returns, so the fitted values depend
// only on that subspace (model_fitter.cc, solve()).
#ifndef SKIDIMM_CORE_SRC_FITTING_AFFINE_SUBSPACE_MANIFOLD_H_
#define SKIDIMM_CORE_SRC_FITTING_AFFINE_SUBSPACE_MANIFOLD_H_

#include <ceres/manifold.h>

#include <Eigen/Core>
#include <utility>

namespace skidimm {
namespace fitting {
namespace internal {

class AffineSubspaceManifold : public ceres::Manifold {
 public:
  // `basis`: ambient x tangent, orthonormal columns.
  explicit AffineSubspaceManifold(Eigen::MatrixXd basis) : basis_(std::move(basis)) {}

  int AmbientSize() const override { return static_cast<int>(basis_.rows()); }
  int TangentSize() const override { return static_cast<int>(basis_.cols()); }

  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override {
    Eigen::Map<Eigen::VectorXd>(x_plus_delta, basis_.rows()) =
        Eigen::Map<const Eigen::VectorXd>(x, basis_.rows()) +
        basis_ * Eigen::Map<const Eigen::VectorXd>(delta, basis_.cols());
    return true;
  }

  bool PlusJacobian(const double* /*x*/, double* jacobian) const override {
    Eigen::Map<RowMajor>(jacobian, basis_.rows(), basis_.cols()) = basis_;
    return true;
  }

  // Exact for y on the subspace through x, which is where the solver asks.
  bool Minus(const double* y, const double* x, double* y_minus_x) const override {
    Eigen::Map<Eigen::VectorXd>(y_minus_x, basis_.cols()) =
        basis_.transpose() * (Eigen::Map<const Eigen::VectorXd>(y, basis_.rows()) -
                              Eigen::Map<const Eigen::VectorXd>(x, basis_.rows()));
    return true;
  }

  bool MinusJacobian(const double* /*x*/, double* jacobian) const override {
    Eigen::Map<RowMajor>(jacobian, basis_.cols(), basis_.rows()) = basis_.transpose();
    return true;
  }

 private:
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  Eigen::MatrixXd basis_;
};

}  // namespace internal
}  // namespace fitting
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_FITTING_AFFINE_SUBSPACE_MANIFOLD_H_
