// Wheel-ground contact parameters: terrains and per-wheel traction loss.
//
// The simulator is deliberately NOT one of the filter's models: it computes
// tyre forces from slip with a saturating friction law, so that identifying
// modes on its logs tests the IMM honestly. A traction mode assigns a contact
// to each of the four wheels: a terrain for all of them, optionally with some
// wheels wrapped in a tarp (the paper's small-traction-change experiments).
#ifndef SKIDIMM_SIMULATION_TERRAIN_H_
#define SKIDIMM_SIMULATION_TERRAIN_H_

#include <array>
#include <string>
#include <vector>

namespace skidimm {
namespace simulation {

enum Wheel { kFrontLeft = 0, kFrontRight = 1, kRearLeft = 2, kRearRight = 3, kNumWheels = 4 };
inline constexpr const char* kWheelNames[kNumWheels] = {"FL", "FR", "RL", "RR"};

// Simplified Pacejka "magic formula" for the combined slip magnitude sigma:
//   D(sigma) = N sin(shape * atan(stiffness * sigma)),
//   Fx = mu D sx / sigma,   Fy = -mu lateral_ratio D sy / sigma,
// which rises linearly for small slip and saturates at mu N (mu lateral_ratio
// N sideways), plus rolling resistance c_rr N opposing rolling.
// lateral_ratio > 1 models ground that resists sideways sliding more than it
// resists traction (loose or granular soil is bulldozed by a wheel sliding
// sideways). A skid-steer robot must slide its wheels sideways to turn, so
// this ratio, more than mu itself, sets how much of a commanded yaw rate it
// achieves on a terrain.
struct WheelGroundContact {
  double friction = 0.9;              // peak longitudinal friction coefficient mu (-)
  double lateral_ratio = 1.0;         // peak lateral over longitudinal friction (-)
  double stiffness = 10.0;            // Pacejka B (-)
  double shape = 1.9;                 // Pacejka C (-)
  double rolling_resistance = 0.015;  // c_rr (-)
};

struct Terrain {
  std::string name;
  WheelGroundContact contact;
  const char* source;  // why these numbers
};

// The built-in terrains: asphalt, crushed_concrete, grass, ice.
const std::vector<Terrain>& builtin_terrains();
// nullptr if there is no terrain of that name.
const Terrain* find_terrain(const std::string& name);

// A tarp between wheel and ground keeps this fraction of the terrain's
// friction (polyethylene on asphalt: mu about 0.25-0.35 against 0.9).
inline constexpr double kTarpFrictionFactor = 0.35;

struct TractionMode {
  std::string name;
  std::array<WheelGroundContact, kNumWheels> wheels;
};

// A mode on `terrain` with the wheels in `tarp` (names FL, FR, RL, RR)
// wrapped. Throws std::invalid_argument on an unknown terrain or wheel.
TractionMode make_traction_mode(const std::string& name, const std::string& terrain,
                                const std::vector<std::string>& tarp);

}  // namespace simulation
}  // namespace skidimm

#endif  // SKIDIMM_SIMULATION_TERRAIN_H_
