// `skidimm simulate`: the bundled example logs come from their scenarios.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>

#include "cli/cli_test_support.h"

namespace skidimm_test {
namespace {

namespace fs = std::filesystem;

TEST(Cli, BundledExampleLogsAreReproducibleFromTheirScenarios) {
  const fs::path dir = test_directory();
  for (const std::string name : {"ltc_switching", "stc_switching"}) {
    const fs::path out = dir / (name + ".csv");
    const Result r = run_skidimm("simulate -q --scenario " + kSource + "/configs/scenarios/" + name +
                                 ".yaml --output " + out.string());
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(read_file(out), read_file(kSource + "/configs/examples/" + name + ".csv"))
        << "regenerate with scripts/make_examples.sh";
  }
}

}  // namespace
}  // namespace skidimm_test
