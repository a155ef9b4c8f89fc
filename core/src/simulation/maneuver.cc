#include "skidimm/simulation/maneuver.h"

#include <algorithm>
#include <cmath>

namespace skidimm {
namespace simulation {

void Maneuver::desired(double t, double* v, double* omega) const {
  const double ramp_factor = ramp > 0.0 ? std::min(1.0, t / ramp) : 1.0;
  *v = speed * ramp_factor;
  double curvature = 0.0;
  switch (type) {
    case Type::kStraight:
      break;
    case Type::kSkidpad:
      curvature = 1.0 / radius;
      break;
    case Type::kClothoid:
      curvature = initial_curvature + curvature_rate * t;
      break;
    case Type::kSpiral:
      curvature = 1.0 / (initial_radius + radius_rate * t);
      break;
    case Type::kSinusoidal:
      *omega = direction * ramp_factor * yaw_rate_amplitude * std::sin(2.0 * 3.14159265358979323846 * t / period);
      return;
  }
  *omega = direction * *v * curvature;
}

bool parse_maneuver_type(const std::string& name, Maneuver::Type* type) {
  const std::pair<const char*, Maneuver::Type> names[] = {{"straight", Maneuver::Type::kStraight},
                                                          {"skidpad", Maneuver::Type::kSkidpad},
                                                          {"clothoid", Maneuver::Type::kClothoid},
                                                          {"sinusoidal", Maneuver::Type::kSinusoidal},
                                                          {"spiral", Maneuver::Type::kSpiral}};
  for (const auto& [text, value] : names) {
    if (name == text) {
      *type = value;
      return true;
    }
  }
  return false;
}

const char* to_string(Maneuver::Type type) {
  switch (type) {
    case Maneuver::Type::kStraight:
      return "straight";
    case Maneuver::Type::kSkidpad:
      return "skidpad";
    case Maneuver::Type::kClothoid:
      return "clothoid";
    case Maneuver::Type::kSinusoidal:
      return "sinusoidal";
    case Maneuver::Type::kSpiral:
      return "spiral";
  }
  return "unknown";
}

}  // namespace simulation
}  // namespace skidimm
