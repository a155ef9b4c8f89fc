#include "ldlt_solve.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>

namespace skidimm {
namespace {

// A random symmetric positive definite n x n matrix whose eigenvalues span
// `decades` orders of magnitude (so that LDLT pivots), and a right-hand side.
template <int N>
void random_problem(int n, int decades, std::mt19937_64* rng, Eigen::Matrix<double, N, N>* a,
                    Eigen::Matrix<double, N, N>* b) {
  std::normal_distribution<double> normal;
  Eigen::MatrixXd q = Eigen::MatrixXd::NullaryExpr(n, n, [&] { return normal(*rng); });
  Eigen::VectorXd scales(n);
  for (int i = 0; i < n; ++i) scales[i] = std::pow(10.0, decades * (static_cast<double>(i) / std::max(n - 1, 1)));
  const Eigen::MatrixXd spd = q * scales.asDiagonal() * q.transpose() + 1e-12 * Eigen::MatrixXd::Identity(n, n);
  *a = spd;
  *b = Eigen::MatrixXd::NullaryExpr(n, n, [&] { return normal(*rng); });
}

template <int N>
void expect_eigens_solve_bit_for_bit(int n) {
  std::mt19937_64 rng(29 + n);
  for (int decades = 0; decades <= 12; decades += 4) {
    for (int trial = 0; trial < 50; ++trial) {
      Eigen::Matrix<double, N, N> a, b;
      random_problem<N>(n, decades, &rng, &a, &b);
      const Eigen::LDLT<Eigen::Matrix<double, N, N>> ldlt(a);
      const Eigen::Matrix<double, N, N> expected = ldlt.solve(b);
      Eigen::Matrix<double, N, N> actual = b;
      internal::ldlt_solve_in_place(ldlt, &actual);
      ASSERT_EQ(std::memcmp(expected.data(), actual.data(), sizeof(double) * static_cast<std::size_t>(n * n)), 0)
          << "n " << n << ", eigenvalues over " << decades << " decades, trial " << trial << "\nEigen:\n"
          << expected << "\nours:\n"
          << actual;
    }
  }
}

// The smoother's gains must be what Eigen's LDLT::solve gives, to the bit,
// up to 4 x 4: at the fixed sizes the smoother uses (2, 3) and the others,
// and dynamically, well and badly conditioned (the pivoting order changes).
TEST(LdltSolve, IsEigensSolveBitForBitUpTo4x4) {
  expect_eigens_solve_bit_for_bit<1>(1);
  expect_eigens_solve_bit_for_bit<2>(2);
  expect_eigens_solve_bit_for_bit<3>(3);
  expect_eigens_solve_bit_for_bit<4>(4);
  for (int n = 1; n <= 4; ++n) expect_eigens_solve_bit_for_bit<Eigen::Dynamic>(n);
}

// A zero pivot is D's pseudo-inverse, as Eigen's: that row of the solution is 0.
TEST(LdltSolve, AZeroPivotGivesZeroAsEigens) {
  Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
  a(0, 0) = 4.0;
  a(1, 1) = 2.0;
  const Eigen::LDLT<Eigen::Matrix3d> ldlt(a);
  const Eigen::Matrix3d b = Eigen::Matrix3d::Constant(1.0);
  Eigen::Matrix3d actual = b;
  internal::ldlt_solve_in_place(ldlt, &actual);
  const Eigen::Matrix3d expected = ldlt.solve(b);
  EXPECT_EQ(actual, expected);
  EXPECT_EQ(actual.row(2), Eigen::RowVector3d::Zero());
  EXPECT_EQ(actual(0, 0), 0.25);
  EXPECT_EQ(actual(1, 0), 0.5);
}

}  // namespace
}  // namespace skidimm
