#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "core/temp_files.h"
#include "skidimm/config/bank.h"
#include "skidimm/engine/plugin_registry.h"
#include "skidimm/errors.h"
#include "skidimm/sdk/angles.h"
#include "skidimm/sdk/testing/conformance.h"
#include "skidimm/sdk/testing/plugin_lifecycle.h"

namespace skidimm {
namespace {

sdk::ParameterSet slip_params(double k, double m) {
  sdk::ParameterSet p;
  p.set_scalar("k", k);
  p.set_scalar("m", m);
  p.set_scalar("r", 0.165);
  p.set_scalar("b", 0.555);
  return p;
}

class StcKinematic : public ::testing::Test {
 protected:
  PluginRegistry registry_{{SKIDIMM_PLUGIN_DIR}};
};

TEST_F(StcKinematic, ConformsAtSeveralHeadingsIncludingTheSeam) {
  ModelHandle model = registry_.create("stc_kinematic", slip_params(0.85, 0.68));
  for (double theta : {0.0, 0.7, -2.0, 3.1, -3.14}) {
    for (double dt : {0.01, 0.1}) {
      EXPECT_MOTION_MODEL_CONFORMS(*model, Eigen::Vector3d(1.0, -2.0, theta), Eigen::Vector2d(2.0, 7.0), dt);
    }
  }
  EXPECT_TRUE(model->has_analytic_jacobian());
  EXPECT_TRUE(model->is_angle(2));
  EXPECT_FALSE(model->is_angle(0));
}

TEST_F(StcKinematic, SurvivesRepeatedLoadAndUnload) {
  EXPECT_PLUGIN_SURVIVES_RELOAD(SKIDIMM_STC_KINEMATIC_PLUGIN, slip_params(0.85, 0.68), Eigen::Vector3d(1.0, -2.0, 0.4),
                                Eigen::Vector2d(2.0, 7.0), 0.05);
}

TEST_F(StcKinematic, PredictsEquationThreeByHand) {
  ModelHandle model = registry_.create("stc_kinematic", slip_params(0.9, 0.6));
  Eigen::VectorXd next(3);
  const double theta = 0.3;
  ASSERT_TRUE(model->predict(Eigen::Vector3d(1.0, 2.0, theta), Eigen::Vector2d(4.0, 6.0), 0.1, next));
  const double u1 = 0.165 * (4.0 + 6.0) / 2.0;  // 0.825 m/s
  const double u2 = 0.165 * (6.0 - 4.0) / 0.555;
  EXPECT_NEAR(next[0], 1.0 + 0.9 * std::cos(theta) * u1 * 0.1, 1e-15);
  EXPECT_NEAR(next[1], 2.0 + 0.9 * std::sin(theta) * u1 * 0.1, 1e-15);
  EXPECT_NEAR(next[2], theta + 0.6 * u2 * 0.1, 1e-15);
}

TEST_F(StcKinematic, HeadingWrapsAcrossPi) {
  ModelHandle model = registry_.create("stc_kinematic", slip_params(1.0, 1.0));
  Eigen::VectorXd next(3);
  ASSERT_TRUE(model->predict(Eigen::Vector3d(0.0, 0.0, 3.1), Eigen::Vector2d(0.0, 10.0), 0.1, next));
  EXPECT_NEAR(next[2], sdk::wrap_angle(3.1 + 0.165 * 10.0 / 0.555 * 0.1), 1e-15);
  EXPECT_LT(next[2], 0.0);
}

TEST_F(StcKinematic, GeometryIsBankScopedAndSlipIsPerMode) {
  ModelHandle model = registry_.create("stc_kinematic", slip_params(0.9, 0.6));
  const auto& info = model->parameter_info();
  ASSERT_EQ(info.size(), 4u);
  EXPECT_EQ(info[0].scope, sdk::ParameterScope::kMode);
  EXPECT_EQ(info[2].name, "r");
  EXPECT_EQ(info[2].scope, sdk::ParameterScope::kBank);
}

TEST_F(StcKinematic, OutOfBoundsParametersAreRejected) {
  try {
    registry_.create("stc_kinematic", slip_params(-0.5, 0.6));
    FAIL();
  } catch (const std::exception& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("parameter 'k' = -0.500000 is outside [0.000000, 2.000000]"));
  }
  ModelHandle model = registry_.create("stc_kinematic", slip_params(0.9, 0.6));
  std::string error;
  EXPECT_FALSE(model->set_parameters(Eigen::Vector4d(0.9, 0.6, 0.165, 0.0), &error));
  EXPECT_THAT(error, ::testing::HasSubstr("'b'"));
}

// The error Bank::load reports for `text`, written as a bank file.
std::string bank_error(const std::string& text) {
  const std::filesystem::path file = skidimm_test::write_file(skidimm_test::test_directory() / "bank.yaml", text);
  try {
    Bank::load(file, {SKIDIMM_PLUGIN_DIR});
  } catch (const std::exception& e) {
    return e.what();
  }
  return "no error";
}

// A bank declaring [V, omega] but naming a pose model, whose Q is written
// for the model: the Q has the wrong size for the bank, but the cause is the
// states, and that is reported first.
TEST(StcKinematicBank, StatesThatAreNotTheModelsAreReportedBeforeMatrixShapes) {
  const std::string error = bank_error(R"(
name: wrong_states
states: [V, omega]
inputs: [phi_dot_L, phi_dot_R]
measurement:
  observe: [V, omega]
  R: {std: [0.05, 0.02]}
transition: {mean_dwell_time: 10.0}
initial:
  covariance: {std: [0.5, 0.5]}
shared: {r: 0.165, b: 0.555}
modes:
  - name: grip
    model: stc_kinematic
    params: {k: 0.9, m: 0.8}
    Q: {diagonal: [0.01, 0.01, 0.001]}
)");
  EXPECT_THAT(error, ::testing::HasSubstr("bank.yaml:14: modes[0].model: model stc_kinematic has states [X, Y, "
                                          "theta] but the bank declares [V, omega]"));
  EXPECT_THAT(error, ::testing::Not(::testing::HasSubstr(".Q")));
}

const char* const kTwoModes = R"(
name: slips
states: [X, Y, theta]
angles: [theta]
inputs: [phi_dot_L, phi_dot_R]
measurement:
  observe: [X, Y, theta]
  R: {std: [0.05, 0.05, 0.02]}
transition: {mean_dwell_time: 10.0}
initial:
  covariance: {std: [0.5, 0.5, 0.1]}
)";

