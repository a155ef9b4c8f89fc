// `skidimm simulate`: the bundled example logs come from their scenarios.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>

#include "cli/cli_test_support.h"
#include "skidimm/io/csv.h"

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
    EXPECT_EQ(r.err, "") << "a robot that follows its maneuver gets no warning";
    EXPECT_EQ(read_file(out), read_file(kSource + "/configs/examples/" + name + ".csv"))
        << "regenerate with scripts/make_examples.sh";
  }
}

// The log whose inputs drive the models, given as the output too: refused,
// the log kept.
TEST(Cli, SimulateRefusesToWriteOverTheLogItReads) {
  const fs::path dir = test_directory();
  const fs::path log = write_file(dir / "log.csv", read_file(kSwitching));
  const Result r = run_skidimm("simulate -q --bank " + kTerrains + " --plugin-path " + kPlugins + " --inputs-from " +
                               log.string() + " --output " + (dir / "." / "log.csv").string());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, ::testing::HasSubstr("--output " + (dir / "." / "log.csv").string() + " is the log file " +
                                          log.string() + " itself"));
  EXPECT_EQ(read_file(log), read_file(kSwitching));
  // Nor over the scenario it reads.
  const fs::path scenario =
      write_file(dir / "scenario.yaml", read_file(kSource + "/configs/scenarios/ltc_switching.yaml"));
  const Result over_scenario = run_skidimm("simulate -q --scenario " + scenario.string() + " --output " +
                                           (dir / "." / "scenario.yaml").string());
  EXPECT_EQ(over_scenario.exit_code, 1);
  EXPECT_THAT(over_scenario.err, ::testing::HasSubstr("is the file of --scenario (" + scenario.string() + ")"));
  EXPECT_EQ(read_file(scenario), read_file(kSource + "/configs/scenarios/ltc_switching.yaml"));
}

// A bank that reads its time column in ms (columns.time_unit) gets its
// simulated log stamped in ms, so that it runs on what it simulated: the
// same times, in seconds, as the bank in seconds gives.
TEST(Cli, SimulateStampsTheLogInTheUnitTheBankReads) {
  const fs::path dir = test_directory();
  std::string text = read_file(kTerrains);
  ASSERT_NE(text.find("  time: t\n"), std::string::npos);
  text.replace(text.find("  time: t\n"), 10, "  time: t\n  time_unit: ms\n");
  const fs::path ms_bank = write_file(dir / "ms.yaml", text);
  std::vector<std::vector<std::string>> rows = read_csv(kSwitching);
  const auto t = static_cast<std::size_t>(column(rows[0], "t"));
  for (std::size_t i = 1; i < rows.size(); ++i) rows[i][t] = skidimm::CsvWriter::format(std::stod(rows[i][t]) * 1000.0);
  const fs::path ms_log = write_file(dir / "ms.csv", csv_text(rows));
  const Result sim =
      run_skidimm("simulate -q --bank " + ms_bank.string() + " --plugin-path " + kPlugins + " --seed 3 --inputs-from " +
                  ms_log.string() + " --output " + (dir / "sim.csv").string());
  ASSERT_EQ(sim.exit_code, 0) << sim.err;
  const std::vector<std::vector<std::string>> simulated = read_csv(dir / "sim.csv");
  EXPECT_EQ(simulated[2][0], rows[2][t]) << "in ms, as the log it was driven by";
  const Result run = run_skidimm("run -q --bank " + ms_bank.string() + " --plugin-path " + kPlugins + " --input " +
                                 (dir / "sim.csv").string() + " --output " + (dir / "out.csv").string());
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(read_csv(dir / "out.csv")[2][0], read_csv(kSwitching)[2][t]) << "read back in seconds";
  // The copy --output-bank writes reads the log in the same unit (it dropped time_unit, and read ms as s).
  const Result copy = run_skidimm("simulate -q --bank " + ms_bank.string() + " --plugin-path " + kPlugins +
                                  " --seed 3 --inputs-from " + ms_log.string() + " --output " +
                                  (dir / "sim2.csv").string() + " --output-bank " + (dir / "copy.yaml").string());
  ASSERT_EQ(copy.exit_code, 0) << copy.err;
  EXPECT_THAT(read_file(dir / "copy.yaml"), ::testing::HasSubstr("  time_unit: ms\n"));
  const Result with_copy =
      run_skidimm("run -q --bank " + (dir / "copy.yaml").string() + " --plugin-path " + kPlugins + " --input " +
                  (dir / "sim2.csv").string() + " --output " + (dir / "out2.csv").string());
  ASSERT_EQ(with_copy.exit_code, 0) << with_copy.err;
  EXPECT_EQ(read_file(dir / "out2.csv"), read_file(dir / "out.csv"));
}

