#include "skidimm/simulation/skid_steer_dynamics.h"

#include <algorithm>
#include <cmath>

namespace skidimm {
namespace simulation {

namespace {

constexpr double kGravity = 9.81;
// Below this speed (m/s) slips are normalised by it instead of by the wheel
// or contact speed, the usual regularisation that keeps slip finite at rest.
constexpr double kSlipSpeedFloor = 0.05;
// Rolling resistance fades in over this speed (m/s) instead of switching sign.
constexpr double kRollingSmoothing = 0.02;

}  // namespace

ContactForces SkidSteerDynamics::forces(const RobotState& s, const TractionMode& mode) const {
  ContactForces out;
  const double half_track = robot_.track / 2.0;
  const double half_base = robot_.wheelbase / 2.0;
  const double positions[kNumWheels][2] = {
      {half_base, half_track}, {half_base, -half_track}, {-half_base, half_track}, {-half_base, -half_track}};
  const double normal = robot_.mass * kGravity / kNumWheels;
  double sum_x = 0.0, sum_y = 0.0;
  for (int i = 0; i < kNumWheels; ++i) {
    const WheelGroundContact& c = mode.wheels[i];
    const double contact_vx = s.vx - s.omega * positions[i][1];
    const double contact_vy = s.vy + s.omega * positions[i][0];
    const double rim_speed = robot_.wheel_radius * s.wheel_speed[i];
    const double scale = std::max({std::abs(rim_speed), std::abs(contact_vx), kSlipSpeedFloor});
    const double slip_x = (rim_speed - contact_vx) / scale;  // > 0: the wheel spins faster than it travels
    const double slip_y = contact_vy / scale;                // > 0: the contact slides to the left
    const double slip = std::hypot(slip_x, slip_y);
    double fx = 0.0, fy = 0.0;
    if (slip > 1e-12) {
      const double magnitude = c.friction * normal * std::sin(c.shape * std::atan(c.stiffness * slip));
      fx = magnitude * slip_x / slip;
      fy = -c.lateral_ratio * magnitude * slip_y / slip;
    }
    out.traction[i] = fx;
    fx -= c.rolling_resistance * normal * std::tanh(contact_vx / kRollingSmoothing);
    out.fx[i] = fx;
    out.fy[i] = fy;
    sum_x += fx;
    sum_y += fy;
  }
  out.ax = sum_x / robot_.mass;
  out.ay = sum_y / robot_.mass;
  return out;
}

FastestResponse SkidSteerDynamics::fastest_response(const TractionMode& mode) const {
  const double half_track = robot_.track / 2.0;
  const double half_base = robot_.wheelbase / 2.0;
  const double normal = robot_.mass * kGravity / kNumWheels;
  double longitudinal = 0.0, lateral = 0.0, yaw = 0.0;
  for (const WheelGroundContact& c : mode.wheels) {
    // d/d(slip) of mu N sin(C atan(B slip)) at slip 0; slip = speed / v0.
    const double slope = std::abs(c.friction * normal * c.shape * c.stiffness) / kSlipSpeedFloor;
    longitudinal += slope;
    lateral += std::abs(c.lateral_ratio) * slope;
    yaw += slope * (std::abs(c.lateral_ratio) * half_base * half_base + half_track * half_track);
  }
  const FastestResponse candidates[] = {{1.0 / robot_.motor_time_constant, "wheel speed loop"},
                                        {longitudinal / robot_.mass, "longitudinal"},
                                        {lateral / robot_.mass, "lateral"},
                                        {yaw / robot_.yaw_inertia, "yaw"}};
  FastestResponse fastest;
  for (const FastestResponse& r : candidates) {
    // A NaN or infinite rate (a parameter of 1e-320) must win, not be skipped.
    if (!(r.rate <= fastest.rate)) fastest = r;
  }
  return fastest;
}

RobotState SkidSteerDynamics::derivative(const RobotState& s, const std::array<double, kNumWheels>& commands,
                                         const TractionMode& mode) const {
  const ContactForces f = forces(s, mode);
  const double half_track = robot_.track / 2.0;
  const double half_base = robot_.wheelbase / 2.0;
  const double xs[kNumWheels] = {half_base, half_base, -half_base, -half_base};
  const double ys[kNumWheels] = {half_track, -half_track, half_track, -half_track};
  double moment = 0.0;
  for (int i = 0; i < kNumWheels; ++i) moment += xs[i] * f.fy[i] - ys[i] * f.fx[i];
  RobotState d;
  const double c = std::cos(s.psi), sn = std::sin(s.psi);
  d.x = s.vx * c - s.vy * sn;
  d.y = s.vx * sn + s.vy * c;
  d.psi = s.omega;
  d.vx = f.ax + s.omega * s.vy;
  d.vy = f.ay - s.omega * s.vx;
  d.omega = moment / robot_.yaw_inertia;
  for (int i = 0; i < kNumWheels; ++i) {
    d.wheel_speed[i] = (commands[i] - s.wheel_speed[i]) / robot_.motor_time_constant;
  }
  return d;
}

namespace {

RobotState add(const RobotState& s, const RobotState& d, double h) {
  RobotState out;
  out.x = s.x + h * d.x;
  out.y = s.y + h * d.y;
  out.psi = s.psi + h * d.psi;
  out.vx = s.vx + h * d.vx;
  out.vy = s.vy + h * d.vy;
  out.omega = s.omega + h * d.omega;
  for (int i = 0; i < kNumWheels; ++i) out.wheel_speed[i] = s.wheel_speed[i] + h * d.wheel_speed[i];
  return out;
}

}  // namespace

void SkidSteerDynamics::step(const std::array<double, kNumWheels>& commands, const TractionMode& mode, double h,
                             RobotState* s) const {
  const RobotState k1 = derivative(*s, commands, mode);
  const RobotState k2 = derivative(add(*s, k1, h / 2.0), commands, mode);
  const RobotState k3 = derivative(add(*s, k2, h / 2.0), commands, mode);
  const RobotState k4 = derivative(add(*s, k3, h), commands, mode);
  RobotState sum = k1;
  sum = add(sum, k2, 2.0);
  sum = add(sum, k3, 2.0);
  sum = add(sum, k4, 1.0);
  *s = add(*s, sum, h / 6.0);
}

}  // namespace simulation
}  // namespace skidimm
