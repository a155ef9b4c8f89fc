#include "skidimm/simulation/terrain.h"

#include <stdexcept>

namespace skidimm {
namespace simulation {

const std::vector<Terrain>& builtin_terrains() {
  // Peak friction from the usual tyre-road tables (dry asphalt 0.8-1.0,
  // gravel/crushed stone 0.6-0.75, dry grass 0.4-0.55, ice 0.05-0.15).
  // Loose ground deforms before it shears, so its slip curve is flatter
  // (smaller B) and it resists rolling more (larger c_rr: hard surfaces
  // 0.01-0.02, gravel 0.03-0.05, grass 0.05-0.10). It also resists a wheel
  // sliding sideways more than one rolling through it: aggregate piles up in
  // front of the sliding tyre, turf holds it; paved and frozen surfaces are
  // close to isotropic. The lateral ratios are assumptions chosen within that
  // ordering (terramechanics gives lateral-resistance coefficients of skid
  // steering that grow on loose soil); fit them to data where you have it.
  static const std::vector<Terrain> terrains = {
      {"asphalt", {0.90, 1.00, 12.0, 1.9, 0.015}, "dry asphalt: high, isotropic, sharply peaking friction"},
      {"crushed_concrete",
       {0.70, 1.60, 6.0, 1.9, 0.050},
       "coarse granular aggregate: soft traction, high sideways resistance, rolling loss"},
      {"grass", {0.55, 1.25, 5.0, 1.9, 0.080}, "dry grass on soil: low, soft friction, high rolling loss"},
      {"ice", {0.10, 1.00, 8.0, 1.9, 0.010}, "ice: very low, isotropic friction"},
  };
  return terrains;
}

const Terrain* find_terrain(const std::string& name) {
  for (const Terrain& t : builtin_terrains()) {
    if (t.name == name) return &t;
  }
  return nullptr;
}

TractionMode make_traction_mode(const std::string& name, const std::string& terrain,
                                const std::vector<std::string>& tarp) {
  const Terrain* ground = find_terrain(terrain);
  if (ground == nullptr) {
    std::string known;
    for (const Terrain& t : builtin_terrains()) known += (known.empty() ? "" : ", ") + t.name;
    throw std::invalid_argument("unknown terrain '" + terrain + "' (known: " + known + ")");
  }
  TractionMode mode;
  mode.name = name;
  mode.wheels.fill(ground->contact);
  for (const std::string& wheel : tarp) {
    int index = -1;
    for (int w = 0; w < kNumWheels; ++w) {
      if (wheel == kWheelNames[w]) index = w;
    }
    if (index < 0) throw std::invalid_argument("unknown wheel '" + wheel + "' (wheels: FL, FR, RL, RR)");
    mode.wheels[index].friction *= kTarpFrictionFactor;
  }
  return mode;
}

}  // namespace simulation
}  // namespace skidimm
