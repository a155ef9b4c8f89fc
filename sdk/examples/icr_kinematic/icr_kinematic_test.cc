// The plugin author's own tests, with skidimm's conformance kit.
#include <gtest/gtest.h>

#include <cmath>

#include "icr_kinematic_model.h"
#include "skidimm/sdk/testing/conformance.h"
#include "skidimm/sdk/testing/plugin_lifecycle.h"

namespace {

skidimm::sdk::ParameterSet husky_params() {
  skidimm::sdk::ParameterSet p;
  p.set_scalar("y_icr_l", 0.45);
  p.set_scalar("y_icr_r", -0.43);
  p.set_scalar("x_icr_v", 0.02);
  p.set_scalar("efficiency", 0.95);
  p.set_scalar("r", 0.165);
  return p;
}

TEST(IcrKinematic, ConformsToTheMotionModelContract) {
  std::string error;
  auto model = icr_kinematic::IcrKinematicModel::Create(husky_params(), &error);
  ASSERT_TRUE(model) << error;
  for (double theta : {0.0, 1.2, -2.9, 3.1}) {
    EXPECT_MOTION_MODEL_CONFORMS(*model, Eigen::Vector3d(2.0, -1.0, theta), Eigen::Vector2d(3.0, 6.0), 0.05);
  }
}

TEST(IcrKinematic, SymmetricIcrsAreTheIdealDifferentialDrive) {
  skidimm::sdk::ParameterSet p = husky_params();
  p.set_scalar("y_icr_l", 0.2775);
  p.set_scalar("y_icr_r", -0.2775);
  p.set_scalar("x_icr_v", 0.0);
  p.set_scalar("efficiency", 1.0);
  std::string error;
  auto model = icr_kinematic::IcrKinematicModel::Create(p, &error);
  ASSERT_TRUE(model) << error;
  Eigen::VectorXd next(3);
  ASSERT_TRUE(model->predict(Eigen::Vector3d(0, 0, 0), Eigen::Vector2d(4.0, 6.0), 0.1, next));
  EXPECT_NEAR(next[0], 0.165 * 5.0 * 0.1, 1e-15);  // v = r (phi_L + phi_R) / 2
  EXPECT_NEAR(next[1], 0.0, 1e-15);
  EXPECT_NEAR(next[2], 0.165 * 2.0 / 0.555 * 0.1, 1e-15);  // omega = r (phi_R - phi_L) / b
}

TEST(IcrKinematic, RejectsIcrsOnTheWrongSide) {
  skidimm::sdk::ParameterSet p = husky_params();
  p.set_scalar("y_icr_r", 0.4);
  std::string error;
  EXPECT_FALSE(icr_kinematic::IcrKinematicModel::Create(p, &error));
  EXPECT_NE(error.find("y_icr_r"), std::string::npos) << error;
}

TEST(IcrKinematic, SurvivesRepeatedLoadAndUnload) {
  EXPECT_PLUGIN_SURVIVES_RELOAD(ICR_PLUGIN_FILE, husky_params(), Eigen::Vector3d(1.0, 2.0, 0.5),
                                Eigen::Vector2d(3.0, 5.0), 0.02);
}

}  // namespace
