// The plugin author's tests: the built plugin file, loaded as skidimm loads
// it, checked over the region where the model will be used.
#include <gtest/gtest.h>

#include "skidimm/sdk/testing/conformance.h"
#include "skidimm/sdk/testing/load_plugin_model.h"
#include "skidimm/sdk/testing/plugin_lifecycle.h"

namespace {

using skidimm::sdk::testing::load_plugin_model;

skidimm::sdk::ParameterSet husky() {
  skidimm::sdk::ParameterSet p;
  p.set_scalar("s_ss", 0.2);
  p.set_scalar("m", 0.6);
  p.set_scalar("tau", 0.05);
  p.set_scalar("tau_s", 0.5);
  p.set_scalar("r", 0.165);
  p.set_scalar("b", 0.555);
  return p;
}

TEST(SlipRatio, ConformsOverItsOperatingRegion) {
  auto model = load_plugin_model(SLIP_RATIO_PLUGIN_FILE, husky());
  skidimm::sdk::testing::OperatingRegion region;
  region.x_min = Eigen::Vector3d(-2.0, -1.5, 0.0);  // V (m/s), omega (rad/s), s
  region.x_max = Eigen::Vector3d(2.0, 1.5, 0.9);
  region.u_min = Eigen::Vector2d(-15.0, -15.0);  // wheel speeds (rad/s)
  region.u_max = Eigen::Vector2d(15.0, 15.0);
  region.dt_min = 0.001;
  region.dt_max = 0.1;
  EXPECT_MOTION_MODEL_CONFORMS_OVER(*model, region);
}

TEST(SlipRatio, StepsAsItsEquationsSay) {
  auto model = load_plugin_model(SLIP_RATIO_PLUGIN_FILE, husky());
  Eigen::VectorXd next(3);
  ASSERT_TRUE(model->predict(Eigen::Vector3d(1.0, 0.1, 0.1), Eigen::Vector2d(10.0, 12.0), 0.01, next));
  const double wheel_speed = 0.165 * 11.0;  // r (phi_L + phi_R) / 2
  EXPECT_NEAR(next[0], 1.0 + 0.01 * ((1.0 - 0.1) * wheel_speed - 1.0) / 0.05, 1e-15);
  EXPECT_NEAR(next[1], 0.1 + 0.01 * (0.6 * 0.165 * 2.0 / 0.555 - 0.1) / 0.05, 1e-15);
  EXPECT_NEAR(next[2], 0.1 + 0.01 * (0.2 - 0.1) / 0.5, 1e-15);
}

TEST(SlipRatio, RefusesAParameterOutOfBoundsNamingIt) {
  skidimm::sdk::ParameterSet p = husky();
  p.set_scalar("s_ss", 1.5);
  try {
    load_plugin_model(SLIP_RATIO_PLUGIN_FILE, p);
    ADD_FAILURE() << "s_ss = 1.5 was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("s_ss"), std::string::npos) << e.what();
  }
}

TEST(SlipRatio, SurvivesRepeatedLoadAndUnload) {
  EXPECT_PLUGIN_SURVIVES_RELOAD(SLIP_RATIO_PLUGIN_FILE, husky(), Eigen::Vector3d(1.0, 0.2, 0.1),
                                Eigen::Vector2d(8.0, 9.0), 0.02);
}

}  // namespace
