#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "core/temp_files.h"
#include "plugins/husky_geometry.h"
#include "skidimm/config/bank.h"
#include "skidimm/engine/plugin_registry.h"
#include "skidimm/sdk/angles.h"
#include "skidimm/sdk/testing/conformance.h"
#include "skidimm/sdk/testing/plugin_lifecycle.h"

namespace skidimm {
namespace {

using skidimm_test::kHuskyTrack;
using skidimm_test::kHuskyWheelRadius;

struct Sided {
  double eta_l = 1.0, eta_r = 1.0;
  double alpha_l_outer = 1.0, alpha_l_inner = 1.0, alpha_r_outer = 1.0, alpha_r_inner = 1.0;
  double x_icr = 0.0;
};

sdk::ParameterSet sided_params(const Sided& s) {
  sdk::ParameterSet p;
  p.set_scalar("eta_l", s.eta_l);
  p.set_scalar("eta_r", s.eta_r);
  p.set_scalar("alpha_l_outer", s.alpha_l_outer);
  p.set_scalar("alpha_l_inner", s.alpha_l_inner);
  p.set_scalar("alpha_r_outer", s.alpha_r_outer);
  p.set_scalar("alpha_r_inner", s.alpha_r_inner);
  p.set_scalar("x_icr", s.x_icr);
  p.set_scalar("r", kHuskyWheelRadius);
  p.set_scalar("b", kHuskyTrack);
  return p;
}

sdk::ParameterSet eq3_params(double k, double m) {
  sdk::ParameterSet p;
  p.set_scalar("k", k);
  p.set_scalar("m", m);
  p.set_scalar("r", kHuskyWheelRadius);
  p.set_scalar("b", kHuskyTrack);
  return p;
}

// Body velocity (v_x, v_y, omega) the model moves with, read back from one
// short step at heading 0.
Eigen::Vector3d body_velocity(const sdk::MotionModel& model, double phi_left, double phi_right) {
  const double dt = 1e-3;
  Eigen::VectorXd next(3);
  EXPECT_TRUE(model.predict(Eigen::Vector3d::Zero(), Eigen::Vector2d(phi_left, phi_right), dt, next));
  return next / dt;
}

class StcSided : public ::testing::Test {
 protected:
  PluginRegistry registry_{{SKIDIMM_PLUGIN_DIR}};
};

TEST_F(StcSided, ConformsAtSeveralHeadingsAndSlipsIncludingTheSeam) {
  const Sided cases[] = {{},
                         {0.9, 0.6, 1.4, 1.3, 4.5, 2.5, 0.0},
                         {1.0, 0.97, 1.2, 1.1, 1.1, 1.2, -0.24},
                         {0.7, 1.1, 3.0, 2.0, 0.8, 0.9, 0.3}};
  for (const Sided& s : cases) {
    ModelHandle model = registry_.create("stc_sided", sided_params(s));
    for (double theta : {0.0, 0.7, -2.0, 3.1, -3.14}) {
      for (double dt : {0.01, 0.1}) {
        EXPECT_MOTION_MODEL_CONFORMS(*model, Eigen::Vector3d(1.0, -2.0, theta), Eigen::Vector2d(2.0, 7.0), dt);
      }
    }
    // Turning right and reversing exercise the other signs of every term.
    EXPECT_MOTION_MODEL_CONFORMS(*model, Eigen::Vector3d(0.3, 0.1, 1.2), Eigen::Vector2d(6.0, -1.5), 0.05);
  }
  ModelHandle model = registry_.create("stc_sided", sided_params({}));
  EXPECT_TRUE(model->has_analytic_jacobian());
  EXPECT_TRUE(model->is_angle(2));
  EXPECT_FALSE(model->is_angle(0));
  EXPECT_FALSE(model->is_angle(1));
}

TEST_F(StcSided, SurvivesRepeatedLoadAndUnload) {
  EXPECT_PLUGIN_SURVIVES_RELOAD(SKIDIMM_STC_SIDED_PLUGIN, sided_params({0.9, 0.6, 1.4, 1.3, 4.5, 2.5, 0.1}),
                                Eigen::Vector3d(1.0, -2.0, 0.4), Eigen::Vector2d(2.0, 7.0), 0.05);
}

TEST_F(StcSided, PredictsTheIcrKinematicsByHand) {
  const Sided s{0.9, 0.6, 1.4, 1.3, 4.5, 2.5, -0.2};
  ModelHandle model = registry_.create("stc_sided", sided_params(s));
  const double theta = 0.3, dt = 0.1;
  // Turning left: the left tread is inside (1.3), the right one outside (4.5);
  // turning right, the other way round (1.4 and 2.5).
  const double turns[2][4] = {{4.0, 6.0, 1.3, 4.5}, {6.0, 4.0, 1.4, 2.5}};
  for (const auto& turn : turns) {
    const double phi_l = turn[0], phi_r = turn[1];
    Eigen::VectorXd next(3);
    ASSERT_TRUE(model->predict(Eigen::Vector3d(1.0, 2.0, theta), Eigen::Vector2d(phi_l, phi_r), dt, next));
    const double v_l = 0.9 * kHuskyWheelRadius * phi_l, v_r = 0.6 * kHuskyWheelRadius * phi_r;     // tread speeds
    const double y_l = turn[2] * kHuskyTrack / 2.0, y_r = -turn[3] * kHuskyTrack / 2.0;  // tread ICRs
    const double omega = (v_r - v_l) / (y_l - y_r);
    const double v_x = (v_r * y_l - v_l * y_r) / (y_l - y_r);
    const double v_y = 0.2 * omega;  // -x_icr omega
    EXPECT_NEAR(next[0], 1.0 + (v_x * std::cos(theta) - v_y * std::sin(theta)) * dt, 1e-15);
    EXPECT_NEAR(next[1], 2.0 + (v_x * std::sin(theta) + v_y * std::cos(theta)) * dt, 1e-15);
    EXPECT_NEAR(next[2], theta + omega * dt, 1e-15);
  }
}

// The roles switch when the turn does, where the motion does not depend on
// them: straight ahead the robot drives at the tread speed, without turning.
TEST_F(StcSided, IsContinuousWhereTheTreadsSwapRoles) {
  ModelHandle model = registry_.create("stc_sided", sided_params({1.0, 1.0, 1.2, 1.1, 9.0, 3.0, 0.1}));
  const Eigen::Vector3d straight = body_velocity(*model, 5.0, 5.0);
  EXPECT_NEAR(straight[0], kHuskyWheelRadius * 5.0, 1e-9);
  EXPECT_NEAR(straight[2], 0.0, 1e-12);
  for (double d : {1e-6, -1e-6}) {
    EXPECT_TRUE(body_velocity(*model, 5.0 - d, 5.0 + d).isApprox(straight, 1e-6)) << d;
  }
}

TEST_F(StcSided, IdealParametersAreTheDifferentialDrive) {
  ModelHandle model = registry_.create("stc_sided", sided_params({}));
  const Eigen::Vector3d v = body_velocity(*model, 4.0, 6.0);
  EXPECT_NEAR(v[0], kHuskyWheelRadius * 5.0, 1e-12);
  EXPECT_NEAR(v[1], 0.0, 1e-12);
  EXPECT_NEAR(v[2], kHuskyWheelRadius * 2.0 / kHuskyTrack, 1e-12);
}

// eq. 3 with (k, m) is the sided model with eta = k on both sides, both ICRs
// at k / m half tracks and x_icr = 0: the two plugins mix in one bank and
// agree where eq. 3 is enough.
TEST_F(StcSided, ContainsEquationThree) {
  const double k = 0.97, m = 0.54;
  ModelHandle eq3 = registry_.create("stc_kinematic", eq3_params(k, m));
  ModelHandle sided = registry_.create("stc_sided", sided_params({k, k, k / m, k / m, k / m, k / m, 0.0}));
  Eigen::VectorXd a(3), b(3);
  for (const Eigen::Vector2d& u : {Eigen::Vector2d(4.0, 6.0), Eigen::Vector2d(6.0, 4.0), Eigen::Vector2d(-3.0, 2.0)}) {
    ASSERT_TRUE(eq3->predict(Eigen::Vector3d(1.0, 2.0, 2.5), u, 0.1, a));
    ASSERT_TRUE(sided->predict(Eigen::Vector3d(1.0, 2.0, 2.5), u, 0.1, b));
    EXPECT_TRUE(a.isApprox(b, 1e-14)) << a.transpose() << " vs " << b.transpose();
  }
}

// What eq. 3 cannot say: a slippery right side turns a left turn (where it
// must push) less than a mirrored right turn, slows the robot in the one and
// speeds it up in the other (the simulator does the same:
// SkidSteerDynamics.ASlipperySideTurnsLeftAndRightDifferently), and still
// drives straight when not turning.
TEST_F(StcSided, ASlipperySideMakesLeftAndRightTurnsDiffer) {
  ModelHandle model = registry_.create("stc_sided", sided_params({1.0, 1.0, 1.5, 1.4, 18.0, 10.0, 0.0}));
  const Eigen::Vector3d left = body_velocity(*model, 4.0, 6.0);
  const Eigen::Vector3d right = body_velocity(*model, 6.0, 4.0);
  EXPECT_GT(left[2], 0.0);
  EXPECT_LT(right[2], 0.0);
  EXPECT_LT(left[2], -right[2] * 0.75);
  EXPECT_LT(left[0], 0.9 * kHuskyWheelRadius * 5.0);
  EXPECT_GT(right[0], 1.1 * kHuskyWheelRadius * 5.0);
  EXPECT_NEAR(body_velocity(*model, 5.0, 5.0)[2], 0.0, 1e-12);
  // eq. 3 cannot: its left and right turns mirror each other exactly.
  ModelHandle eq3 = registry_.create("stc_kinematic", eq3_params(0.9, 0.4));
  const Eigen::Vector3d eq3_left = body_velocity(*eq3, 4.0, 6.0), eq3_right = body_velocity(*eq3, 6.0, 4.0);
  EXPECT_NEAR(eq3_left[2], -eq3_right[2], 1e-12);
  EXPECT_NEAR(eq3_left[0], eq3_right[0], 1e-12);
}

TEST_F(StcSided, TheVehicleIcrMakesTheBodySlideSideways) {
  // Front wheels sliding out of a left turn: the ICR lies behind the centre,
  // and the centre moves to the left of its heading.
  ModelHandle model = registry_.create("stc_sided", sided_params({1.0, 1.0, 1.0, 1.0, 1.0, 1.0, -0.25}));
  const Eigen::Vector3d v = body_velocity(*model, 4.0, 6.0);
  EXPECT_NEAR(v[1], 0.25 * v[2], 1e-12);
  EXPECT_GT(v[1], 0.0);
}

TEST_F(StcSided, HeadingWrapsAcrossPi) {
  ModelHandle model = registry_.create("stc_sided", sided_params({}));
  Eigen::VectorXd next(3);
  ASSERT_TRUE(model->predict(Eigen::Vector3d(0.0, 0.0, 3.1), Eigen::Vector2d(0.0, 10.0), 0.1, next));
  EXPECT_NEAR(next[2], sdk::wrap_angle(3.1 + kHuskyWheelRadius * 10.0 / kHuskyTrack * 0.1), 1e-15);
  EXPECT_LT(next[2], 0.0);
}

TEST_F(StcSided, GeometryIsBankScopedAndSlipIsPerMode) {
  ModelHandle model = registry_.create("stc_sided", sided_params({}));
  const auto& info = model->parameter_info();
  ASSERT_EQ(info.size(), 9u);
  const char* names[] = {"eta_l", "eta_r", "alpha_l_outer", "alpha_l_inner", "alpha_r_outer", "alpha_r_inner", "x_icr",
                         "r",     "b"};
  for (std::size_t i = 0; i < info.size(); ++i) {
    EXPECT_EQ(info[i].name, names[i]);
    EXPECT_EQ(info[i].scope, i < 7 ? sdk::ParameterScope::kMode : sdk::ParameterScope::kBank) << names[i];
  }
}

TEST_F(StcSided, BadParametersAreRejectedWithTheirName) {
  Sided bad;
  bad.alpha_r_inner = 0.0;
  try {
    registry_.create("stc_sided", sided_params(bad));
    FAIL() << "alpha_r_inner = 0 puts the right tread's ICR on the centre line and must be refused";
  } catch (const std::exception& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("'alpha_r_inner'"));
  }
  sdk::ParameterSet missing = sided_params({});
  sdk::ParameterSet without;
  for (const char* key :
       {"eta_l", "eta_r", "alpha_l_outer", "alpha_l_inner", "alpha_r_outer", "alpha_r_inner", "r", "b"}) {
    double v = 0.0;
    ASSERT_TRUE(missing.get_scalar(key, &v, nullptr));
    without.set_scalar(key, v);
  }
  try {
    registry_.create("stc_sided", without);
    FAIL() << "x_icr is required";
  } catch (const std::exception& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("x_icr"));
  }
  ModelHandle model = registry_.create("stc_sided", sided_params({}));
  std::string error;
  Eigen::VectorXd values(9);
  values << 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.165, -0.5;
  EXPECT_FALSE(model->set_parameters(values, &error));
  EXPECT_THAT(error, ::testing::HasSubstr("'b'"));
}

