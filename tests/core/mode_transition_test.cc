#include "skidimm/engine/mode_transition.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>
#include <unsupported/Eigen/MatrixFunctions>
#include <vector>

namespace skidimm {
namespace {

// The implementation this one replaced, kept to pin the
// new one to it: uniformisation with scaling and squaring, O(N^3) for every
// new dt.
Eigen::MatrixXd original_uniformisation(const Eigen::MatrixXd& generator, double dt) {
  const Eigen::Index n = generator.rows();
  const double max_rate = (-generator.diagonal()).maxCoeff();
  Eigen::MatrixXd matrix = Eigen::MatrixXd::Identity(n, n);
  if (n == 1 || max_rate == 0.0 || dt <= 0.0) return matrix;
  const Eigen::MatrixXd jump = Eigen::MatrixXd::Identity(n, n) + generator / max_rate;
  int squarings = 0;
  double h = dt;
  while (max_rate * h > 0.5) {
    h *= 0.5;
    ++squarings;
  }
  const double lambda = max_rate * h;
  double weight = std::exp(-lambda);
  double accumulated = weight;
  matrix *= weight;
  Eigen::MatrixXd power = Eigen::MatrixXd::Identity(n, n);
  for (int k = 1; k < 64 && 1.0 - accumulated > 1e-17; ++k) {
    power = (power * jump).eval();
    weight *= lambda / k;
    accumulated += weight;
    matrix += weight * power;
  }
  for (int s = 0; s < squarings; ++s) matrix = (matrix * matrix).eval();
  for (Eigen::Index i = 0; i < n; ++i) matrix.row(i) /= matrix.row(i).sum();
  return matrix;
}

// Steps as logs have them: a nominal rate with jitter in the last digits,
// merged sensors, and gaps.
std::vector<double> irregular_steps() {
  std::vector<double> steps;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> jitter(-1.0, 1.0);
  for (int k = 0; k < 200; ++k) steps.push_back(0.01 + 1e-6 * jitter(rng));  // text-log rounding
  for (int k = 0; k < 200; ++k) steps.push_back(0.02 * (1.0 + 0.3 * jitter(rng)));  // jittered sensor
  for (int k = 0; k < 50; ++k) steps.push_back(k % 3 == 0 ? 0.0035 : k % 3 == 1 ? 0.0065 : 0.154);  // merged files
  for (double gap : {0.4, 1.3, 7.5, 30.0, 100.0, 1000.0, 1e5, 0.01, 0.0100001, 2.0, 0.01}) steps.push_back(gap);
  return steps;
}

TEST(ModeTransition, StaySpreadsTheRestEvenly) {
  ModeTransition t = ModeTransition::per_step_stay(4, 0.91);
  const Eigen::MatrixXd& m = t.matrix(0.5);
  EXPECT_DOUBLE_EQ(m(2, 2), 0.91);
  EXPECT_DOUBLE_EQ(m(2, 0), 0.03);
  EXPECT_FALSE(t.is_continuous());
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(m.row(i).sum(), 1.0, 1e-15);
}

TEST(ModeTransition, PerStepMatrixIgnoresDt) {
  Eigen::MatrixXd p(2, 2);
  p << 0.7, 0.3, 0.4, 0.6;
  ModeTransition t = ModeTransition::per_step(p);
  EXPECT_EQ(t.matrix(0.01), p);
  EXPECT_EQ(t.matrix(10.0), p);
}

TEST(ModeTransition, DwellTimesMatchEigensMatrixExponential) {
  Eigen::VectorXd dwell(4);
  dwell << 2.0, 5.0, 0.5, 30.0;
  ModeTransition t = ModeTransition::from_dwell_times(dwell);
  ASSERT_TRUE(t.is_continuous());
  for (double dt : {1e-4, 0.01, 0.1, 1.0, 7.5, 100.0}) {
    const Eigen::MatrixXd expected = (t.generator() * dt).exp();  // Pade, an independent method
    const Eigen::MatrixXd& actual = t.matrix(dt);
    EXPECT_TRUE(actual.isApprox(expected, 1e-12)) << "dt = " << dt << "\n" << actual << "\nvs\n" << expected;
    for (int i = 0; i < 4; ++i) EXPECT_NEAR(actual.row(i).sum(), 1.0, 1e-14);
    EXPECT_GE(actual.minCoeff(), 0.0);
  }
}

TEST(ModeTransition, GeneratorLeavesEachModeAtItsRateSpreadEvenly) {
  Eigen::VectorXd dwell(3);
  dwell << 2.0, 4.0, 8.0;
  ModeTransition t = ModeTransition::from_dwell_times(dwell);
  EXPECT_DOUBLE_EQ(t.generator()(0, 0), -0.5);
  EXPECT_DOUBLE_EQ(t.generator()(0, 2), 0.25);
  EXPECT_DOUBLE_EQ(t.generator()(2, 1), 0.0625);
  // Staying probability over a short step is about 1 - dt / tau.
  EXPECT_NEAR(t.matrix(0.001)(1, 1), 1.0 - 0.001 / 4.0, 1e-6);
}

TEST(ModeTransition, EqualDwellTimesUseTheClosedFormAndAgreeWithExpm) {
  ModeTransition t = ModeTransition::from_dwell_times(Eigen::VectorXd::Constant(16, 10.0));
  for (double dt : {0.02, 0.3, 25.0}) {
    EXPECT_TRUE(t.matrix(dt).isApprox((t.generator() * dt).exp(), 1e-12)) << "dt = " << dt;
  }
}

TEST(ModeTransition, IsASemigroupSoIrregularStepsKeepTheStatistics) {
  Eigen::VectorXd dwell(3);
  dwell << 1.0, 3.0, 9.0;
  ModeTransition t = ModeTransition::from_dwell_times(dwell);
  const Eigen::MatrixXd one = t.matrix(0.013);
  const Eigen::MatrixXd two = t.matrix(0.026);
  EXPECT_TRUE(two.isApprox(one * one, 1e-13));
}

// Per-mode dwell times: O(N^2) per new dt (anchors and a Taylor correction,
// eigenvectors past 50 expected jumps); the matrix and its transposed product
// agree with the original uniformisation to 1e-12 on every step of an
// irregular log, from jittered 10 ms steps to a day-long gap.
TEST(ModeTransition, PerModeDwellTimesMatchTheOriginalUniformisationOnIrregularSteps) {
  Eigen::VectorXd dwell(6);
  dwell << 2.0, 5.0, 0.5, 30.0, 10.0, 7.0;
  ModeTransition t = ModeTransition::from_dwell_times(dwell);
  ModeTransition fresh = ModeTransition::from_dwell_times(dwell);
  t.reserve_columns(3);
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  Eigen::MatrixXd in(6, 3), out(6, 3);
  double worst_matrix = 0.0, worst_product = 0.0;
  for (double dt : irregular_steps()) {
    const Eigen::MatrixXd expected = original_uniformisation(t.generator(), dt);
    for (int i = 0; i < in.size(); ++i) in.data()[i] = uniform(rng);
    t.propagate(dt, in, out);
    worst_product = std::max(worst_product, (out - expected.transpose() * in).cwiseAbs().maxCoeff());
    const Eigen::MatrixXd& actual = fresh.matrix(dt);
    worst_matrix = std::max(worst_matrix, (actual - expected).cwiseAbs().maxCoeff());
    ASSERT_LT((actual - expected).cwiseAbs().maxCoeff(), 1e-12) << "dt = " << dt;
    for (int i = 0; i < 6; ++i) ASSERT_NEAR(actual.row(i).sum(), 1.0, 1e-13) << "dt = " << dt;
  }
  EXPECT_LT(worst_product, 1e-12);
  // Not just within tolerance: close to round-off.
  EXPECT_LT(worst_matrix, 1e-14);
}

// A few modes and more columns than modes (4 STC modes carry 10 moments
// each): the series then runs on P(dt)' before the product instead of on the
// columns, and must agree as closely on the same irregular log.
TEST(ModeTransition, FewModesWithManyColumnsMatchTheOriginalUniformisationOnIrregularSteps) {
  Eigen::VectorXd dwell(4);
  dwell << 5.0, 0.7, 20.0, 12.0;
  ModeTransition t = ModeTransition::from_dwell_times(dwell);
  t.reserve_columns(10);
  std::mt19937 rng(6);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  Eigen::MatrixXd in(4, 10), out(4, 10);
  double worst = 0.0;
  for (double dt : irregular_steps()) {
    const Eigen::MatrixXd expected = original_uniformisation(t.generator(), dt);
    for (int i = 0; i < in.size(); ++i) in.data()[i] = uniform(rng);
    t.propagate(dt, in, out);
    const double error = (out - expected.transpose() * in).cwiseAbs().maxCoeff();
    ASSERT_LT(error, 1e-12) << "dt = " << dt;
    worst = std::max(worst, error);
  }
  EXPECT_LT(worst, 1e-14);
}

// Dwell times of seconds and steps of tens of milliseconds (||Pi_c dt|| up to
// 0.01): the series from the identity, no anchor; longer steps of the same
// log take the anchors or the eigenvectors in between, and each path must
// pick up where the others left off.
TEST(ModeTransition, PerModeDwellTimesOnShortStepsMatchTheOriginalUniformisation) {
  ModeTransition t = ModeTransition::from_dwell_times(Eigen::VectorXd::LinSpaced(12, 5.0, 20.0));
  ModeTransition fresh = ModeTransition::from_dwell_times(Eigen::VectorXd::LinSpaced(12, 5.0, 20.0));
  t.reserve_columns(6);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  Eigen::MatrixXd in(12, 6), out(12, 6);
  int short_steps = 0;
  for (double dt : irregular_steps()) {
    if (2.0 * 0.2 * dt <= 0.01) ++short_steps;
    const Eigen::MatrixXd expected = original_uniformisation(t.generator(), dt);
    for (int i = 0; i < in.size(); ++i) in.data()[i] = uniform(rng);
    t.propagate(dt, in, out);
    ASSERT_LT((out - expected.transpose() * in).cwiseAbs().maxCoeff(), 1e-14) << "dt = " << dt;
    const Eigen::MatrixXd& actual = fresh.matrix(dt);
    ASSERT_LT((actual - expected).cwiseAbs().maxCoeff(), 1e-14) << "dt = " << dt;
    for (int i = 0; i < 12; ++i) ASSERT_NEAR(actual.row(i).sum(), 1.0, 1e-14) << "dt = " << dt;
  }
  EXPECT_GT(short_steps, 300);
}

TEST(ModeTransition, PerModeDwellTimesMatchEigensExponentialPastTheUniformisationRange) {
  Eigen::VectorXd dwell(5);
  dwell << 0.2, 0.3, 1.0, 4.0, 20.0;  // the fastest mode: 5 jumps/s, so dt > 10 s takes the eigenvectors
  ModeTransition t = ModeTransition::from_dwell_times(dwell);
  for (double dt : {9.0, 11.0, 40.0, 250.0}) {
    const Eigen::MatrixXd expected = (t.generator() * dt).exp();
    EXPECT_LT((t.matrix(dt) - expected).cwiseAbs().maxCoeff(), 1e-12) << "dt = " << dt;
  }
}

TEST(ModeTransition, PropagateIsTheTransposedMatrixTimesItsInputForEveryForm) {
  Eigen::MatrixXd p(3, 3);
  p << 0.8, 0.15, 0.05, 0.1, 0.7, 0.2, 0.0, 0.3, 0.7;
  std::vector<ModeTransition> forms = {ModeTransition::per_step(p), ModeTransition::per_step_stay(3, 0.9),
                                       ModeTransition::from_dwell_times(Eigen::Vector3d(4.0, 4.0, 4.0)),
                                       ModeTransition::from_dwell_times(Eigen::Vector3d(1.0, 4.0, 9.0))};
  const Eigen::MatrixXd in = Eigen::MatrixXd::Random(3, 7);
  Eigen::MatrixXd out(3, 7);
  for (ModeTransition& t : forms) {
    t.reserve_columns(7);
    for (double dt : {0.01, 0.0137, 0.5, 0.01, 60.0}) {
      t.propagate(dt, in, out);
      const Eigen::MatrixXd expected = t.matrix(dt).transpose() * in;
      EXPECT_LT((out - expected).cwiseAbs().maxCoeff(), 1e-14) << "dt = " << dt;
    }
  }
}

// From 16 modes on, a per-step matrix's product (and every anchor's of the
// per-mode dwell times) takes several columns at a time; each entry must
// still be Eigen's dot product of a column of P with a column of the input,
// bit for bit, as before, so published results stay exactly reproduced.
TEST(ModeTransition, ManyModesPropagateIsEigensDotProductBitForBit) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  for (int n : {16, 17, 19, 31, 64, 101}) {
    Eigen::MatrixXd p(n, n);
    for (Eigen::Index k = 0; k < p.size(); ++k) {
      p.data()[k] = uniform(rng) * std::pow(10.0, -static_cast<int>(rng() % 6));
    }
    p.array().colwise() /= p.rowwise().sum().array();  // rows sum to 1
    for (int columns : {1, 4, 6, 7, 10}) {
      ModeTransition t = ModeTransition::per_step(p);
      t.reserve_columns(columns);
      // A block of a larger matrix, as the IMM passes its moments.
      Eigen::MatrixXd whole = Eigen::MatrixXd::Random(n + 2, columns + 1);
      whole.col(1).setZero();
      const Eigen::Ref<const Eigen::MatrixXd> in = whole.block(1, 1, n, columns);
      Eigen::MatrixXd out(n, columns);
      t.propagate(0.01, in, out);
      for (Eigen::Index j = 0; j < n; ++j) {
        for (Eigen::Index c = 0; c < columns; ++c) {
          const double expected = p.col(j).dot(in.col(c));
          ASSERT_EQ(std::memcmp(&out(j, c), &expected, sizeof(double)), 0)
              << n << " modes, column " << c << ": " << out(j, c) << " against " << expected;
        }
      }
    }
  }
}

// Equal dwell times: row j of P(dt)' x is e x_j + (1 - e)/N sum_i x_i, each
// column's sum exactly as Eigen's sum() of the column gives it (its order
// depends on where the column starts in memory), as the engine always
// computed it, so published results stay exactly reproduced.
TEST(ModeTransition, EqualDwellTimesPropagateIsTheClosedFormWithEigensSumBitForBit) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  for (int n = 2; n <= 37; ++n) {
    const double dwell = 0.5 + 20.0 * uniform(rng);
    ModeTransition t = ModeTransition::from_dwell_times(Eigen::VectorXd::Constant(n, dwell));
    for (int columns : {1, 6, 10}) {
      t.reserve_columns(columns);
      for (int offset = 0; offset < 4; ++offset) {
        Eigen::MatrixXd whole(n + 4, columns + 1);
        for (Eigen::Index k = 0; k < whole.size(); ++k) {
          whole.data()[k] = uniform(rng) * std::pow(10.0, -static_cast<int>(rng() % 8));
        }
        const Eigen::Ref<const Eigen::MatrixXd> in = whole.block(offset, 1, n, columns);
        Eigen::MatrixXd out(n, columns);
        const double dt = 0.01 * (1.0 + 0.1 * uniform(rng));
        t.propagate(dt, in, out);
        const double nn = static_cast<double>(n);
        const double decay = std::exp(-(1.0 / dwell) * nn / (nn - 1.0) * dt);
        const double spread = (1.0 - decay) / nn;
        for (Eigen::Index c = 0; c < columns; ++c) {
          const double total = spread * in.col(c).sum();
          for (Eigen::Index i = 0; i < n; ++i) {
            const double expected = decay * in(i, c) + total;
            ASSERT_EQ(std::memcmp(&out(i, c), &expected, sizeof(double)), 0)
                << n << " modes, offset " << offset << ", column " << c << ": " << out(i, c) << " against "
                << expected;
          }
        }
      }
    }
  }
}

// Larger banks, where the old implementation's N^3 per new dt hurt: 64
// modes, every step a slightly different dt.
TEST(ModeTransition, SixtyFourModesWithJitteredStepsMatchTheOriginal) {
  ModeTransition t = ModeTransition::from_dwell_times(Eigen::VectorXd::LinSpaced(64, 1.0, 40.0));
  t.reserve_columns(10);
  const Eigen::MatrixXd in = Eigen::MatrixXd::Random(64, 10).cwiseAbs();
  Eigen::MatrixXd out(64, 10);
  for (int k = 0; k < 20; ++k) {
    const double dt = 0.01 * (1.0 + 0.1 * std::sin(0.37 * k));
    t.propagate(dt, in, out);
    const Eigen::MatrixXd expected = original_uniformisation(t.generator(), dt).transpose() * in;
    ASSERT_LT((out - expected).cwiseAbs().maxCoeff(), 1e-12) << "step " << k;
  }
}

TEST(ModeTransition, SingleModeIsAlwaysIdentity) {
  ModeTransition t = ModeTransition::from_dwell_times(Eigen::VectorXd::Constant(1, 3.0));
  EXPECT_EQ(t.matrix(1.0)(0, 0), 1.0);
}

}  // namespace
}  // namespace skidimm
