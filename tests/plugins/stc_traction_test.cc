// stc_traction: stc_sided's kinematics plus each side's motor current
// (plugins/stc_traction/stc_traction_equations.h), and the yaw-rate outputs of the
// kinematic plugins.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "skidimm/engine/plugin_registry.h"
#include "plugins/husky_geometry.h"
#include "skidimm/errors.h"
#include "skidimm/sdk/testing/conformance.h"

namespace skidimm {
namespace {

using skidimm_test::kHuskyTrack;
using skidimm_test::kHuskyWheelRadius;

// stc_sided's parameters of PredictsTheIcrKinematicsByHand, plus currents.
sdk::ParameterSet traction_params(bool with_currents = true) {
  sdk::ParameterSet p;
  const char* names[] = {"eta_l", "eta_r", "alpha_l_outer", "alpha_l_inner", "alpha_r_outer", "alpha_r_inner", "x_icr"};
  const double values[] = {0.9, 0.6, 1.4, 1.3, 4.5, 2.5, -0.2};
  for (int i = 0; i < 7; ++i) p.set_scalar(names[i], values[i]);
  p.set_scalar("r", kHuskyWheelRadius);
  p.set_scalar("b", kHuskyTrack);
  if (with_currents) {
    p.set_scalar("k_skid_l", 30.0);
    p.set_scalar("k_skid_r", 30.0);
    p.set_scalar("i_straight", 2.0);
    p.set_scalar("i_l_outer", 9.0);
    p.set_scalar("i_l_inner", 7.0);
    p.set_scalar("i_r_outer", 5.0);
    p.set_scalar("i_r_inner", 4.0);
    p.set_scalar("s_peak", 0.12);
  }
  return p;
}

class StcTraction : public ::testing::Test {
 protected:
  PluginRegistry registry_{{SKIDIMM_PLUGIN_DIR}};
};

TEST_F(StcTraction, ConformsWithItsOutputsTurningBothWaysAndReversing) {
  ModelHandle model = registry_.create("stc_traction", traction_params());
  EXPECT_EQ(model->output_names(), (std::vector<std::string>{"omega", "i_L", "i_R"}));
  for (const Eigen::Vector2d& u : {Eigen::Vector2d(2.0, 7.0), Eigen::Vector2d(6.0, 5.5), Eigen::Vector2d(6.0, -1.5),
                                   Eigen::Vector2d(-3.0, -3.5)}) {
    EXPECT_MOTION_MODEL_CONFORMS(*model, Eigen::Vector3d(1.0, -2.0, 0.7), u, 0.05);
  }
}

// The currents by hand: turn ratio s, shape 2 (s / s_peak) / (1 + (s /
// s_peak)^2), each side's gain for its role; omega is the pose's yaw rate.
TEST_F(StcTraction, PredictsEachSidesCurrentAndTheYawRateByHand) {
  ModelHandle model = registry_.create("stc_traction", traction_params());
  Eigen::VectorXd y(3), next(3);
  const double turns[2][4] = {{4.0, 6.0, 7.0, 5.0}, {6.0, 4.0, 9.0, 4.0}};  // left: L inner, R outer
  for (const auto& turn : turns) {
    const Eigen::Vector2d u(turn[0], turn[1]);
    ASSERT_TRUE(model->outputs(u, y));
    const double s = std::abs(turn[1] - turn[0]) / (turn[0] + turn[1] + 0.5) / 0.12;
    const double shape = 2.0 * s / (1.0 + s * s);
    EXPECT_NEAR(y[1], 2.0 + turn[2] * shape, 1e-12);
    EXPECT_NEAR(y[2], 2.0 + turn[3] * shape, 1e-12);
    ASSERT_TRUE(model->predict(Eigen::Vector3d::Zero(), u, 1e-3, next));
    EXPECT_NEAR(y[0], next[2] / 1e-3, 1e-9);
  }
  // Straight, or at rest, each side draws i_straight.
  ASSERT_TRUE(model->outputs(Eigen::Vector2d(5.0, 5.0), y));
  EXPECT_EQ(y[1], 2.0);
  EXPECT_EQ(y[2], 2.0);
  ASSERT_TRUE(model->outputs(Eigen::Vector2d(0.0, 0.0), y));
  EXPECT_EQ(y[1], 2.0);
  // The peak of the turn current is at s_peak.
  const double phi = 4.0;
  const double right = phi * (1.0 + 0.12) / (1.0 - 0.12) + 0.5 * 0.12 / (1.0 - 0.12);  // s = 0.12 exactly
  ASSERT_TRUE(model->outputs(Eigen::Vector2d(phi, right), y));
  EXPECT_NEAR(y[1], 2.0 + 7.0, 1e-12);
}

// With k_skid_l = k_skid_r both ICRs move out by 1 + k_skid s^2: the yaw rate
// and the lateral skid are stc_sided's divided by it, the forward speed is
// stc_sided's.
TEST_F(StcTraction, TreadIcrsMoveOutAsTheTurnTightens) {
  ModelHandle traction = registry_.create("stc_traction", traction_params());
  ModelHandle sided = registry_.create("stc_sided", traction_params(false));
  Eigen::VectorXd a(3), b(3);
  const double dt = 1e-3, theta = 0.4;
  for (const Eigen::Vector2d& u : {Eigen::Vector2d(4.0, 6.0), Eigen::Vector2d(6.5, 2.0), Eigen::Vector2d(5.0, 5.0)}) {
    ASSERT_TRUE(traction->predict(Eigen::Vector3d(0.0, 0.0, theta), u, dt, a));
    ASSERT_TRUE(sided->predict(Eigen::Vector3d(0.0, 0.0, theta), u, dt, b));
    const double s = (u[1] - u[0]) / (u[0] + u[1] + 0.5);
    const double spread = 1.0 + 30.0 * s * s;
    EXPECT_NEAR(a[2] - theta, (b[2] - theta) / spread, 1e-15);
    // Body velocities from the step: v_x is unchanged, v_y divided.
    const double c = std::cos(theta), sn = std::sin(theta);
    const double vx_a = (a[0] * c + a[1] * sn) / dt, vy_a = (-a[0] * sn + a[1] * c) / dt;
    const double vx_b = (b[0] * c + b[1] * sn) / dt, vy_b = (-b[0] * sn + b[1] * c) / dt;
    EXPECT_NEAR(vx_a, vx_b, 1e-12);
    EXPECT_NEAR(vy_a, vy_b / spread, 1e-12);
  }
}

// With a side of its own each ICR moves out by its side's factor: the same as
// stc_sided with that side's alphas multiplied by it, at that input. With the
// right tread's ICR moving out fast the robot turns about its left tread, so
// its forward speed moves towards the left tread's (turning left, the right
// tread outer).
TEST_F(StcTraction, EachSidesIcrMovesOutByItsOwnFactor) {
  sdk::ParameterSet params = traction_params();
  params.set_scalar("k_skid_l", 2.0);
  params.set_scalar("k_skid_r", 40.0);
  ModelHandle traction = registry_.create("stc_traction", params);
  Eigen::VectorXd a(3), b(3);
  const double dt = 1e-3;
  for (const Eigen::Vector2d& u : {Eigen::Vector2d(4.0, 6.0), Eigen::Vector2d(6.5, 2.0), Eigen::Vector2d(-3.0, -1.0)}) {
    const double s = (u[1] - u[0]) / (std::abs(u[0]) + std::abs(u[1]) + 0.5);
    sdk::ParameterSet moved = traction_params(false);
    moved.set_scalar("alpha_l_outer", 1.4 * (1.0 + 2.0 * s * s));  // traction_params()' alphas
    moved.set_scalar("alpha_l_inner", 1.3 * (1.0 + 2.0 * s * s));
    moved.set_scalar("alpha_r_outer", 4.5 * (1.0 + 40.0 * s * s));
    moved.set_scalar("alpha_r_inner", 2.5 * (1.0 + 40.0 * s * s));
    ModelHandle sided = registry_.create("stc_sided", moved);
    ASSERT_TRUE(traction->predict(Eigen::Vector3d(0.5, -1.0, 0.4), u, dt, a));
    ASSERT_TRUE(sided->predict(Eigen::Vector3d(0.5, -1.0, 0.4), u, dt, b));
    EXPECT_TRUE(a.isApprox(b, 1e-14)) << a.transpose() << " vs " << b.transpose();
  }
  // Turning left on (3, 6) rad/s: s = 3 / 9.5, the right ICR 5 times as far
  // out, the left 1.2 times; v_x = (v_r y_l - v_l y_r) / (y_l - y_r).
  const double s = 3.0 / 9.5;
  const double y_l = 1.3 * kHuskyTrack / 2 * (1.0 + 2.0 * s * s), y_r = -4.5 * kHuskyTrack / 2 * (1.0 + 40.0 * s * s);
  const double v_l = 0.9 * kHuskyWheelRadius * 3.0, v_r = 0.6 * kHuskyWheelRadius * 6.0;
  ASSERT_TRUE(traction->predict(Eigen::Vector3d::Zero(), Eigen::Vector2d(3.0, 6.0), dt, a));
  EXPECT_NEAR(a[0] / dt, (v_r * y_l - v_l * y_r) / (y_l - y_r), 1e-9);
  EXPECT_NEAR(a[2] / dt, (v_r - v_l) / (y_l - y_r), 1e-9);
  // Closer to the left tread's speed than with both ICRs moved alike.
  const double y_r_alike = -4.5 * kHuskyTrack / 2 * (1.0 + 2.0 * s * s);
  EXPECT_LT(std::abs(a[0] / dt - v_l), std::abs((v_r * y_l - v_l * y_r_alike) / (y_l - y_r_alike) - v_l) - 0.01);
}

TEST_F(StcTraction, TheKinematicPluginsPredictTheGyrosYawRate) {
  sdk::ParameterSet eq3;
  eq3.set_scalar("k", 0.8);
  eq3.set_scalar("m", 0.6);
  eq3.set_scalar("r", kHuskyWheelRadius);
  eq3.set_scalar("b", kHuskyTrack);
  for (const auto& [name, params] :
       {std::make_pair("stc_kinematic", eq3), std::make_pair("stc_sided", traction_params(false)),
        std::make_pair("stc_traction", traction_params())}) {
    ModelHandle model = registry_.create(name, params);
    Eigen::VectorXd y(static_cast<Eigen::Index>(model->output_names().size())), next(3);
    EXPECT_EQ(model->output_names()[0], "omega") << name;
    for (const Eigen::Vector2d& u : {Eigen::Vector2d(2.0, 7.0), Eigen::Vector2d(6.0, -1.5)}) {
      ASSERT_TRUE(model->outputs(u, y)) << name;
      ASSERT_TRUE(model->predict(Eigen::Vector3d::Zero(), u, 1e-3, next));
      EXPECT_NEAR(y[0], next[2] / 1e-3, 1e-9) << name;
    }
    EXPECT_MOTION_MODEL_CONFORMS(*model, Eigen::Vector3d(1.0, -2.0, 0.7), Eigen::Vector2d(2.0, 7.0), 0.05);
  }
}

TEST_F(StcTraction, EveryParameterIsRequiredAndBounded) {
  sdk::ParameterSet p = traction_params();
  p.set_scalar("s_peak", 0.0);
  try {
    registry_.create("stc_traction", p);
    ADD_FAILURE() << "s_peak 0 accepted";
  } catch (const PluginError& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("s_peak"));
  }
  try {
    registry_.create("stc_traction", traction_params(false));
    ADD_FAILURE() << "stc_sided's parameters alone accepted";
  } catch (const PluginError& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("missing parameter 'k_skid_l'"));
  }
  const sdk::ParameterSet all = traction_params();
  sdk::ParameterSet no_current;
  for (const std::string& key : all.keys()) {
    if (key != "i_r_inner") no_current.set(key, *all.find(key));
  }
  try {
    registry_.create("stc_traction", no_current);
    ADD_FAILURE() << "no i_r_inner accepted";
  } catch (const PluginError& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("missing parameter 'i_r_inner'"));
  }
}

}  // namespace
}  // namespace skidimm
