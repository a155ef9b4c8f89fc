// Planar rigid-body dynamics of a four-wheel skid-steer robot.
//
// Body frame: x forward, y left; world frame: X east, Y north, psi from X.
// Wheels at (+-wheelbase/2, +-track/2). Each wheel's speed follows its
// command through the motor's speed loop (first order, time constant tau_m:
// Husky-class drives hold speed under load, so wheel dynamics are not
// simulated). Each contact's velocity gives a longitudinal slip ratio and a
// lateral slip, combined into one slip magnitude whose force follows
// WheelGroundContact's saturating law and points against the contact's
// sliding; the four normal loads are m g / 4 (no load transfer). Then
//
//   m (dvx/dt - omega vy) = sum Fx     m (dvy/dt + omega vx) = sum Fy
//   Iz domega/dt = sum (x_i Fy_i - y_i Fx_i)
//
// integrated with classical RK4. Because every |F_i| <= mu_i N_i, the body's
// acceleration never exceeds mu g (tested).
#ifndef SKIDIMM_SIMULATION_SKID_STEER_DYNAMICS_H_
#define SKIDIMM_SIMULATION_SKID_STEER_DYNAMICS_H_

#include <array>

#include "skidimm/simulation/terrain.h"

namespace skidimm {
namespace simulation {

struct RobotParameters {
  double mass = 50.0;                 // kg, Clearpath Husky
  double yaw_inertia = 6.0;           // kg m^2: m (0.99^2 + 0.67^2) / 12 for the Husky's 0.99 x 0.67 m box
  double wheel_radius = 0.165;        // m
  double track = 0.555;               // m, lateral distance between wheel centres
  double wheelbase = 0.512;           // m, longitudinal distance between axles
  double motor_time_constant = 0.05;  // s, wheel speed loop
};

struct RobotState {
  double x = 0.0, y = 0.0, psi = 0.0;            // world pose (m, m, rad)
  double vx = 0.0, vy = 0.0, omega = 0.0;        // body velocity (m/s, m/s, rad/s)
  std::array<double, kNumWheels> wheel_speed{};  // rad/s
};

// Forces and accelerations at a state, for sensors and tests.
struct ContactForces {
  std::array<double, kNumWheels> fx{};  // N, body x
  std::array<double, kNumWheels> fy{};  // N, body y
  // N, body x: the slip force alone, before rolling resistance. The wheel's
  // motor holds its speed against it, so its torque is wheel_radius x this;
  // rolling resistance is a loss the motor also drives against, so fx =
  // traction - rolling resistance is what the body feels.
  std::array<double, kNumWheels> traction{};
  double ax = 0.0;                      // body acceleration (sum F / m), what an IMU measures, m/s^2
  double ay = 0.0;
};

// The fastest response of the dynamics on one traction mode: the largest
// rate (1/s) of its linearisation where it is stiffest, at rest, where slips
// are normalised by the slip speed floor. RK4, like every explicit method,
// diverges when the step exceeds a limit set by this rate (docs/simulation.md,
// "Integration step").
struct FastestResponse {
  double rate = 0.0;  // 1/s; its time constant is 1 / rate
  const char* what = "";  // "wheel speed loop", "longitudinal", "lateral" or "yaw"
};

class SkidSteerDynamics {
 public:
  explicit SkidSteerDynamics(const RobotParameters& robot) : robot_(robot) {}

  const RobotParameters& robot() const { return robot_; }

  ContactForces forces(const RobotState& s, const TractionMode& mode) const;

  // Advances the state by h seconds with per-wheel speed commands (rad/s).
  void step(const std::array<double, kNumWheels>& commands, const TractionMode& mode, double h, RobotState* s) const;

  // Each response's rate is the magnitude of the diagonal entry of the
  // Jacobian at rest: 1/tau_m for the wheels, and for the body, with each
  // wheel's force slope mu N C B at zero slip, sum(slope) / (m v0)
  // (longitudinal), sum(lateral_ratio slope) / (m v0) (lateral) and
  // sum(slope (lateral_ratio x_i^2 + y_i^2)) / (Iz v0) (yaw), v0 the slip
  // speed floor. Symmetric wheel positions make the off-diagonal coupling
  // cancel, so these are the eigenvalues for equal wheels.
  FastestResponse fastest_response(const TractionMode& mode) const;

  // Wheel commands for a wheel-speed pair: left wheels get `left`, right `right`.
  static std::array<double, kNumWheels> side_commands(double left, double right) { return {left, right, left, right}; }

 private:
  RobotState derivative(const RobotState& s, const std::array<double, kNumWheels>& commands,
                        const TractionMode& mode) const;

  RobotParameters robot_;
};

}  // namespace simulation
}  // namespace skidimm

#endif  // SKIDIMM_SIMULATION_SKID_STEER_DYNAMICS_H_
