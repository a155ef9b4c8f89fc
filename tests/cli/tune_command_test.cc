// `skidimm tune` on real runs.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>

#include "cli/cli_test_support.h"
#include "core/sanitizer.h"
#include "skidimm/config/bank.h"

namespace skidimm_test {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

// On real runs the plain IMM (likelihood weight 1) counts the same evidence
// many times: nine features averaged over overlapping windows, whose errors
// move together. `tune --tune likelihood-weight` leaves the weight at 1
// unless a smaller one scores the held-out runs better, so a weight below 1
// in the written bank is that finding, on runs the fit never saw.
TEST(Cli, TuneTempersTheEvidenceOfABankThatOvercountsItOnRealRuns) {
  SKIDIMM_SKIP_UNDER_SANITIZERS_STATISTICAL();  // Tune.* and HostileInput.Tune* run the same code under them
  const std::string boreal = std::string(SKIDIMM_SHARED_DATA_DIR) + "/borealtc";
  if (!fs::exists(boreal)) GTEST_SKIP() << "no shared data at " << boreal;
  const fs::path dir = test_directory();
  std::string logs;
  for (const std::string terrain : {"FLOORING", "ICE"}) {
    for (const std::string run : {"00", "01", "05"}) {
      if (!fs::exists(boreal + "/" + terrain + "/pro_" + run + ".csv")) continue;
      logs += " --log '" + terrain + "=" + boreal + "/" + terrain + "/pro_" + run + ".csv+" + boreal + "/" + terrain +
              "/imu_" + run + ".csv'";
    }
  }
  const Result tune = run_skidimm("tune --bank " + kSource + "/configs/borealtc/terrains_start.yaml" + logs +
                                  " --objective window --hold-unexcited --full-q --tune likelihood-weight --no-assess"
                                  " --threads 2 --output-bank " +
                                  (dir / "tuned.yaml").string() + " --plugin-path " + kPlugins);
  ASSERT_EQ(tune.exit_code, 0) << tune.err;
  EXPECT_THAT(tune.err, HasSubstr("likelihood weight"));
  const skidimm::BankConfig tuned = skidimm::load_bank_config(dir / "tuned.yaml");
  EXPECT_LT(tuned.likelihood_weight, 0.5) << tune.err;
  EXPECT_THAT(read_file(dir / "tuned.yaml"), HasSubstr("likelihood weight"));  // the header's chosen settings
}

}  // namespace
}  // namespace skidimm_test