// A bank that reads expressions (BorealTC's: inputs from wheel speeds,
// measurements aggregated over a step) cannot read the log of its own
// models back, which has them under their own names: simulate says so, and
// --output-bank writes the copy that reads it, with which the log runs and
// its truth is found. A bank of plain columns reads its log as it is.
TEST(Cli, SimulateWritesTheBankThatReadsTheLogOfABankOfExpressions) {
  const std::string boreal = std::string(SKIDIMM_SHARED_DATA_DIR) + "/borealtc";
  if (!fs::exists(boreal)) GTEST_SKIP() << "no shared data at " << boreal;
  const fs::path dir = test_directory();
  const std::string bank = kSource + "/configs/borealtc/terrains.yaml";
  const std::string simulate = "simulate --bank " + bank + " --plugin-path " + kPlugins +
                               " --inputs-from 'ICE_straight=" + boreal + "/ICE/pro_00.csv+" + boreal +
                               "/ICE/imu_00.csv' --seed 3 --output " + (dir / "log.csv").string();
  const Result alone = run_skidimm(simulate);
  ASSERT_EQ(alone.exit_code, 0) << alone.err;
  EXPECT_THAT(alone.err, ::testing::HasSubstr("the log has speed, turn, dv, omega, current, "));
  EXPECT_THAT(alone.err,
              ::testing::HasSubstr("so the bank cannot read it back; --output-bank writes a copy of the bank"));
  const Result unread = run_skidimm("run --bank " + bank + " --plugin-path " + kPlugins + " --input " +
                                    (dir / "log.csv").string() + " --output " + (dir / "unread.csv").string());
  EXPECT_EQ(unread.exit_code, 1);
  EXPECT_THAT(unread.err, ::testing::HasSubstr("no column 'velL'"));
  const Result with_bank = run_skidimm(simulate + " --output-bank " + (dir / "reads.yaml").string());
  ASSERT_EQ(with_bank.exit_code, 0) << with_bank.err;
  EXPECT_THAT(with_bank.err, ::testing::HasSubstr("wrote " + (dir / "reads.yaml").string()));
  EXPECT_THAT(read_file(dir / "reads.yaml"), ::testing::HasSubstr("    speed: speed\n"));
  const Result run = run_skidimm("run --bank " + (dir / "reads.yaml").string() + " --plugin-path " + kPlugins +
                                 " --input " + (dir / "log.csv").string() + " --output " + (dir / "run.csv").string());
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_THAT(run.err, ::testing::HasSubstr("most likely mode equals column 'terrain' on"));
  const Result plain = run_skidimm("simulate --bank " + kTerrains + " --plugin-path " + kPlugins + " --inputs-from " +
                                   kSwitching + " --output " + (dir / "plain.csv").string());
  ASSERT_EQ(plain.exit_code, 0) << plain.err;
  EXPECT_THAT(plain.err, ::testing::Not(::testing::HasSubstr("cannot read it back")));
  const Result scenario =
      run_skidimm("simulate --scenario " + kSource + "/configs/scenarios/ltc_switching.yaml" + " --output " +
                  (dir / "s.csv").string() + " --output-bank " + (dir / "s.yaml").string());
  EXPECT_EQ(scenario.exit_code, 2);
  EXPECT_THAT(scenario.err, ::testing::HasSubstr("--output-bank writes a bank given with --bank, not a scenario"));
}

