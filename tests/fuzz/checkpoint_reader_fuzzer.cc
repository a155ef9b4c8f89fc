// Fuzzes checkpoint files: YAML text -> ImmCheckpoint -> restored into an Imm
// of tests/fuzz/checkpoint_bank.yaml (configs/ltc_terrains.yaml with every
// part of the engine that remembers something between steps; the bank the
// seeds were saved from) -> a few steps. A bad file, or one that does not
// fit the bank, must end in a skidimm::Error; one that restores must give
// finite estimates (the engine resets a filter that a restored covariance
// makes diverge). Any other
// exception, a crash, a sanitizer report or a non-finite estimate is a
// finding.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "skidimm/config/bank.h"
#include "skidimm/engine/decision.h"
#include "skidimm/engine/imm.h"
#include "skidimm/engine/plugin_registry.h"
#include "skidimm/errors.h"
#include "skidimm/io/checkpoint_file.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static skidimm::PluginRegistry registry({SKIDIMM_PLUGIN_DIR});
  static const skidimm::Bank bank = skidimm::Bank::instantiate(
      skidimm::load_bank_config(std::string(SKIDIMM_SOURCE_DIR) + "/tests/fuzz/checkpoint_bank.yaml"), registry);
  try {
    const skidimm::ImmCheckpoint checkpoint =
        skidimm::parse_checkpoint(std::string(reinterpret_cast<const char*>(data), size), "fuzz.yaml");
    skidimm::Imm imm(bank);
    imm.restore(checkpoint);
    skidimm::ModeDecision decision(bank.config);
    if (checkpoint.decision) decision.restore(*checkpoint.decision);
    const double t0 = checkpoint.started ? checkpoint.t : 0.0;
    for (int k = 1; k <= 3; ++k) {
      const skidimm::ImmEstimate& e =
          imm.step(t0 + 0.02 * k, Eigen::Vector2d(1.0, 1.2), Eigen::Vector2d(0.3, k == 2 ? NAN : 0.05));
      decision.update(e.t, e.mode_probabilities, e.measured());
      const bool accepted = e.status != skidimm::StepStatus::kRejectedTime;
      if (accepted && (!e.state.allFinite() || !e.covariance.allFinite() || !e.mode_probabilities.allFinite())) {
        std::fprintf(stderr, "a restored checkpoint gave a non-finite estimate at step %d\n", k);
        std::abort();
      }
    }
  } catch (const skidimm::Error&) {
    // A clear, located error: what bad input must get.
  }
  return 0;
}
