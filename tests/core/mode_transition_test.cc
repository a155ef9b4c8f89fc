#include "skidimm/mode_transition.h"

#include <gtest/gtest.h>

#include <unsupported/Eigen/MatrixFunctions>

namespace skidimm {
namespace {

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

TEST(ModeTransition, SingleModeIsAlwaysIdentity) {
  ModeTransition t = ModeTransition::from_dwell_times(Eigen::VectorXd::Constant(1, 3.0));
  EXPECT_EQ(t.matrix(1.0)(0, 0), 1.0);
}

}  // namespace
}  // namespace skidimm