// A simulation that stops on a state it cannot integrate keeps the rows
// before it in the .partial file, and says so (it said nothing of them).
TEST(Cli, ASimulationThatFailsSaysWhereItsRowsAre) {
  const fs::path dir = test_directory();
  std::string scenario = read_file(kSource + "/configs/scenarios/ltc_switching.yaml");
  scenario.replace(scenario.find("speed: 0.8"), 10, "speed: 1e308");
  const fs::path file = write_file(dir / "fast.yaml", scenario);
  const Result r = run_skidimm("simulate --scenario " + file.string() + " --output " + (dir / "log.csv").string());
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_THAT(r.err, ::testing::HasSubstr("the simulated state is not finite at t = "));
  EXPECT_THAT(r.err, ::testing::HasSubstr("the rows simulated before the error are in " + (dir / "log.csv").string() +
                                          ".partial"));
  EXPECT_TRUE(fs::exists(dir / "log.csv.partial"));
  EXPECT_FALSE(fs::exists(dir / "log.csv"));
}

// A bank's model whose prediction is not finite stops the simulation there,
// naming the mode, its plugin and why: it wrote NaN into the log's rows
// without a word, or failed a step later blaming the next mode.
TEST(Cli, ABanksModelThatPredictsNaNIsNamedWhereItFails) {
  const fs::path dir = test_directory();
  const Result r = run_skidimm("simulate --bank " + faulty_bank(dir, "nan").string() + " --inputs-from " +
                               write_file(dir / "slippery.csv", slippery_switching_log()).string() + " --output " +
                               (dir / "log.csv").string() + " --plugin-path " + kPlugins + " --plugin-path " +
                               kFixturePlugins + "/faulty");
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_THAT(r.err, ::testing::HasSubstr("mode 'slippery' (plugin faulty_model 0.0.2"));
  EXPECT_THAT(r.err, ::testing::HasSubstr("could not propagate the state at t = "));
  EXPECT_THAT(r.err, ::testing::HasSubstr(": predict() returned a state that is not finite"));
  EXPECT_FALSE(fs::exists(dir / "log.csv"));
}

// A maneuver faster than the robot can drive on its terrain (1e6 m/s) runs,
// but its log is of wheels spinning under a body that cannot keep up: a
// warning says so, naming the scenario, the speeds and what to change.
TEST(Cli, SimulateWarnsWhenTheRobotCannotFollowTheManeuversSpeed) {
  const fs::path dir = test_directory();
  std::string scenario = read_file(kSource + "/configs/scenarios/ltc_switching.yaml");
  scenario.replace(scenario.find("speed: 0.8"), 10, "speed: 1e6");
  const fs::path file = write_file(dir / "fast.yaml", scenario);
  const Result r = run_skidimm("simulate -q --scenario " + file.string() + " --output " + (dir / "log.csv").string());
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.err, ::testing::HasSubstr("skidimm simulate: warning: " + file.string() +
                                          ": the body never went half the maneuver's commanded speed (at most "));
  EXPECT_THAT(r.err, ::testing::HasSubstr(" m/s where it commanded 1e+06 m/s)"));
  EXPECT_THAT(r.err, ::testing::HasSubstr("lower maneuver.speed"));
  EXPECT_TRUE(fs::exists(dir / "log.csv"));
  // A short run of a bundled scenario is mostly its start from rest, which
  // is not counted: no warning.
  const Result short_run =
      run_skidimm("simulate -q --duration 1 --scenario " + kSource + "/configs/scenarios/stc_switching.yaml --output " +
                  (dir / "short.csv").string());
  EXPECT_EQ(short_run.exit_code, 0) << short_run.err;
  EXPECT_EQ(short_run.err, "");
}

