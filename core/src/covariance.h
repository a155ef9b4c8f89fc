// Checks and repairs for covariance matrices.
#ifndef SKIDIMM_CORE_SRC_COVARIANCE_H_
#define SKIDIMM_CORE_SRC_COVARIANCE_H_

#include <Eigen/Core>
#include <string>

namespace skidimm {

// True if `m` is square, finite, symmetric (to a relative tolerance) and
// positive semidefinite (positive definite if `strict`). Otherwise false with
// the reason in *why ("not symmetric: m(0,1) = 1 but m(1,0) = 2", ...).
bool check_covariance(const Eigen::MatrixXd& m, bool strict, std::string* why);

// m = (m + m') / 2, in place, without a temporary.
template <typename Derived>
void symmetrize(Eigen::MatrixBase<Derived>& m) {
  for (Eigen::Index i = 0; i < m.rows(); ++i) {
    for (Eigen::Index j = i + 1; j < m.cols(); ++j) {
      const double mean = 0.5 * (m(i, j) + m(j, i));
      m(i, j) = mean;
      m(j, i) = mean;
    }
  }
}

}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_COVARIANCE_H_
