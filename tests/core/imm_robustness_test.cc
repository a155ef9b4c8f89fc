// The IMM under outliers and divergence: the innovation gate, the
// reset of a diverged mode filter, the exact probability floor, and the
// guarantee that no output state is non-finite and no variance negative.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>
#include <vector>

#include "sanitizer.h"
#include "skidimm/engine/imm.h"
#include "test_banks.h"

namespace {

using skidimm::Imm;
using skidimm::ImmEstimate;
using skidimm::ModeFailure;
using skidimm::StepStatus;
using skidimm_test::BankBuilder;
using skidimm_test::make_ltc;
using skidimm_test::ScalarLinearModel;
using skidimm_test::vec;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Two scalar modes that predict differently under a large input.
BankBuilder scalar_bank() {
  BankBuilder b;
  b.models = {std::make_shared<ScalarLinearModel>(-1.0, 1.0), std::make_shared<ScalarLinearModel>(-2.0, 0.5)};
  b.q = {Eigen::MatrixXd::Constant(1, 1, 1e-4)};
  b.r = Eigen::MatrixXd::Constant(1, 1, 0.01);
  b.x0 = vec({0.0});
  b.p0 = Eigen::MatrixXd::Constant(1, 1, 1.0);
  return b;
}

// Two LTC modes over [V, omega], both measured, as the bundled terrain banks.
BankBuilder ltc_bank() {
  BankBuilder b;
  b.states = {"V", "omega"};
  b.angles = {false, false};
  b.inputs = {"phi_dot_L", "phi_dot_R"};
  Eigen::Matrix2d a1, b1, a2, b2;
  a1 << -5, 0, 0, -4;
  b1 << 0.4, 0.4, -0.8, 0.8;
  a2 << -2, 0, 0, -1;
  b2 << 0.1, 0.1, -0.2, 0.2;
  b.models = {make_ltc(a1, b1), make_ltc(a2, b2)};
  b.q = {Eigen::Matrix2d::Identity() * 0.01};
  b.r = Eigen::Vector2d(0.0025, 0.0009).asDiagonal();
  return b;
}

// What expect_sound() checks, without building a message: for the loops
// over millions of steps, which report through expect_sound() on a failure.
bool is_sound(const ImmEstimate& e) {
  bool sound = e.state.allFinite() && e.covariance.allFinite() && e.covariance.diagonal().minCoeff() >= 0.0 &&
               std::abs(e.mode_probabilities.sum() - 1.0) <= 1e-12 && e.mode_probabilities.allFinite();
  for (std::size_t j = 0; j < e.mode_states.size(); ++j) {
    sound = sound && e.mode_states[j].allFinite() && e.mode_covariances[j].allFinite() &&
            e.mode_covariances[j].diagonal().minCoeff() >= 0.0;
  }
  return sound;
}

void expect_sound(const ImmEstimate& e, const std::string& where) {
  EXPECT_TRUE(e.state.allFinite()) << where << ": state " << e.state.transpose();
  EXPECT_TRUE(e.covariance.allFinite()) << where;
  EXPECT_GE(e.covariance.diagonal().minCoeff(), 0.0) << where << ": variances " << e.covariance.diagonal().transpose();
  for (std::size_t j = 0; j < e.mode_states.size(); ++j) {
    EXPECT_TRUE(e.mode_states[j].allFinite()) << where << ", mode " << j;
    EXPECT_TRUE(e.mode_covariances[j].allFinite()) << where << ", mode " << j;
    EXPECT_GE(e.mode_covariances[j].diagonal().minCoeff(), 0.0) << where << ", mode " << j;
  }
  EXPECT_NEAR(e.mode_probabilities.sum(), 1.0, 1e-12) << where;
  EXPECT_TRUE(e.mode_probabilities.allFinite()) << where;
}

TEST(ImmRobustness, GateAtTwoComponentsIsTheChiSquareQuantile) {
  // First step: no prediction, x = 0, P = I, R = I, so S = 2 I and a
  // measurement (a, 0) has NIS a^2 / 2. chi2(2 dof) is exponential with mean
  // 2: its 0.9999 quantile is -2 ln(1e-4) = 18.420680743952367, the gate at
  // a = 6.0697.
  BankBuilder b = ltc_bank();
  b.r = Eigen::Matrix2d::Identity();
  b.p0 = Eigen::Matrix2d::Identity();
  skidimm::Bank bank = b.build();
  bank.config.innovation_gate = 0.9999;
  Imm below(bank);
  const ImmEstimate& in = below.step(0.0, vec({0, 0}), vec({6.06, 0.0}));
  EXPECT_EQ(in.status, StepStatus::kUpdated);
  EXPECT_NEAR(in.nis[0], 6.06 * 6.06 / 2.0, 1e-12);
  EXPECT_NEAR(in.state[0], 3.03, 1e-12);  // K = 1/2

  Imm above(bank);
  const ImmEstimate& out = above.step(0.0, vec({0, 0}), vec({6.08, 0.0}));
  EXPECT_EQ(out.status, StepStatus::kGated);
  EXPECT_EQ(out.num_gated_modes, 2);
  EXPECT_EQ(out.mode_failures[0], ModeFailure::kGated);
  EXPECT_EQ(out.state[0], 0.0);  // not applied
  EXPECT_EQ(out.covariance(0, 0), 1.0);
  // Treated as predict-only: the prior probabilities stand.
  EXPECT_DOUBLE_EQ(out.mode_probabilities[0], 0.5);
}

TEST(ImmRobustness, AnOutlierEveryModeGatesLeavesTheStepAsIfUnmeasured) {
  skidimm::Bank bank = scalar_bank().build();
  bank.config.innovation_gate = 0.9999;
  Imm gated(bank), missing(bank);
  for (Imm* imm : {&gated, &missing}) {
    imm->step(0.0, vec({1.0}), vec({0.0}));
    imm->step(0.1, vec({1.0}), vec({0.1}));
  }
  const ImmEstimate& g = gated.step(0.2, vec({1.0}), vec({1e6}));
  const ImmEstimate& m = missing.step(0.2, vec({1.0}), vec({kNaN}));
  EXPECT_EQ(g.status, StepStatus::kGated);
  EXPECT_EQ(m.status, StepStatus::kPredictOnly);
  EXPECT_EQ(g.state[0], m.state[0]);
  EXPECT_EQ(g.covariance(0, 0), m.covariance(0, 0));
  EXPECT_EQ(g.mode_probabilities, m.mode_probabilities);
  EXPECT_GT(g.nis[0], 1e12);
  // The next measurement is applied again.
  EXPECT_EQ(gated.step(0.3, vec({1.0}), vec({0.2})).status, StepStatus::kUpdated);
}

TEST(ImmRobustness, AModeThatGatesScoresAtItsBoundaryAndNeverAboveTheWorstModeThatApplied) {
  // Under u = 10 for 1 s, mode 0 predicts about 10 and mode 1 about 5; z = 10
  // fits mode 0 and is far outside mode 1's gate (S about 0.01).
  skidimm::Bank bank = scalar_bank().build();
  bank.config.innovation_gate = 0.99;
  Imm imm(bank);
  imm.step(0.0, vec({10.0}), vec({0.0}));
  Imm reference(bank);  // the same step unmeasured: mode 1's predicted state
  reference.step(0.0, vec({10.0}), vec({0.0}));
  const ImmEstimate& unmeasured = reference.step(1.0, vec({10.0}), vec({kNaN}));
  const double predicted_1 = unmeasured.mode_states[1][0];
  const double predicted_1_variance = unmeasured.mode_covariances[1](0, 0);

  const ImmEstimate& e = imm.step(1.0, vec({10.0}), vec({10.0}));
  ASSERT_EQ(e.status, StepStatus::kModeGated);
  EXPECT_EQ(e.num_gated_modes, 1);
  EXPECT_EQ(e.mode_failures[0], ModeFailure::kNone);
  EXPECT_EQ(e.mode_failures[1], ModeFailure::kGated);
  EXPECT_EQ(e.mode_states[1][0], predicted_1);  // left as predicted
  // Hand computation: S = P- + R, the boundary -1/2 (gamma + log(2 pi S)),
  // gamma the chi2(1) 0.99 quantile 6.634896601021214.
  const double s = predicted_1_variance + 0.01;
  const double nu = 10.0 - predicted_1;
  EXPECT_NEAR(e.nis[1], nu * nu / s, 1e-9 * nu * nu / s);
  const double boundary = -0.5 * (6.634896601021214 + std::log(2.0 * M_PI * s));
  EXPECT_NEAR(e.log_likelihoods[1], std::min(boundary, e.log_likelihoods[0]), 1e-9);
  EXPECT_LE(e.log_likelihoods[1], e.log_likelihoods[0]);
  EXPECT_GT(e.mode_probabilities[0], e.mode_probabilities[1]);
}

TEST(ImmRobustness, WithoutAGateEveryOutlierMagnitudeLeavesEveryOutputSound) {
  // Under the sanitizers (scripts/check.sh) every tenth magnitude and the
  // last ones before overflow, where undefined behaviour would be: the same
  // code paths, a tenth of the steps (the whole sweep was a tenth of the
  // sanitizer suite's time). The Release suite sweeps them all.
  std::vector<int> exponents;
  for (int exponent = 6; exponent <= 308; exponent += 2) {
    if (!SKIDIMM_SANITIZED || exponent % 20 == 6 || exponent >= 300) exponents.push_back(exponent);
  }
  for (const skidimm::ImmKernelChoice kernel :
       {skidimm::ImmKernelChoice::kFastest, skidimm::ImmKernelChoice::kDynamic}) {
    for (const int exponent : exponents) {
      for (const double sign : {1.0, -1.0}) {
        const double outlier = sign * std::pow(10.0, exponent);
        const std::string where = "outlier " + std::to_string(outlier) + ", kernel " + std::to_string(int(kernel));
        Imm imm(ltc_bank().build(), kernel);
        Imm clean(ltc_bank().build(), kernel);
        double last_error = 0.0;
        for (int k = 0; k < 1500; ++k) {
          const double t = 0.02 * k;
          const Eigen::VectorXd u = vec({3.0 + std::sin(0.01 * k), 3.5});
          const Eigen::VectorXd z = vec({0.3 + 0.1 * std::sin(0.05 * k), 0.1 + 0.05 * std::cos(0.03 * k)});
          Eigen::VectorXd measured = z;
          if (k == 100) measured[0] = outlier;
          const ImmEstimate& e = imm.step(t, u, measured);
          if (!is_sound(e)) {
            expect_sound(e, where + ", step " + std::to_string(k));
            ADD_FAILURE() << where << ", step " << k << ": not sound";
            return;
          }
          last_error = (e.state - clean.step(t, u, z).state).cwiseAbs().maxCoeff();
        }
        // Recovered: back on the run without the outlier by the end.
        EXPECT_LT(last_error, 1e-9) << where;
      }
    }
  }
}

TEST(ImmRobustness, A1e150OutlierMakesEveryModeDivergeAndTheNextStepsRunNormally) {
  Imm imm(ltc_bank().build());
  const Eigen::VectorXd u = vec({3.0, 3.5});
  Eigen::VectorXd before;
  for (int k = 0; k < 50; ++k) before = imm.step(0.02 * k, u, vec({0.3, 0.1})).state;
  const ImmEstimate& e = imm.step(1.0, u, vec({1e150, 0.1}));
  EXPECT_EQ(e.status, StepStatus::kAllModesRejected);
  EXPECT_EQ(e.mode_failures[0], ModeFailure::kDiverged);
  EXPECT_EQ(e.mode_failures[1], ModeFailure::kDiverged);
  EXPECT_EQ(e.num_rejected_modes, 2);
  expect_sound(e, "the outlier's step");
  EXPECT_LT(std::abs(e.state[0] - before[0]), 1.0);  // restarted from the last combined estimate
  for (int k = 1; k <= 3; ++k) {
    EXPECT_EQ(imm.step(1.0 + 0.02 * k, u, vec({0.3, 0.1})).status, StepStatus::kUpdated) << "step " << k;
  }
}

// A model that blows up: x_next = 1e150 x + 1.
class ExplodingModel : public skidimm::sdk::SizedMotionModel<1, 1> {
 public:
  const std::vector<std::string>& state_names() const noexcept override { return states_; }
  const std::vector<std::string>& input_names() const noexcept override { return inputs_; }
  const std::vector<skidimm::sdk::ParameterInfo>& parameter_info() const noexcept override { return info_; }
  void get_parameters(Eigen::Ref<Eigen::VectorXd>) const noexcept override {}
  bool set_parameters(const Eigen::Ref<const Eigen::VectorXd>&, std::string*) noexcept override { return true; }
  bool predict_fixed(const State& x, const Input&, double, State* next) const override {
    (*next)[0] = 1e150 * x[0] + 1.0;
    return true;
  }
  bool jacobian_fixed(const State&, const Input&, double, Jacobian* j) const override {
    (*j)(0, 0) = 1e150;
    return true;
  }
  bool has_analytic_jacobian() const noexcept override { return true; }

