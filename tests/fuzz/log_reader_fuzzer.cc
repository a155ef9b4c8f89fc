// Fuzzes the CSV log reader with the bundled ltc_terrains bank (columns t,
// phi_dot_L, phi_dot_R, V, omega, mode), and runs the IMM over every row it
// reads, as `skidimm run` does. Bad input must end in a skidimm::Error; any
// other exception, a crash or a sanitizer report is a finding.
//
// It also aborts on an estimate with a non-finite state or a negative
// variance: the engine guarantees neither can be written, whatever the input
// (a measurement of 1e150 once gave one). SKIDIMM_FUZZ_CHECK_ESTIMATES=0
// turns that check off, to hunt memory and undefined-behaviour findings only.

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <optional>

#include "fuzz_input_file.h"
#include "skidimm/config/bank.h"
#include "skidimm/engine/imm.h"
#include "skidimm/engine/plugin_registry.h"
#include "skidimm/errors.h"
#include "skidimm/io/log_reader.h"

namespace {

bool check_estimates() {
  const char* value = std::getenv("SKIDIMM_FUZZ_CHECK_ESTIMATES");
  return value == nullptr || std::strcmp(value, "0") != 0;
}

void check(const skidimm::ImmEstimate& estimate, long row) {
  for (Eigen::Index i = 0; i < estimate.state.size(); ++i) {
    if (!std::isfinite(estimate.state[i]) || !(estimate.covariance(i, i) >= 0.0)) {
      std::fprintf(stderr, "row %ld: state %d is %g with variance %g\n", row, static_cast<int>(i), estimate.state[i],
                   estimate.covariance(i, i));
      std::abort();
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::filesystem::path file = skidimm_fuzz::input_file(".csv");
  static const bool checking = check_estimates();
  // The registry lives as long as the process: it keeps every plugin it
  // examined loaded. A plugin unloaded while libFuzzer still counts coverage
  // in it would make libFuzzer write to unmapped memory.
  static skidimm::PluginRegistry registry({SKIDIMM_PLUGIN_DIR});
  static std::optional<skidimm::Imm> imm;
  if (!imm) {
    imm.emplace(skidimm::Bank::instantiate(
        skidimm::load_bank_config(std::filesystem::path(SKIDIMM_SOURCE_DIR) / "configs/ltc_terrains.yaml"), registry));
  }
  skidimm_fuzz::write_input(file, data, size);
  imm->reset();
  try {
    skidimm::LogReader reader(imm->config(), {file});
    skidimm::LogSample sample;
    while (reader.next(&sample)) {
      const skidimm::ImmEstimate& estimate = imm->step(sample.t, sample.u, sample.z);
      if (checking) check(estimate, sample.row);
    }
    (void)reader.describe_stats(imm->config());
  } catch (const skidimm::Error&) {
  }
  return 0;
}
