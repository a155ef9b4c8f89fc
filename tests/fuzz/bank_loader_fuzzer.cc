// Fuzzes the bank loader: YAML text -> BankConfig -> models created by the
// bundled plugins -> an Imm. A bad bank must end in a skidimm::Error (a
// message with file, line and field); any other exception, a crash or a
// sanitizer report is a finding.
//
// The registry searches only the build tree's bundled plugins (never the
// input's plugin_paths, which could name any shared library on the machine),
// and lives as long as the process, keeping them loaded: libFuzzer counts
// coverage inside them, and would write to unmapped memory after an unload.
#include <cstddef>
#include <cstdint>
#include <memory>

#include "fuzz_input_file.h"
#include "skidimm/config/bank.h"
#include "skidimm/engine/imm.h"
#include "skidimm/engine/plugin_registry.h"
#include "skidimm/errors.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::filesystem::path file = skidimm_fuzz::input_file(".yaml");
  static skidimm::PluginRegistry registry({SKIDIMM_PLUGIN_DIR});
  skidimm_fuzz::write_input(file, data, size);
  try {
    skidimm::BankConfig config = skidimm::load_bank_config(file);
    skidimm::Bank bank = skidimm::Bank::instantiate(std::move(config), registry);
    // Construction checks the bank against its kernel and allocates the
    // workspaces: part of loading as a user sees it.
    skidimm::Imm imm(std::move(bank));
    (void)imm;
  } catch (const skidimm::Error&) {
    // A clear, located error: what bad input must get.
  }
  return 0;
}
