// A plugin that throws, returns NaN or returns false inside a step: the IMM
// rejects that mode for the step, names why, and goes on.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>

#include "core/temp_files.h"
#include "skidimm/engine/imm.h"

namespace skidimm {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

// Two [V, omega] modes: ltc_linear and faulty_model failing as `failure`
// says once |V| > 0.5 m/s.
Imm faulty_bank(const std::string& failure) {
  const fs::path bank = skidimm_test::write_file(skidimm_test::test_directory() / "bank.yaml", R"(
name: faulty
states: [V, omega]
inputs: [phi_dot_L, phi_dot_R]
measurement:
  observe: [V, omega]
  R: {std: [0.05, 0.02]}
transition: {mean_dwell_time: 10.0}
initial:
  covariance: {std: [0.5, 0.5]}
modes:
  - name: good
    model: ltc_linear
    params: {A: [[-5, 0], [0, -4]], B: [[0.39, 0.39], [-0.83, 0.83]]}
    Q: {diagonal: [0.01, 0.01]}
  - name: broken
    model: faulty_model
    params: {failure: )" + failure + R"(, above: 0.5}
    Q: {diagonal: [0.01, 0.01]}
)");
  return Imm::from_yaml(bank, {SKIDIMM_PLUGIN_DIR, fs::path(SKIDIMM_TEST_PLUGIN_ROOT) / "faulty"});
}

// Steps at V = 0.2 (fine) and then V = 1 (the broken mode fails).
const ImmEstimate& two_steps(Imm* imm) {
  const Eigen::Vector2d u(1.0, 1.0);
  const ImmEstimate& first = imm->step(0.0, u, Eigen::Vector2d(0.2, 0.0));
  EXPECT_EQ(first.num_rejected_modes, 0);
  EXPECT_EQ(first.mode_failures, (std::vector<ModeFailure>{ModeFailure::kNone, ModeFailure::kNone}));
  imm->step(0.01, u, Eigen::Vector2d(1.0, 0.0));  // predicts from 0.2: still fine
  return imm->step(0.02, u, Eigen::Vector2d(1.0, 0.0));
}

TEST(PluginFailure, AnExceptionInPredictRejectsTheModeWithTheExceptionsText) {
  Imm imm = faulty_bank("predict_throws");
  const ImmEstimate& e = two_steps(&imm);
  EXPECT_EQ(e.num_rejected_modes, 1);
  EXPECT_EQ(e.mode_failures[0], ModeFailure::kNone);
  EXPECT_EQ(e.mode_failures[1], ModeFailure::kModel);
  EXPECT_THAT(e.failure_reasons[1], HasSubstr("predict_fixed() threw: vector::_M_range_check"));
  EXPECT_EQ(e.most_likely_mode, 0);
  EXPECT_TRUE(e.state.allFinite());
}

TEST(PluginFailure, ExceptionsInTheJacobianAndTheNoiseAreNamedToo) {
  Imm jacobian = faulty_bank("jacobian_throws");
  EXPECT_EQ(two_steps(&jacobian).failure_reasons[1], "jacobian_fixed() threw: no Jacobian here");
  Imm noise = faulty_bank("noise_throws");
  EXPECT_EQ(two_steps(&noise).failure_reasons[1], "process_noise_fixed() threw: noise table missing");
}

TEST(PluginFailure, NaNFalseAndSilentFalseAreToldApart) {
  Imm nan = faulty_bank("nan");
  EXPECT_EQ(two_steps(&nan).mode_failures[1], ModeFailure::kNotFinite);
  Imm reported = faulty_bank("false");
  const ImmEstimate& r = two_steps(&reported);
  EXPECT_EQ(r.mode_failures[1], ModeFailure::kModel);
  EXPECT_EQ(r.failure_reasons[1], "the slip ratio is undefined at this speed");
  Imm silent = faulty_bank("silent_false");
  const ImmEstimate& s = two_steps(&silent);
  EXPECT_EQ(s.mode_failures[1], ModeFailure::kModel);
  EXPECT_THAT(s.failure_reasons[1], HasSubstr("returned false without a reason"));
}

TEST(PluginFailure, TheFailureIsClearedOnTheNextGoodStep) {
  Imm imm = faulty_bank("predict_throws");
  two_steps(&imm);
  const Eigen::Vector2d u(1.0, 1.0);
  // Back below 0.5 m/s the mode restarts from the combined estimate and predicts again.
  imm.step(0.03, u, Eigen::Vector2d(0.1, 0.0));
  imm.step(0.04, u, Eigen::Vector2d(0.1, 0.0));
  imm.step(0.05, u, Eigen::Vector2d(0.1, 0.0));
  const ImmEstimate& e = imm.step(0.06, u, Eigen::Vector2d(0.1, 0.0));
  EXPECT_EQ(e.mode_failures[1], ModeFailure::kNone);
  EXPECT_EQ(e.num_rejected_modes, 0);
}

}  // namespace
}  // namespace skidimm
