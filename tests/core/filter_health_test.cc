// The finiteness and health tests the filters and the IMM decide divergence
// by (all_finite.h, filter_health.h), against values chosen by hand at and
// beyond each bound, in every entry.
#include "filter_health.h"

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <limits>

#include "all_finite.h"

namespace skidimm {
namespace internal {
namespace {

using Limits = std::numeric_limits<double>;

const double kNonFinite[] = {Limits::infinity(), -Limits::infinity(), Limits::quiet_NaN(), -Limits::quiet_NaN()};

// Finite but extreme: the largest magnitudes, the smallest subnormal, a
// negative zero. x * 0 is (+-)0 for each, so the sum must stay 0.
Eigen::Matrix<double, 9, 9> extreme_finite_matrix() {
  Eigen::Matrix<double, 9, 9> m = Eigen::Matrix<double, 9, 9>::Constant(-Limits::max());
  m(0, 0) = -0.0;
  m(4, 4) = Limits::denorm_min();
  m(8, 8) = Limits::max();
  m(3, 7) = Limits::lowest();
  return m;
}

TEST(AllFinite, FindsEveryInfinityAndNaNInEveryEntryOfAFixedSizeMatrix) {
  const Eigen::Matrix<double, 9, 9> finite = extreme_finite_matrix();
  EXPECT_TRUE(all_finite(finite));
  EXPECT_TRUE(all_finite(Eigen::Vector3d(1.0, -2.0, 0.0)));
  for (double bad : kNonFinite) {
    for (int i = 0; i < 81; ++i) {
      Eigen::Matrix<double, 9, 9> m = finite;
      m.data()[i] = bad;
      EXPECT_FALSE(all_finite(m)) << "entry " << i << " = " << bad;
    }
    EXPECT_FALSE(all_finite(Eigen::Vector3d(1.0, bad, 2.0))) << bad;
  }
}

TEST(AllFinite, WorksOnDynamicMatricesBlocksRefsAndEmptyOnes) {
  Eigen::MatrixXd m = extreme_finite_matrix();
  EXPECT_TRUE(all_finite(m));
  EXPECT_TRUE(all_finite(Eigen::MatrixXd(0, 0)));
  EXPECT_TRUE(all_finite(Eigen::VectorXd(0)));
  m(6, 2) = Limits::quiet_NaN();
  EXPECT_FALSE(all_finite(m));
  EXPECT_FALSE(all_finite(Eigen::Ref<const Eigen::MatrixXd>(m)));
  EXPECT_FALSE(all_finite(m.col(2)));
  EXPECT_FALSE(all_finite(m.row(6)));
  // A block that leaves the NaN out sees only finite entries.
  EXPECT_TRUE(all_finite(m.leftCols(2)));
  EXPECT_TRUE(all_finite(m.block(0, 0, 6, 9)));
}

TEST(FilterIsHealthy, AcceptsAnOrdinaryFilterAndTheBoundsThemselves) {
  Eigen::Vector2d x(0.3, -kMaxStateMagnitude);
  Eigen::Matrix2d p;
  p << kMaxVariance, -1e150, -1e150, 0.0;
  EXPECT_TRUE(filter_is_healthy(x, p));
  EXPECT_TRUE(filter_is_healthy(Eigen::VectorXd(x), Eigen::MatrixXd(p)));
}

TEST(FilterIsHealthy, RejectsEachWayAFilterCanDiverge) {
  const Eigen::Vector3d x(1.0, -2.0, 0.5);
  Eigen::Matrix3d p;
  p << 2.0, 0.1, 0.0, 0.1, 1.0, 0.2, 0.0, 0.2, 3.0;
  ASSERT_TRUE(filter_is_healthy(x, p));
  for (int i = 0; i < 3; ++i) {
    for (double beyond : {1.0000001 * kMaxStateMagnitude, -1.0000001 * kMaxStateMagnitude}) {
      Eigen::Vector3d far = x;
      far[i] = beyond;
      EXPECT_FALSE(filter_is_healthy(far, p)) << "state " << i << " = " << beyond;
    }
    for (double bad : kNonFinite) {
      Eigen::Vector3d nonfinite = x;
      nonfinite[i] = bad;
      EXPECT_FALSE(filter_is_healthy(nonfinite, p)) << "state " << i << " = " << bad;
    }
    for (double variance : {-1e-300, 1.0000001 * kMaxVariance}) {
      Eigen::Matrix3d q = p;
      q(i, i) = variance;
      EXPECT_FALSE(filter_is_healthy(x, q)) << "variance " << i << " = " << variance;
    }
  }
  for (int k = 0; k < 9; ++k) {
    for (double bad : kNonFinite) {
      Eigen::Matrix3d q = p;
      q.data()[k] = bad;
      EXPECT_FALSE(filter_is_healthy(x, q)) << "covariance entry " << k << " = " << bad;
      EXPECT_FALSE(filter_is_healthy(Eigen::VectorXd(x), Eigen::MatrixXd(q))) << "entry " << k << " = " << bad;
    }
  }
}

// The output's promise is weaker: any finite state, any finite covariance
// with no negative variance, however large.
TEST(EstimateIsSound, AcceptsAnyFiniteEstimateWithoutANegativeVariance) {
  Eigen::Vector2d x(Limits::max(), -Limits::max());
  Eigen::Matrix2d p;
  p << Limits::max(), Limits::lowest(), Limits::lowest(), 0.0;
  EXPECT_TRUE(estimate_is_sound(x, p));
  EXPECT_FALSE(filter_is_healthy(x, p));
  for (int i = 0; i < 2; ++i) {
    Eigen::Matrix2d q = p;
    q(i, i) = -Limits::denorm_min();
    EXPECT_FALSE(estimate_is_sound(x, q)) << "variance " << i;
    for (double bad : kNonFinite) {
      Eigen::Vector2d y = x;
      y[i] = bad;
      EXPECT_FALSE(estimate_is_sound(y, p)) << "state " << i << " = " << bad;
    }
  }
  for (int k = 0; k < 4; ++k) {
    for (double bad : kNonFinite) {
      Eigen::Matrix2d q = p;
      q.data()[k] = bad;
      EXPECT_FALSE(estimate_is_sound(Eigen::VectorXd(x), Eigen::MatrixXd(q))) << "entry " << k << " = " << bad;
    }
  }
}

}  // namespace
}  // namespace internal
}  // namespace skidimm
