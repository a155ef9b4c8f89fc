// Fuzzes the scenario loader (skidimm simulate's YAML). A bad scenario must
// end in a skidimm::Error; any other exception, a crash or a sanitizer report
// is a finding. A scenario that loads is then simulated for at most 2000
// integration steps (1 s at the default step): enough to reach the
// integrator, the sensors and the non-finite-state check without spending
// the fuzzer's time.
#include <algorithm>
#include <cstddef>
#include <cstdint>

#include "fuzz_input_file.h"
#include "skidimm/errors.h"
#include "skidimm/simulation/scenario.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::filesystem::path file = skidimm_fuzz::input_file(".yaml");
  static const std::filesystem::path log = skidimm_fuzz::input_file(".csv");
  skidimm_fuzz::write_input(file, data, size);
  try {
    skidimm::simulation::Scenario scenario = skidimm::simulation::load_scenario(file);
    scenario.duration = std::min(scenario.duration, 2000 * scenario.integration_step);
    skidimm::simulation::simulate(scenario, scenario.seed, log);
  } catch (const skidimm::Error&) {
  }
  return 0;
}
