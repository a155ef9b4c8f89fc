#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "skidimm/plugin_registry.h"
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

}  // namespace
}  // namespace skidimm
