#include "covariance.h"

#include <gtest/gtest.h>

#include <limits>

namespace skidimm {
namespace {

TEST(CheckCovariance, AcceptsSymmetricPositiveMatrices) {
  Eigen::MatrixXd m(2, 2);
  m << 2, 1, 1, 2;
  EXPECT_TRUE(check_covariance(m, true, nullptr));
  EXPECT_TRUE(check_covariance(Eigen::MatrixXd::Zero(2, 2), false, nullptr));
}

TEST(CheckCovariance, ExplainsEachFailure) {
  std::string why;
  Eigen::MatrixXd asymmetric(2, 2);
  asymmetric << 1, 0.5, 0.2, 1;
  EXPECT_FALSE(check_covariance(asymmetric, false, &why));
  EXPECT_EQ(why, "not symmetric: (0,1) = 0.5 but (1,0) = 0.2");
  Eigen::MatrixXd indefinite(2, 2);
  indefinite << 1, 2, 2, 1;
  EXPECT_FALSE(check_covariance(indefinite, false, &why));
  EXPECT_EQ(why, "not positive semidefinite: smallest eigenvalue -1");
  EXPECT_FALSE(check_covariance(Eigen::MatrixXd::Zero(2, 2), true, &why));
  EXPECT_EQ(why, "not positive definite: smallest eigenvalue 0");
  Eigen::MatrixXd nan = Eigen::MatrixXd::Identity(2, 2);
  nan(0, 0) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(check_covariance(nan, false, &why));
  EXPECT_EQ(why, "has non-finite entries");
  EXPECT_FALSE(check_covariance(Eigen::MatrixXd::Zero(2, 3), false, &why));
  EXPECT_EQ(why, "not square (2x3)");
}

TEST(Symmetrize, AveragesOffDiagonalPairs) {
  Eigen::MatrixXd m(2, 2);
  m << 1, 2, 4, 3;
  symmetrize(m);
  EXPECT_EQ(m(0, 1), 3.0);
  EXPECT_EQ(m(1, 0), 3.0);
  EXPECT_EQ(m(0, 0), 1.0);
}

}  // namespace
}  // namespace skidimm
