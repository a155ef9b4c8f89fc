#include "transposed_product.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>

namespace skidimm {
namespace {

// The predicted mode probabilities c = P' mu must be Eigen's product to the
// bit (the order of exactly tied modes depends on it), for every size: one
// mode, sizes below, at and past a packet, odd and even, and transition
// matrices whose entries span several orders of magnitude.
TEST(TransposedProduct, IsEigensMatrixVectorProductBitForBit) {
  std::mt19937_64 rng(13);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  for (int n = 1; n <= 37; ++n) {
    for (int trial = 0; trial < 20; ++trial) {
      Eigen::MatrixXd p(n, n);
      for (Eigen::Index k = 0; k < p.size(); ++k) {
        p.data()[k] = uniform(rng) * std::pow(10.0, -static_cast<int>(rng() % 6));
      }
      p.array().colwise() /= p.rowwise().sum().array();
      Eigen::VectorXd mu(n);
      for (int i = 0; i < n; ++i) mu[i] = uniform(rng) * std::pow(10.0, -static_cast<int>(rng() % 12));
      mu /= mu.sum();
      Eigen::VectorXd expected(n), actual(n);
      expected.noalias() = p.transpose() * mu;
      internal::transposed_times(p, mu, &actual);
      for (int i = 0; i < n; ++i) {
        ASSERT_EQ(std::memcmp(&actual[i], &expected[i], sizeof(double)), 0)
            << n << " modes, entry " << i << ": " << actual[i] << " against " << expected[i];
      }
    }
  }
}

}  // namespace
}  // namespace skidimm