 private:
  const std::vector<std::string> states_{"x"};
  const std::vector<std::string> inputs_{"u"};
  const std::vector<skidimm::sdk::ParameterInfo> info_{};
};

TEST(ImmRobustness, ADivergingModelIsResetAndReportedWhileTheOtherModeRuns) {
  BankBuilder b = scalar_bank();
  b.models[1] = std::make_shared<ExplodingModel>();
  Imm imm(b.build());
  int resets = 0;
  for (int k = 0; k < 199; ++k) {  // ends on a measured row
    // Every other row unmeasured: no update can pull the exploded mode back.
    const ImmEstimate& e = imm.step(0.1 * k, vec({1.0}), vec({k % 2 ? kNaN : 0.5}));
    expect_sound(e, "step " + std::to_string(k));
    if (k > 0 && k % 2 == 1) {
      EXPECT_EQ(e.status, StepStatus::kModeReset) << "step " << k;
    }
    if (e.status == StepStatus::kModeReset) {
      ++resets;
      EXPECT_EQ(e.mode_failures[0], ModeFailure::kNone);
      EXPECT_NE(e.mode_failures[1], ModeFailure::kNone);
    }
  }
  EXPECT_GE(resets, 99);
  EXPECT_GT(imm.estimate().mode_probabilities[0], 0.99);
  // Mode 0 (x' = -x + u) settles between its equilibrium 1 and the measured 0.5.
  EXPECT_GT(imm.estimate().state[0], 0.4);
  EXPECT_LT(imm.estimate().state[0], 1.1);
}

TEST(ImmRobustness, TheProbabilityFloorIsALowerBoundAfterRenormalisation) {
  // Three modes, floor 0.333: a decisive measurement leaves the two losing
  // modes at exactly the floor and the winner at 1 - 2 x 0.333 = 0.334 (the
  // old rule, max(mu, floor) / sum, gave 0.2).
  BankBuilder b = scalar_bank();
  b.models.push_back(std::make_shared<ScalarLinearModel>(-4.0, 0.1));
  b.floor = 0.333;
  Imm imm(b.build());
  imm.step(0.0, vec({10.0}), vec({0.0}));
  const ImmEstimate& e = imm.step(1.0, vec({10.0}), vec({9.0}));  // mode 0 predicts about 9
  EXPECT_EQ(e.most_likely_mode, 0);
  EXPECT_DOUBLE_EQ(e.mode_probabilities[1], 0.333);
  EXPECT_DOUBLE_EQ(e.mode_probabilities[2], 0.333);
  EXPECT_NEAR(e.mode_probabilities[0], 0.334, 1e-15);
  EXPECT_GE(e.mode_probabilities.minCoeff(), 0.333);

  // Any floor below 1/N, through steps of every kind of evidence: every
  // probability ends at or above it.
  b.floor = 0.3;
  Imm second(b.build());
  for (int k = 0; k < 50; ++k) {
    const ImmEstimate& s = second.step(0.1 * k, vec({10.0}), vec({0.5 * k}));
    EXPECT_GE(s.mode_probabilities.minCoeff(), 0.3) << "step " << k;
    EXPECT_NEAR(s.mode_probabilities.sum(), 1.0, 1e-14);
  }
}

}  // namespace