// A switch the scenario's own duration never reaches (a typo in `at`) is
// named; a --duration shorter than the schedule asks for the cut.
TEST(Cli, SimulateWarnsOfASwitchAfterTheScenariosEnd) {
  const fs::path dir = test_directory();
  std::string scenario = read_file(kSource + "/configs/scenarios/ltc_switching.yaml");
  scenario.replace(scenario.find("{at: 20, mode: asphalt}"), 23, "{at: 40, mode: asphalt}");
  const fs::path file = write_file(dir / "late.yaml", scenario);
  const Result r = run_skidimm("simulate -q --scenario " + file.string() + " --output " + (dir / "a.csv").string());
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.err, ::testing::HasSubstr("skidimm simulate: warning: " + file.string() +
                                          ": schedule[2] (at 40 s, mode 'asphalt') starts when the run of 30 s has "
                                          "ended: it is not driven"));
  const Result cut = run_skidimm("simulate -q --duration 15 --scenario " + kSource +
                                 "/configs/scenarios/ltc_switching.yaml --output " + (dir / "b.csv").string());
  EXPECT_EQ(cut.exit_code, 0) << cut.err;
  EXPECT_EQ(cut.err, "");
}

// --seed takes what a scenario's `seed:` takes: -1 ran with seed 2^64 - 1,
// and 2^64 or more clamped to it, so different seeds gave one log.
TEST(Cli, SimulateTakesAWholeSeedOf64BitsAndRefusesTheRest) {
  const std::string simulate =
      "simulate -q --scenario " + kSource + "/configs/scenarios/ltc_switching.yaml --output /dev/null --seed ";
  for (const std::string seed : {"-1", "-5", "18446744073709551616", "1e3", "7.5", ""}) {
    const Result r = run_skidimm(simulate + "'" + seed + "'");
    EXPECT_EQ(r.exit_code, 2) << seed << ": " << r.err;
    EXPECT_THAT(r.err, ::testing::HasSubstr("--seed: expected a whole number from 0 to 18446744073709551615, got '" +
                                            seed + "'"));
  }
  EXPECT_EQ(run_skidimm(simulate + "18446744073709551615").exit_code, 0);
}

}  // namespace
// Outputs written after the work are checked before it: a bank or a figure
// in a missing directory failed only once the simulation or the run was done.
TEST(CliIo, OutputsWrittenAfterTheWorkAreCheckedBeforeIt) {
  const fs::path dir = test_directory();
  const fs::path missing = dir / "no_such_directory";
  const Result simulated =
      run_skidimm("simulate --bank " + kTerrains + " --plugin-path " + kPlugins + " --inputs-from " + kSwitching +
                  " --output " + (dir / "sim.csv").string() + " --output-bank " + (missing / "b.yaml").string());
  EXPECT_EQ(simulated.exit_code, 1);
  EXPECT_THAT(simulated.err, HasSubstr("--output-bank " + (missing / "b.yaml").string() +
                                       ": cannot write there: No such file or directory"));
  EXPECT_FALSE(fs::exists(dir / "sim.csv"));
  EXPECT_FALSE(fs::exists(dir / "sim.csv.partial"));
  const Result ran =
      run_skidimm("run -q --bank " + kTerrains + " --plugin-path " + kPlugins + " --input " + kSwitching +
                  " --output " + (dir / "out.csv").string() + " --plot " + (missing / "fig.png").string());
  EXPECT_EQ(ran.exit_code, 1);
  EXPECT_THAT(ran.err, HasSubstr("--plot " + (missing / "fig.png").string() +
                                 ": cannot write there: No such file or directory"));
  EXPECT_FALSE(fs::exists(dir / "out.csv.partial"));
}

// A class label (the truth of a BorealTC run) names several modes, and each
// step is simulated by one: the error says so and what to label the log with.
TEST(CliIo, SimulateSaysAClassLabelNamesSeveralModes) {
  const fs::path dir = test_directory();
  const fs::path bank =
      write_file(dir / "paved.yaml", read_file(kTerrains) + "\nclasses:\n  paved: [asphalt, crushed_concrete]\n");
  const Result r = run_skidimm("simulate --bank " + bank.string() + " --plugin-path " + kPlugins +
                               " --inputs-from paved=" + kSwitching + " --output " + (dir / "sim.csv").string());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("step at t = 0: 'paved' is a class of bank 'ltc_terrains' (its modes: asphalt, "
                               "crushed_concrete), and each step is simulated by one mode: label the log with one of "
                               "them (asphalt=...)"));
}

}  // namespace skidimm_test
