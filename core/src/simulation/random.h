// Random draws that give the same numbers on every platform: mt19937_64 is
// specified bit for bit by the standard, its distributions are not, so the
// uniform and Gaussian transforms are our own. A seed reproduces a log byte
// for byte anywhere.
#ifndef SKIDIMM_CORE_SRC_SIMULATION_RANDOM_H_
#define SKIDIMM_CORE_SRC_SIMULATION_RANDOM_H_

#include <cmath>
#include <cstdint>
#include <random>

#include "skidimm/sdk/angles.h"

namespace skidimm {
namespace simulation {

class Random {
 public:
  explicit Random(std::uint64_t seed) : engine_(seed) {}
  // Uniform on (0, 1), never 0 or 1.
  double uniform() { return (static_cast<double>(engine_() >> 11) + 0.5) * (1.0 / 9007199254740992.0); }
  // Standard normal (Box-Muller).
  double gaussian() {
    const double u1 = uniform(), u2 = uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * sdk::kPi * u2);
  }

 private:
  std::mt19937_64 engine_;
};

}  // namespace simulation
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_SIMULATION_RANDOM_H_