// A bank mixing both plugins loads: same states, angles and inputs, one
// shared r and b.
TEST_F(StcSided, MixesWithStcKinematicInOneBank) {
  const auto dir = skidimm_test::test_directory();
  const auto bank_file = skidimm_test::write_file(dir / "mixed.yaml", R"(name: mixed
states: [X, Y, theta]
angles: [theta]
inputs: [phi_dot_L, phi_dot_R]
measurement: {observe: [X, Y, theta], R: {std: [0.02, 0.02, 0.05]}}
transition: {mean_dwell_time: 20}
initial: {covariance: {std: [0.1, 0.1, 0.05]}}
shared: {r: 0.165, b: 0.555}
modes:
  - {name: eq3, model: stc_kinematic, params: {k: 1.0, m: 0.54}, Q: {diagonal: [1e-4, 1e-4, 1e-4]}}
  - name: right_side_slips
    model: stc_sided
    params: {eta_l: 1.0, eta_r: 1.0, alpha_l_outer: 1.5, alpha_l_inner: 1.4, alpha_r_outer: 18, alpha_r_inner: 10, x_icr: 0}
    Q: {diagonal: [1e-4, 1e-4, 1e-4]}
)");
  const Bank bank = Bank::load(bank_file, {SKIDIMM_PLUGIN_DIR});
  ASSERT_EQ(bank.config.num_modes(), 2);
  Eigen::VectorXd values(9);
  bank.models[1]->get_parameters(values);
  EXPECT_DOUBLE_EQ(values[7], 0.165);
  EXPECT_DOUBLE_EQ(values[8], 0.555);
}

}  // namespace
}  // namespace skidimm