// r and b are one value for the whole bank: missing from `shared:`, or given
// under a mode's params, the message says where they belong.
TEST(StcKinematicBank, ABankLevelParameterMissingOrGivenPerModeIsSaidToBelongUnderShared) {
  const std::string missing = bank_error(std::string(kTwoModes) + R"(shared: {r: 0.165}
modes:
  - name: grip
    model: stc_kinematic
    params: {k: 0.9, m: 0.8}
    Q: {diagonal: [0.01, 0.01, 0.001]}
)");
  EXPECT_THAT(missing, ::testing::HasSubstr("modes[0].params: mode 'grip' (model stc_kinematic)"));
  EXPECT_THAT(missing, ::testing::HasSubstr("missing parameter 'b' (a number): model stc_kinematic takes it from "
                                            "the bank's 'shared:' block"));
  const std::string per_mode = bank_error(std::string(kTwoModes) + R"(shared: {r: 0.165}
modes:
  - name: grip
    model: stc_kinematic
    params: {k: 0.9, m: 0.8, b: 0.555}
    Q: {diagonal: [0.01, 0.01, 0.001]}
  - name: slip
    model: stc_kinematic
    params: {k: 0.7, m: 0.5}
    Q: {diagonal: [0.01, 0.01, 0.001]}
)");
  EXPECT_THAT(per_mode, ::testing::HasSubstr("modes[0].params.b: 'b' is one value for the whole bank in model "
                                             "stc_kinematic: give it once under 'shared:', not per mode"));
}

}  // namespace
}  // namespace skidimm
