// Fuzzes the reader of `skidimm run` outputs (skidimm eval --estimates),
// without a bank (every mu_ column is a mode) and with the ltc_terrains bank.
// Bad input must end in a skidimm::Error; any other exception, a crash or a
// sanitizer report is a finding.
#include <cstddef>
#include <cstdint>

#include "evaluation/estimates_reader.h"
#include "fuzz_input_file.h"
#include "skidimm/config/bank.h"
#include "skidimm/errors.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::filesystem::path file = skidimm_fuzz::input_file(".csv");
  static const skidimm::BankConfig bank =
      skidimm::load_bank_config(std::filesystem::path(SKIDIMM_SOURCE_DIR) / "configs/ltc_terrains.yaml");
  skidimm_fuzz::write_input(file, data, size);
  for (const skidimm::BankConfig* with : {static_cast<const skidimm::BankConfig*>(nullptr), &bank}) {
    try {
      (void)skidimm::evaluation::evaluate_estimates(file, with);
    } catch (const skidimm::Error&) {
    }
  }
  return 0;
}
