// Angle helpers shared by plugins and the engine.
#ifndef SKIDIMM_SDK_ANGLES_H_
#define SKIDIMM_SDK_ANGLES_H_

#include <cmath>

namespace skidimm {
namespace sdk {

inline constexpr double kPi = 3.14159265358979323846;

// Wraps an angle to [-pi, pi). Templated so that Ceres jets pass through.
template <typename T>
T wrap_angle(const T& angle) {
  using std::floor;
  const T two_pi = T(2.0 * kPi);
  return angle - two_pi * floor((angle + T(kPi)) / two_pi);
}

}  // namespace sdk
}  // namespace skidimm

#endif  // SKIDIMM_SDK_ANGLES_H_
