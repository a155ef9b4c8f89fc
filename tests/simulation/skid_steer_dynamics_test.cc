#include "skidimm/simulation/skid_steer_dynamics.h"

#include <gtest/gtest.h>

#include <cmath>

#include "skidimm/simulation/terrain.h"

namespace skidimm {
namespace simulation {
namespace {

constexpr double kGravity = 9.81;

// Drives `seconds` with constant side commands, recording the peak body
// acceleration and the peak of each wheel's force over its friction limit.
RobotState drive(const TractionMode& mode, double left, double right, double seconds, double* peak_lateral,
                 double* peak_total, RobotState start = {}, double* peak_wheel_ratio = nullptr) {
  const RobotParameters robot;
  const SkidSteerDynamics dynamics{robot};
  const double normal = robot.mass * kGravity / kNumWheels;
  RobotState s = start;
  for (double t = 0.0; t < seconds; t += 0.0005) {
    dynamics.step(SkidSteerDynamics::side_commands(left, right), mode, 0.0005, &s);
    const ContactForces f = dynamics.forces(s, mode);
    *peak_lateral = std::max(*peak_lateral, std::abs(f.ay));
    *peak_total = std::max(*peak_total, std::hypot(f.ax, f.ay));
    if (peak_wheel_ratio != nullptr) {
      for (int i = 0; i < kNumWheels; ++i) {
        const WheelGroundContact& c = mode.wheels[i];
        // Traction part within mu N, sideways part within mu lateral_ratio N
        // (the friction ellipse), ignoring rolling resistance.
        const double ellipse =
            std::hypot(f.fx[i] / (c.friction * normal), f.fy[i] / (c.friction * c.lateral_ratio * normal));
        *peak_wheel_ratio = std::max(*peak_wheel_ratio, ellipse);
      }
    }
  }
  return s;
}

TEST(SkidSteerDynamics, AccelerationNeverExceedsTheFrictionLimit) {
  for (const Terrain& terrain : builtin_terrains()) {
    const TractionMode mode = make_traction_mode("m", terrain.name, {});
    const double mu = terrain.contact.friction;
    const double mu_lateral = mu * terrain.contact.lateral_ratio;
    // A hard launch: every wheel commanded far faster than the body can follow.
    double peak_lateral = 0.0, peak_total = 0.0;
    drive(mode, 30.0, 30.0, 2.0, &peak_lateral, &peak_total);
    EXPECT_LE(peak_total, (mu + terrain.contact.rolling_resistance) * kGravity * (1.0 + 1e-9)) << terrain.name;
    // Not trivially true: the launch reaches 0.86-0.98 mu g on all but ice,
    // whose wheels spin straight through the peak into sliding (0.39).
    EXPECT_GT(peak_total, 0.35 * mu * kGravity) << terrain.name << ": the launch did not load the tyres";
    // A violent spin turn: the body's sideways acceleration stays within the
    // lateral friction, and no wheel's force leaves its friction ellipse.
    double wheel_ratio = 0.0;
    peak_lateral = peak_total = 0.0;
    drive(mode, -10.0, 25.0, 4.0, &peak_lateral, &peak_total, RobotState{}, &wheel_ratio);
    EXPECT_LE(peak_lateral, mu_lateral * kGravity * (1.0 + 1e-9)) << terrain.name;
    EXPECT_LE(wheel_ratio, 1.0 + 0.1) << terrain.name;  // rolling resistance adds up to c_rr / mu
    EXPECT_GT(wheel_ratio, 0.5) << terrain.name << ": the spin did not load the tyres";
  }
}

TEST(SkidSteerDynamics, StraightSlowDrivingOnHardGroundIsTheIdealKinematics) {
  const TractionMode asphalt = make_traction_mode("m", "asphalt", {});
  double lateral = 0.0, total = 0.0;
  const double wheel = 0.3 / 0.165;  // rad/s for 0.3 m/s
  const RobotState s = drive(asphalt, wheel, wheel, 5.0, &lateral, &total);
  // Rolling resistance needs a little slip: within 0.5% of r * phi_dot.
  EXPECT_NEAR(s.vx, 0.3, 0.3 * 0.005);
  EXPECT_NEAR(s.vy, 0.0, 1e-9);
  EXPECT_NEAR(s.omega, 0.0, 1e-9);
  EXPECT_NEAR(s.x, 0.3 * 5.0, 0.1);  // minus the speed-up
}

TEST(SkidSteerDynamics, TurningScrubsMoreOnGroundThatResistsSidewaysSliding) {
  // Same command, yaw achieved: isotropic asphalt turns more than crushed concrete.
  double lateral = 0.0, total = 0.0;
  const RobotState on_asphalt = drive(make_traction_mode("a", "asphalt", {}), 3.0, 6.0, 6.0, &lateral, &total);
  const RobotState on_concrete =
      drive(make_traction_mode("c", "crushed_concrete", {}), 3.0, 6.0, 6.0, &lateral, &total);
  const double ideal = 0.165 * 3.0 / 0.555;
  EXPECT_LT(on_asphalt.omega, ideal);
  EXPECT_LT(on_concrete.omega, 0.85 * on_asphalt.omega);
}

TEST(SkidSteerDynamics, ARollingRobotWithStoppedWheelsOnlyLosesEnergy) {
  RobotState start;
  start.vx = 1.0;
  start.omega = 0.5;
  const SkidSteerDynamics dynamics{RobotParameters{}};
  const TractionMode grass = make_traction_mode("g", "grass", {});
  const RobotParameters robot;
  auto energy = [&](const RobotState& s) {
    return 0.5 * robot.mass * (s.vx * s.vx + s.vy * s.vy) + 0.5 * robot.yaw_inertia * s.omega * s.omega;
  };
  RobotState s = start;
  double previous = energy(s);
  for (int k = 0; k < 4000; ++k) {
    dynamics.step(SkidSteerDynamics::side_commands(0.0, 0.0), grass, 0.0005, &s);
    ASSERT_LE(energy(s), previous + 1e-9) << "step " << k;
    previous = energy(s);
  }
  EXPECT_LT(energy(s), 1e-3 * energy(start));
}

// Steady yaw efficiency (omega over the commanded r (phi_R - phi_L) / b) and
// speed efficiency (v_x over r (phi_L + phi_R) / 2) after 12 s of wheel
// commands for speed v and turning radius radius (> 0 turns left).
struct Efficiency {
  double yaw, speed;
};
Efficiency steady_turn(const TractionMode& mode, double v, double radius) {
  const RobotParameters robot;
  const double omega = v / radius;
  const double left = (v - omega * robot.track / 2.0) / robot.wheel_radius;
  const double right = (v + omega * robot.track / 2.0) / robot.wheel_radius;
  double lateral = 0.0, total = 0.0;
  const RobotState s = drive(mode, left, right, 12.0, &lateral, &total);
  return {s.omega / (robot.wheel_radius * (right - left) / robot.track),
          s.vx / (robot.wheel_radius * (left + right) / 2.0)};
}

// Scaling every wheel's friction by one factor leaves the quasi-static force
// balance, and so the motion, unchanged: only inertia and rolling
// resistance, small against friction on wide turns, tell a robot with a tarp
// on every wheel from one with none (docs/simulation.md; the paper's own
// explanation of its baseline/four-wheel confusion). On tight turns the
// tarps' lower friction saturates and the two part.
TEST(SkidSteerDynamics, TarpOnEveryWheelTurnsWideLikeNoTarp) {
  const TractionMode none = make_traction_mode("none", "asphalt", {});
  const TractionMode all = make_traction_mode("all", "asphalt", {"FL", "FR", "RL", "RR"});
  for (double radius : {3.0, 6.0}) {
    const Efficiency a = steady_turn(none, 0.8, radius), b = steady_turn(all, 0.8, radius);
    EXPECT_NEAR(b.yaw, a.yaw, 0.02 * a.yaw) << "radius " << radius;
    EXPECT_NEAR(b.speed, a.speed, 0.01) << "radius " << radius;
  }
  // At 1 m the tarps saturate: the robot with four tarps slides round (yaw
  // efficiency 0.90) where the one without scrubs (0.55).
  const Efficiency tight_none = steady_turn(none, 0.8, 1.0), tight_all = steady_turn(all, 0.8, 1.0);
  EXPECT_GT(tight_all.yaw - tight_none.yaw, 0.2);
}

// A tarp on one side: a turn towards the grippy side (the slippery side
// outside, having to push) turns less and drives slower than the mirrored
// turn, which eq. 3's single (k, m) cannot express and stc_sided can.
TEST(SkidSteerDynamics, ASlipperySideTurnsLeftAndRightDifferently) {
  const TractionMode right_tarp = make_traction_mode("right", "asphalt", {"FR", "RR"});
  const Efficiency left_turn = steady_turn(right_tarp, 0.8, 1.5), right_turn = steady_turn(right_tarp, 0.8, -1.5);
  EXPECT_LT(left_turn.yaw, 0.75 * right_turn.yaw);
  EXPECT_LT(left_turn.speed, 0.9);
  EXPECT_GT(right_turn.speed, 1.1);
}

TEST(TractionMode, TarpScalesTheWrappedWheelsFriction) {
  const TractionMode m = make_traction_mode("slip", "asphalt", {"FR", "RR"});
  EXPECT_DOUBLE_EQ(m.wheels[kFrontLeft].friction, 0.9);
  EXPECT_DOUBLE_EQ(m.wheels[kFrontRight].friction, 0.9 * kTarpFrictionFactor);
  EXPECT_DOUBLE_EQ(m.wheels[kRearRight].friction, 0.9 * kTarpFrictionFactor);
  EXPECT_THROW(make_traction_mode("x", "mud", {}), std::invalid_argument);
  EXPECT_THROW(make_traction_mode("x", "asphalt", {"XX"}), std::invalid_argument);
}

}  // namespace
}  // namespace simulation
}  // namespace skidimm
