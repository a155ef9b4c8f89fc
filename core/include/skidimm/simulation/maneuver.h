// Driving maneuvers from the paper (section III: "skidpad, clothoids and
// sinusoidal"; section V: the outward spiral), as a desired forward speed and
// yaw rate over time, turned into wheel-speed commands by the ideal
// differential-drive relation. Skid-steering then delivers less yaw than
// commanded, by an amount that depends on the ground: that is the signal.
#ifndef SKIDIMM_SIMULATION_MANEUVER_H_
#define SKIDIMM_SIMULATION_MANEUVER_H_

#include <string>

namespace skidimm {
namespace simulation {

struct Maneuver {
  enum class Type { kStraight, kSkidpad, kClothoid, kSinusoidal, kSpiral };
  Type type = Type::kSpiral;
  double speed = 0.8;               // m/s, reached after `ramp` seconds
  double ramp = 1.0;                // s
  double direction = 1.0;           // +1 turns left (counter-clockwise), -1 right
  double radius = 2.0;              // skidpad: turning radius (m)
  double initial_radius = 0.6;      // spiral: radius at t = 0 (m)
  double radius_rate = 0.12;        // spiral: radius growth (m/s)
  double initial_curvature = 0.0;   // clothoid: curvature at t = 0 (1/m)
  double curvature_rate = 0.1;      // clothoid: curvature growth (1/m/s)
  double yaw_rate_amplitude = 0.8;  // sinusoidal: rad/s
  double period = 6.0;              // sinusoidal: s

  // Desired forward speed v (m/s) and yaw rate omega (rad/s) at time t.
  void desired(double t, double* v, double* omega) const;
};

// "straight", "skidpad", "clothoid", "sinusoidal", "spiral"; false if unknown.
bool parse_maneuver_type(const std::string& name, Maneuver::Type* type);
const char* to_string(Maneuver::Type type);

}  // namespace simulation
}  // namespace skidimm

#endif  // SKIDIMM_SIMULATION_MANEUVER_H_
