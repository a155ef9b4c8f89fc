// `skidimm run` end to end on real files: the bundled examples' terrains and
// slips, logs in several files at several rates, pipes and FIFOs, rows
// flushed one by one, a plugin that throws, bad banks and rows, outliers from
// 1e6 to 1e300, and --strict.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "cli/cli_test_support.h"

namespace skidimm_test {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
namespace fs = std::filesystem;

TEST(Cli, RunIdentifiesTheTerrainsOfTheBundledSwitchingExample) {
  const fs::path out = test_directory() / "out.csv";
  const std::string input = kSource + "/configs/examples/ltc_switching.csv";
  const Result r = run_skidimm("run --bank " + kSource + "/configs/ltc_terrains.yaml --input " + input + " --output " +
                               out.string() + " --plugin-path " + kPlugins);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto rows = read_csv(out);
  EXPECT_EQ(rows[0],
            (std::vector<std::string>{"t", "mu_asphalt", "mu_grass", "mu_crushed_concrete", "V", "omega", "var_V",
                                      "var_omega", "mode", "decision", "truth_mode", "status", "reason"}));
  EXPECT_EQ(rows.size(), read_csv(input).size()) << "one output row per input row";
  // The decision: unknown until confident, then one change per true switch (the argmax changes 20 times here).
  long decision_changes = 0, decision_right = 0;
  const int decision = column(rows[0], "decision"), truth = column(rows[0], "truth_mode");
  EXPECT_EQ(rows[1][static_cast<std::size_t>(decision)], "unknown");
  for (std::size_t i = 2; i < rows.size(); ++i) {
    decision_changes += rows[i][static_cast<std::size_t>(decision)] != rows[i - 1][static_cast<std::size_t>(decision)];
    decision_right += rows[i][static_cast<std::size_t>(decision)] == rows[i][static_cast<std::size_t>(truth)];
  }
  EXPECT_EQ(decision_changes, 3) << "unknown -> crushed concrete -> grass -> asphalt";
  EXPECT_GT(static_cast<double>(decision_right) / static_cast<double>(rows.size() - 2), 0.95);
  // The first decision, out of the leading unknown, is not a change: the
  // summary counts as eval's changes per minute do.
  long unknown = 0;
  for (std::size_t i = 1; i < rows.size(); ++i) unknown += rows[i][static_cast<std::size_t>(decision)] == "unknown";
  char share[32];
  std::snprintf(share, sizeof share, "%.1f%%",
                100.0 * static_cast<double>(unknown) / static_cast<double>(rows.size() - 1));
  EXPECT_THAT(r.err,
              HasSubstr("the decision (enter 0.9, leave 0.05, hold 1 s) changed 2 time(s) and was `unknown` on " +
                        std::string(share) + " of the rows, the most likely mode changed 19 time(s)"));
  // The first step, all three modes at 1/3, names none of them, and leaving it is no change.
  EXPECT_THAT(r.err, HasSubstr("0.000 -      0.000 s  (a tie)           (1 steps, mean p = 0.333)"));
  EXPECT_THAT(r.err, Not(HasSubstr("decides more often with a lower enter"))) << "decided most of the time";
  const Result eval = run_skidimm("eval --estimates " + out.string() + " --json");
  ASSERT_EQ(eval.exit_code, 0) << eval.err;
  const YAML::Node evaluated = YAML::Load(eval.out);  // JSON is YAML
  const double minutes = evaluated["overall"]["duration"].as<double>() / 60.0;
  EXPECT_NEAR(evaluated["overall"]["changes_per_minute"]["decision"].as<double>() * minutes, 2.0, 1e-3);
  long correct = 0;
  for (std::size_t i = 1; i < rows.size(); ++i) {
    const double sum = std::stod(rows[i][1]) + std::stod(rows[i][2]) + std::stod(rows[i][3]);
    ASSERT_NEAR(sum, 1.0, 1e-9) << "row " << i;
    correct += rows[i][column(rows[0], "mode")] == rows[i][column(rows[0], "truth_mode")];
  }
  const double accuracy = static_cast<double>(correct) / static_cast<double>(rows.size() - 1);
  EXPECT_GT(accuracy, 0.85);
  // The timeline on stderr shows the three terrains in the order driven.
  const auto concrete = r.err.find("crushed_concrete");
  const auto grass = r.err.find("grass", concrete);
  const auto asphalt = r.err.find("asphalt", grass);
  EXPECT_NE(concrete, std::string::npos) << r.err;
  EXPECT_NE(grass, std::string::npos) << r.err;
  EXPECT_NE(asphalt, std::string::npos) << r.err;
  EXPECT_THAT(r.err, HasSubstr("most likely mode equals column 'mode' on"));
  EXPECT_THAT(r.err, Not(HasSubstr("counts for its class")));  // a bank without classes scores its modes
  EXPECT_FALSE(fs::exists(out.string() + ".partial"));
}

// With every sensor silent the probabilities only relax, and the decision
// is given up after decision.stale_after seconds: by default the bank's
// shortest mean dwell time (10 s here), or --decision-stale-after's, 0
// never. The switching example's V and omega blanked from 5 s to 25 s.
TEST(Cli, RunGivesTheDecisionUpWhenTheSensorsFallSilent) {
  const fs::path dir = capture_directory("run_stale_decision");
  std::vector<std::vector<std::string>> rows = read_csv(kSwitching);
  const int t = column(rows[0], "t"), v = column(rows[0], "V"), omega = column(rows[0], "omega");
  for (std::size_t i = 1; i < rows.size(); ++i) {
    const double time = std::stod(rows[i][static_cast<std::size_t>(t)]);
    if (time >= 5.0 && time < 25.0)
      rows[i][static_cast<std::size_t>(v)] = rows[i][static_cast<std::size_t>(omega)] = "";
  }
  const fs::path log = dir / "silent.csv";
  std::ofstream(log) << csv_text(rows);
  // The decision at each output row of the silence, after `seconds` of it.
  const auto unknown_share = [&](const std::string& stale, double from, double to) {
    const fs::path out = dir / ("out" + stale + ".csv");
    const Result r = run_pipeline(run_command(kTerrains, log.string(), out.string()) +
                                  (stale.empty() ? "" : " --decision-stale-after " + stale));
    EXPECT_EQ(r.exit_code, 0) << r.err;
    const std::vector<std::vector<std::string>> estimates = read_csv(out);
    const int et = column(estimates[0], "t"), decision = column(estimates[0], "decision");
    long in = 0, unknown = 0;
    for (std::size_t i = 1; i < estimates.size(); ++i) {
      const double time = std::stod(estimates[i][static_cast<std::size_t>(et)]);
      if (time < 5.0 + from || time >= 5.0 + to) continue;
      ++in;
      unknown += estimates[i][static_cast<std::size_t>(decision)] == "unknown";
    }
    EXPECT_GT(in, 0);
    return in > 0 ? static_cast<double>(unknown) / static_cast<double>(in) : -1.0;
  };
  EXPECT_EQ(unknown_share("", 0.5, 9.5), 0.0) << "within the bank's dwell time";
  EXPECT_EQ(unknown_share("", 10.5, 19.5), 1.0) << "after it";
  EXPECT_EQ(unknown_share("3", 3.5, 19.5), 1.0);
  EXPECT_EQ(unknown_share("0", 0.5, 19.5), 0.0) << "never";
  const Result negative =
      run_skidimm("run --bank " + kTerrains + " --input " + log.string() + " --output - --decision-stale-after -1");
  EXPECT_NE(negative.exit_code, 0);
  EXPECT_THAT(negative.err, HasSubstr("--decision-stale-after"));
  // The summary names the stale time given.
  const Result said =
      run_skidimm("run --bank " + kTerrains + " --plugin-path " + kPlugins + " --input " + log.string() + " --output " +
                  (dir / "said.csv").string() + " --decision-stale-after 3");
  EXPECT_EQ(said.exit_code, 0) << said.err;
  EXPECT_THAT(said.err, HasSubstr("the decision (enter 0.9, leave 0.05, hold 1 s, stale after 3 s) changed"));
  // A smoothed decision never goes stale: the option is refused there.
  for (const std::string smoothing : {" --smooth", " --lag 1"}) {
    const Result smoothed = run_skidimm("run --bank " + kTerrains + " --input " + log.string() + " --output " +
                                        (dir / "smoothed.csv").string() + smoothing + " --decision-stale-after 3");
    EXPECT_EQ(smoothed.exit_code, 2) << smoothing;
    EXPECT_THAT(smoothed.err, HasSubstr("--decision-stale-after does nothing with")) << smoothing;
  }
  // A decision made again from the file goes stale by its status column
  // (predict_only through the silence), as the run's own does.
  const std::string estimates = (dir / "out.csv").string();
  const auto unknown_in_eval = [&](const std::string& stale) {
    const Result r = run_skidimm("eval --json --estimates " + estimates + " --bank " + kTerrains +
                                 " --decision-stale-after " + stale);
    EXPECT_EQ(r.exit_code, 0) << r.err;
    const YAML::Node report = YAML::Load(r.out);
    return report["overall"]["decision"]["unknown_fraction"].as<double>();
  };
  EXPECT_GT(unknown_in_eval("3"), unknown_in_eval("10") + 0.05);
  EXPECT_LT(unknown_in_eval("0"), unknown_in_eval("10"));
}

// With classes, run's summary scores the most likely mode by rows and eval
// the most likely class (its modes' probabilities summed) by time, which
// differ; the summary line says so, so that the two numbers are not taken
// for one.
TEST(Cli, RunSaysHowItsAccuracyOfABankWithClassesDiffersFromEvals) {
  const fs::path dir = test_directory();
  const fs::path bank = write_file(dir / "paved.yaml", read_file(kTerrains) +
                                                           "\nclasses:\n  paved: [asphalt, crushed_concrete]\n"
                                                           "  soft: [grass]\n");
  const Result r = run_skidimm("run --bank " + bank.string() + " --plugin-path " + kPlugins + " --input " + kSwitching +
                               " --output " + (dir / "out.csv").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.err, HasSubstr("labelled rows (a mode counts for its class; `skidimm eval` scores the most likely "
                               "class, its modes' probabilities summed, over time)"));
}

TEST(Cli, RunHandlesGpsRowsMissingFromAFasterLog) {
  const fs::path out = test_directory() / "out.csv";
  const Result r =
      run_skidimm("run -q --bank " + kSource + "/configs/stc_slip4.yaml --input " + kSource +
                  "/configs/examples/stc_switching.csv --output " + out.string() + " --plugin-path " + kPlugins);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "") << "--quiet prints nothing";
  const auto rows = read_csv(out);
  const int status = column(rows[0], "status");
  const int theta = column(rows[0], "theta");
  long predict_only = 0;
  for (std::size_t i = 1; i < rows.size(); ++i) {
    predict_only += rows[i][status] == "predict_only";
    const double heading = std::stod(rows[i][theta]);
    ASSERT_TRUE(heading >= -M_PI && heading < M_PI) << "row " << i;
  }
  EXPECT_GT(predict_only, static_cast<long>(rows.size()) / 2) << "GPS is at 10 Hz in a 50 Hz log";
  // Before the switch at 10 s the right-two-wheels mode dominates.
  long right_two = 0, before_switch = 0;
  for (std::size_t i = 1; i < rows.size(); ++i) {
    const double t = std::stod(rows[i][0]);
    if (t < 2.0 || t >= 10.0) continue;
    ++before_switch;
    right_two += rows[i][column(rows[0], "mode")] == "slip_FR_RR";
  }
  EXPECT_GT(right_two, before_switch * 9 / 10);
}

// A truth column is optional, but one the log lacks (a misspelt name) is
// said in the summary, where it would otherwise surface only when `eval
// --estimates` needs the column; a log that has it gets its accuracy line.
TEST(Cli, RunSaysWhenTheLogHasNoTruthColumnOfTheBanksName) {
  const fs::path dir = test_directory();
  std::string bank = read_file(kSource + "/configs/ltc_terrains.yaml");
  const std::size_t truth = bank.find("truth_mode: mode");
  ASSERT_NE(truth, std::string::npos);
  bank.replace(truth, 16, "truth_mode: Mode");
  const fs::path misspelt = write_file(dir / "misspelt.yaml", bank);
  const std::string input = " --input " + kSource + "/configs/examples/ltc_switching.csv --output ";
  const Result r = run_skidimm("run --bank " + misspelt.string() + input + (dir / "a.csv").string());
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(
      r.err,
      HasSubstr("\nno accuracy: the log has no column 'Mode' (the bank's columns.truth_mode) and no MODE= label"));
  const Result right =
      run_skidimm("run --bank " + kSource + "/configs/ltc_terrains.yaml" + input + (dir / "b.csv").string());
  EXPECT_EQ(right.exit_code, 0) << right.err;
  EXPECT_THAT(right.err, HasSubstr("most likely mode equals column 'mode' on "));
  EXPECT_THAT(right.err, Not(HasSubstr("no accuracy")));
  // The column there but blank at every row (a logger that never filled it).
  auto rows = read_csv(kSource + "/configs/examples/ltc_switching.csv");
  const int mode = column(rows[0], "mode");
  for (std::size_t i = 1; i < rows.size(); ++i) rows[i][static_cast<std::size_t>(mode)].clear();
  const Result unlabelled =
      run_skidimm("run --bank " + kSource + "/configs/ltc_terrains.yaml --input " +
                  write_file(dir / "blank.csv", csv_text(rows)).string() + " --output " + (dir / "c.csv").string());
  EXPECT_EQ(unlabelled.exit_code, 0) << unlabelled.err;
  EXPECT_THAT(unlabelled.err,
              HasSubstr("\nno accuracy: the log's column 'mode' (the bank's columns.truth_mode) is blank at every "
                        "step\n"));
}

// The bundled BorealTC bank's measurements aggregate the rows of its 0.5 s
// steps (log(std(...)) of the IMU); stepped at 100 Hz they measure something
// else, and the estimate is confidently wrong. `run` and `eval` warn of a
// --rate unlike the bank's; its own rate, or none, gets no warning.
TEST(Cli, RunAndEvalWarnOfARateUnlikeTheOneABankOfAggregatesWasFittedAt) {
  const std::string boreal = std::string(SKIDIMM_SHARED_DATA_DIR) + "/borealtc";
  if (!fs::exists(boreal)) GTEST_SKIP() << "no shared data at " << boreal;
  const std::string bank = kSource + "/configs/borealtc/terrains.yaml";
  const std::string log = "ICE=" + boreal + "/ICE/pro_00.csv+" + boreal + "/ICE/imu_00.csv";
  const fs::path dir = test_directory();
  const std::string warning = "warning: --rate 100 Hz steps " + bank +
                              " at another rate than its sampling.rate of 2 Hz: columns.measurements.omega, ";
  const Result fast = run_skidimm("run -q --bank " + bank + " --input '" + log + "' --rate 100 --output " +
                                  (dir / "fast.csv").string());
  EXPECT_EQ(fast.exit_code, 0) << fast.err;
  EXPECT_THAT(fast.err, HasSubstr("skidimm run: " + warning));
  EXPECT_THAT(fast.err, HasSubstr("over steps of 0.01 s they measure something other than what its modes were "
                                  "fitted on, so its estimates can be confidently wrong. Leave --rate out, or fit "
                                  "the bank at this rate (fit --rate, which writes it as the bank's sampling.rate)\n"));
  const Result evaluated = run_skidimm("eval --bank " + bank + " --input '" + log + "' --rate 100");
  EXPECT_EQ(evaluated.exit_code, 0) << evaluated.err;
  EXPECT_THAT(evaluated.err, HasSubstr("skidimm eval: " + warning));
  for (const std::string rate : {"", " --rate 2"}) {
    const Result own = run_skidimm("run -q --bank " + bank + " --input '" + log + "'" + rate + " --output " +
                                   (dir / "own.csv").string());
    EXPECT_EQ(own.exit_code, 0) << own.err;
    EXPECT_THAT(own.err, Not(HasSubstr("warning"))) << rate;
  }
}

// A log given as the bank and the bank as the log: the log parses as one
// YAML string, and the error says it looks like a CSV log.
TEST(Cli, ALogGivenAsTheBankIsSaidToLookLikeALog) {
  const Result r = run_skidimm("run --bank " + kSource + "/configs/examples/ltc_switching.csv --input " + kSource +
                               "/configs/ltc_terrains.yaml --output " + (test_directory() / "o.csv").string());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("ltc_switching.csv:1: a bank file must be a YAML mapping; this looks like a CSV log, "
                               "not a bank file (were a log and the bank given the other way round?)"));
  // A CSV whose quoted header YAML cannot parse gets the same hint; a
  // scenario is never given beside a log, so no "other way round" there.
  const fs::path quoted = write_file(test_directory() / "quoted.csv", "\"t\",\"V\"\n0,1\n");
  const Result q = run_skidimm("validate " + quoted.string());
  EXPECT_EQ(q.exit_code, 1);
  EXPECT_THAT(q.err, HasSubstr("this looks like a CSV log, not a bank file"));
  const Result scenario =
      run_skidimm("simulate --scenario " + kSource + "/configs/examples/ltc_switching.csv --output " +
                  (test_directory() / "s.csv").string());
  EXPECT_EQ(scenario.exit_code, 1);
  EXPECT_THAT(scenario.err, HasSubstr("this looks like a CSV log, not a scenario file\n"));
}

TEST(Cli, BadBankIsReportedWithFileAndLineAndExitsNonZero) {
  const fs::path dir = test_directory();
  std::string bank = read_file(kSource + "/configs/physical/ltc_terrains.yaml");
  bank.replace(bank.find("Q: {diagonal: [0.02, 0.02]}"), 27, "Q: {diagonal: [0.02]}");
  const fs::path bank_file = write_file(dir / "broken.yaml", bank);
  const Result r = run_skidimm("run --bank " + bank_file.string() + " --input " + kSource +
                               "/configs/examples/ltc_switching.csv --output " + (dir / "out.csv").string() +
                               " --plugin-path " + kPlugins);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("broken.yaml:"));
  EXPECT_THAT(r.err, HasSubstr("modes[1].Q.diagonal: expected 2 values, got 1"));
  EXPECT_FALSE(fs::exists(dir / "out.csv"));
}

// The switching log with its 101st data row's wheel speed corrupted.
fs::path log_corrupt_at_row_101(const fs::path& dir) {
  std::string log = read_file(kSource + "/configs/examples/ltc_switching.csv");
  std::size_t at = 0;
  for (int line = 0; line < 102; ++line) at = log.find('\n', at) + 1;
  log.replace(log.find(',', at) + 1, 1, "x");
  return write_file(dir / "corrupt.csv", log);
}

TEST(Cli, BadRowMidLogKeepsTheRowsAlreadyComputed) {
  const fs::path dir = test_directory();
  const fs::path input = log_corrupt_at_row_101(dir);
  const Result r = run_skidimm("run --bank " + kSource + "/configs/ltc_terrains.yaml --input " + input.string() +
                               " --output " + (dir / "out.csv").string() + " --plugin-path " + kPlugins);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("corrupt.csv:103: column 2 ('phi_dot_L'): expected a finite number"));
  EXPECT_THAT(r.err, HasSubstr("the 101 rows computed before the error are in"));
  EXPECT_FALSE(fs::exists(dir / "out.csv")) << "an incomplete file must not carry the final name";
  EXPECT_EQ(read_csv(dir / "out.csv.partial").size(), 102u);
}

// A logger killed mid-write leaves a last line cut short, without its
// newline: the error says so, and the rows before it are kept. A short line
// with its newline is only a short line.
TEST(Cli, ALastLineCutOffMidWriteIsNamedAsSuch) {
  const fs::path dir = test_directory();
  const std::string log = read_file(kSource + "/configs/examples/ltc_switching.csv");
  const fs::path cut = write_file(dir / "cut.csv", log.substr(0, log.size() - 40));
  const Result r = run_skidimm("run --bank " + kSource + "/configs/ltc_terrains.yaml --input " + cut.string() +
                               " --output " + (dir / "out.csv").string());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("cut.csv:1488: expected 19 fields like the header, got 15; it is the last line and has "
                               "no newline: did the writer stop mid-line? (remove that line to read the rows before "
                               "it)"));
  EXPECT_THAT(r.err, HasSubstr("the 1486 rows computed before the error are in"));
  const std::size_t sixth = [&] {
    std::size_t at = 0;
    for (int line = 0; line < 5; ++line) at = log.find('\n', at) + 1;
    return at;
  }();
  const fs::path short_line = write_file(dir / "short.csv", log.substr(0, sixth) + "1,2,3\n");
  const Result s = run_skidimm("run --bank " + kSource + "/configs/ltc_terrains.yaml --input " + short_line.string() +
                               " --output " + (dir / "short_out.csv").string());
  EXPECT_EQ(s.exit_code, 1);
  EXPECT_THAT(s.err, HasSubstr("short.csv:6: expected 19 fields like the header, got 3\n"));
  // A last line without a newline that has a field too many was not cut off.
  const fs::path extra =
      write_file(dir / "extra.csv", log.substr(0, sixth) + log.substr(sixth, log.find('\n', sixth) - sixth) + ",7");
  const Result e = run_skidimm("run --bank " + kSource + "/configs/ltc_terrains.yaml --input " + extra.string() +
                               " --output " + (dir / "extra_out.csv").string());
  EXPECT_EQ(e.exit_code, 1);
  EXPECT_THAT(e.err, HasSubstr("extra.csv:6: expected 19 fields like the header, got 20\n"));
}

// Smoothing needs the whole log; one that fails part way still gets the
// steps read so far smoothed over what was read, and kept.
TEST(Cli, BadRowMidLogKeepsTheSmoothedRowsAlreadyComputed) {
  const fs::path dir = test_directory();
  const fs::path input = log_corrupt_at_row_101(dir);
  for (const std::string smoothing : {"--smooth", "--lag 1"}) {
    fs::remove(dir / "out.csv.partial");
    const Result r =
        run_skidimm("run --bank " + kSource + "/configs/ltc_terrains.yaml --input " + input.string() + " --output " +
                    (dir / "out.csv").string() + " " + smoothing + " --plugin-path " + kPlugins);
    EXPECT_EQ(r.exit_code, 1) << smoothing;
    EXPECT_THAT(r.err, HasSubstr("corrupt.csv:103: column 2 ('phi_dot_L'): expected a finite number")) << smoothing;
    EXPECT_THAT(r.err, HasSubstr("the 101 rows computed before the error are in")) << smoothing;
    EXPECT_FALSE(fs::exists(dir / "out.csv")) << smoothing;
    EXPECT_EQ(read_csv(dir / "out.csv.partial").size(), 102u) << smoothing;
  }
}

// SIGTERM (or Ctrl-C's SIGINT) while a run waits on a pipe: it stops, keeps
// every row computed in the .partial file, and exits 128 + the signal, where
// the default ending lost the rows still in the writer's buffer.
TEST(Cli, ASignalStopsARunAndKeepsItsRows) {
  const fs::path dir = test_directory();
  const std::string input = kSource + "/configs/examples/ltc_switching.csv";
  const fs::path out = dir / "out.csv";
  // 100 rows down a FIFO, which then stays open: the run waits for more.
  // --flush shows each row in the .partial file once computed, which is when
  // the signal is sent (no guess at how long the rows take).
  const Result r = run_shell("mkfifo " + (dir / "rows").string() + "\n" + kSkidimm + " run -q --flush --bank " +
                             kTerrains + " --plugin-path " + kPlugins + " --input " + (dir / "rows").string() +
                             " --output " + out.string() + " 2>" + (dir / "err").string() +
                             " & run=$!\n"
                             "exec 3>" +
                             (dir / "rows").string() +
                             "\n"
                             "head -n 101 " +
                             input +
                             " >&3\n"
                             "for i in $(seq 600); do [ \"$(wc -l <" +
                             out.string() +
                             ".partial 2>/dev/null)\" = 101 ] && break; sleep 0.05; done\n"
                             "kill -TERM $run\n"
                             "status=0; wait $run || status=$?\n"
                             "exec 3>&-\n"
                             "echo $status");
  EXPECT_EQ(r.out, "143\n") << r.err;
  const std::string err = read_file(dir / "err");
  EXPECT_THAT(err, HasSubstr("stopped by SIGTERM while waiting for the next row"));
  EXPECT_THAT(err, HasSubstr("the 100 rows computed before the error are in " + out.string() + ".partial"));
  EXPECT_FALSE(fs::exists(out));
  EXPECT_EQ(read_csv(out.string() + ".partial").size(), 101u);
}

// A slow replay to Foxglove (--serve-speed 1e-4: a 0.02 s step waits 200 s)
// waits its rows' full time, and a stop request during such a wait (SIGTERM
// here: a shell's background job ignores SIGINT, which the run keeps) stops
// the run there, with its rows kept, instead of once the wait is over.
TEST(Cli, ASignalDuringASlowServedReplaysWaitStopsTheRun) {
  const fs::path dir = test_directory();
  const fs::path out = dir / "out.csv";
  const Result r = run_shell(kSkidimm + " run -q --flush --serve 0 --serve-speed 1e-4 --bank " + kTerrains +
                             " --plugin-path " + kPlugins + " --input " + kSource +
                             "/configs/examples/ltc_switching.csv --output " + out.string() + " 2>" +
                             (dir / "err").string() +
                             " & run=$!\n"
                             "for i in $(seq 600); do [ \"$(wc -l <" +
                             out.string() +
                             ".partial 2>/dev/null)\" -ge 2 ] && break; sleep 0.05; done\n"
                             "sleep 1\n"
                             "rows=$(wc -l <" +
                             out.string() +
                             ".partial)\n"
                             "kill -TERM $run\n"
                             "for i in $(seq 300); do kill -0 $run 2>/dev/null || break; sleep 0.1; done\n"
                             "if kill -0 $run 2>/dev/null; then kill -KILL $run; echo still waiting; fi\n"
                             "status=0; wait $run || status=$?\n"
                             "echo $rows $status");
  // The header and the first row or two: the second is due 200 s after the first.
  EXPECT_THAT(r.out, testing::AnyOf(testing::Eq("2 143\n"), testing::Eq("3 143\n"))) << r.err;
  EXPECT_THAT(read_file(dir / "err"), HasSubstr("stopped by SIGTERM"));
  EXPECT_FALSE(fs::exists(out));
  EXPECT_TRUE(fs::exists(out.string() + ".partial"));
}

TEST(Cli, MissingColumnNamesTheBankField) {
  const fs::path dir = test_directory();
  const fs::path input = write_file(dir / "log.csv", "t,phi_dot_L,phi_dot_R,V\n0,1,1,0\n");
  const Result r = run_skidimm("run --bank " + kSource + "/configs/ltc_terrains.yaml --input " + input.string() +
                               " --output " + (dir / "out.csv").string() + " --plugin-path " + kPlugins);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("no column 'omega' (the bank's columns.measurements.omega)"));
}

// A plugin's bug must not take skidimm down: an .at() out of range in
// predict ended in `terminate called`.
TEST(Cli, RunSurvivesAPluginThatThrowsAndNamesTheModePluginAndReason) {
  const fs::path dir = test_directory();
  const fs::path out = dir / "out.csv";
  const std::string input = kSource + "/configs/examples/ltc_switching.csv";
  const std::string faulty = kFixturePlugins + "/faulty";
  const Result r = run_skidimm("run --bank " + faulty_bank(dir, "predict_throws").string() + " --input " + input +
                               " --output " + out.string() + " --plugin-path " + kPlugins + " --plugin-path " + faulty);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(read_csv(out).size(), read_csv(input).size());
  EXPECT_THAT(r.err, HasSubstr("mode 'slippery' (plugin faulty_model 0.0.2 (" + faulty +
                               "/faulty_plugin.so)) was rejected on "));
  EXPECT_THAT(r.err, HasSubstr("because the model failed"));
  EXPECT_THAT(r.err, HasSubstr("): the model failed: predict_fixed() threw: vector::_M_range_check"));
  EXPECT_THAT(r.err, ::testing::Not(HasSubstr("mode 'asphalt' (plugin")));
  // Which file and version each mode's plugin came from.
  EXPECT_THAT(r.err, HasSubstr("mode 'asphalt': plugin ltc_linear 1.0.0 (" + kPlugins + "/skidimm_ltc_linear.so)"));

  const Result nan = run_skidimm("run --bank " + faulty_bank(dir, "nan").string() + " --input " + input + " --output " +
                                 out.string() + " --plugin-path " + kPlugins + " --plugin-path " + faulty);
  ASSERT_EQ(nan.exit_code, 0) << nan.err;
  EXPECT_THAT(nan.err, HasSubstr("because the model returned a non-finite state, Jacobian or process noise"));
}

// eval scores what the filter did, a reset mode included: the failures are
// said as run says them, not only folded into the scores.
TEST(Cli, EvalNamesAModeWhosePluginFailsAndWhyAsRunDoes) {
  const fs::path dir = test_directory();
  const std::string input = kSource + "/configs/examples/ltc_switching.csv";
  const std::string faulty = kFixturePlugins + "/faulty";
  const Result r = run_skidimm("eval --bank " + faulty_bank(dir, "predict_throws").string() + " --input " + input +
                               " --plugin-path " + kPlugins + " --plugin-path " + faulty);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.err, HasSubstr(input + ": modes rejected and reset"));
  EXPECT_THAT(r.err, HasSubstr("mode 'slippery' (plugin faulty_model 0.0.2 (" + faulty +
                               "/faulty_plugin.so)) was rejected on "));
  EXPECT_THAT(r.err, HasSubstr("): the model failed: predict_fixed() threw: vector::_M_range_check"));
  EXPECT_THAT(r.err, Not(HasSubstr("mode 'asphalt' (plugin")));
  EXPECT_THAT(r.err, Not(HasSubstr("every mode was rejected"))) << "asphalt's filter ran throughout";
  // A log without failures says nothing of them.
  const Result clean = run_skidimm("eval --bank " + kTerrains + " --input " + input + " --plugin-path " + kPlugins);
  ASSERT_EQ(clean.exit_code, 0) << clean.err;
  EXPECT_THAT(clean.err, Not(HasSubstr("rejected")));
}

// tune scores the logs where eval would report each model failure: it says
// them too, at the starting settings, which the search may have moved away
// from to keep the model from failing (it wrote such a bank without a word).
TEST(Cli, TuneSaysWhereAModeWasRejectedWhileItScored) {
  const fs::path dir = test_directory();
  const std::string log = slippery_switching_log();
  const Result r =
      run_skidimm("tune -q --bank " + faulty_bank(dir, "predict_throws").string() + " --log " +
                  write_file(dir / "one.csv", log).string() + " --log " + write_file(dir / "two.csv", log).string() +
                  " --objective none --no-assess --tune floor --plugin-path " + kPlugins + " --plugin-path " +
                  kFixturePlugins + "/faulty");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.err, HasSubstr("warning: modes rejected and reset on 2 of 2 development log(s)"));
  EXPECT_THAT(r.err, HasSubstr("scored at the bank's starting settings"));
  EXPECT_THAT(r.err, HasSubstr("mode 'slippery' (plugin faulty_model 0.0.2"));
  EXPECT_THAT(r.err, HasSubstr("first in one.csv on row "));
  EXPECT_THAT(r.err, HasSubstr("the model failed: predict_fixed() threw"));
  EXPECT_THAT(r.err, Not(HasSubstr("mode 'asphalt' (plugin")));
}

// A plugin that aborts the process cannot be survived, but it is named on
// the way down instead of a bare "Aborted"; the process still ends as the
// signal ends it (exit status 128 + 6 from the shell).
TEST(Cli, APluginThatAbortsTheProcessIsNamed) {
  const fs::path dir = test_directory();
  const std::string input = kSource + "/configs/examples/ltc_switching.csv";
  const Result r =
      run_shell(kSkidimm + " run -q --bank " + faulty_bank(dir, "abort").string() + " --input " + input + " --output " +
                (dir / "out.csv").string() + " --plugin-path " + kPlugins + " --plugin-path " + kFixturePlugins +
                "/faulty 2>" + (dir / "err").string() + "; echo \"status $?\"");
  EXPECT_THAT(r.out, HasSubstr("status 134"));
  const std::string err = read_file(dir / "err");
  EXPECT_THAT(err, HasSubstr("skidimm run: SIGABRT (abort) while the model of mode 'slippery' (plugin faulty_model"));
  EXPECT_THAT(err, HasSubstr("faulty_plugin.so)) was running: the fault is that plugin's; the rows computed "
                             "before it are kept (in " +
                             (dir / "out.csv").string() + ".partial)"));
  EXPECT_FALSE(fs::exists(dir / "out.csv"));
  // The rows computed before the crash, every one whole (they were lost,
  // up to a thousand of them, unless --flush wrote each as it came).
  const auto rows = read_csv(dir / "out.csv.partial");
  ASSERT_GT(rows.size(), 10u);
  for (const auto& row : rows) EXPECT_EQ(row.size(), rows[0].size());
  EXPECT_EQ(read_file(dir / "out.csv.partial").back(), '\n');
  const std::size_t time = column(rows[0], "t");
  for (std::size_t i = 2; i < rows.size(); ++i) EXPECT_GT(std::stod(rows[i][time]), std::stod(rows[i - 1][time]));
}

// Every command that runs a bank's models names its plugins when one of them
// crashes the process (they said nothing and ended 134); where models run on
// several threads, or outside the filter, it cannot tell which mode's was
// running, and says which plugins to suspect and that `run` tells.
TEST(Cli, APluginThatAbortsTheProcessIsNamedByEveryCommand) {
  const fs::path dir = test_directory();
  const std::string input = kSource + "/configs/examples/ltc_switching.csv";
  const std::string bank = faulty_bank(dir, "abort").string();
  const std::string plugins = " --plugin-path " + kPlugins + " --plugin-path " + kFixturePlugins + "/faulty";
  // The log's modes as the bank's, for simulate, which drives each row's mode.
  const std::string log = slippery_switching_log();
  const fs::path relabelled = write_file(dir / "relabelled.csv", log);
  const std::vector<std::pair<std::string, std::string>> commands = {
      {"eval", "eval --bank " + bank + " --input " + input},
      {"validate", "validate " + bank + " --check " + input},
      {"simulate",
       "simulate --bank " + bank + " --inputs-from " + relabelled.string() + " --output " + (dir / "sim.csv").string()},
      {"fit",
       "fit --bank " + bank + " --log " + input + " --mode slippery --output-bank " + (dir / "fitted.yaml").string()},
      {"tune", "tune --bank " + bank + " --log " + relabelled.string() + " --log " +
                   write_file(dir / "relabelled_copy.csv", log).string() +
                   " --objective none --no-assess --tune floor"},
  };
  for (const auto& [name, arguments] : commands) {
    const Result r = run_shell(kSkidimm + " " + arguments + plugins + " 2>" + (dir / "err").string() +
                               " >/dev/null; echo \"status $?\"");
    EXPECT_THAT(r.out, HasSubstr("status 134")) << name;
    const std::string err = read_file(dir / "err");
    EXPECT_THAT(err, HasSubstr("skidimm " + name + ": SIGABRT (abort)")) << name;
    EXPECT_THAT(err, HasSubstr("faulty_model 0.0.2")) << name << ": the plugin to suspect";
    EXPECT_THAT(err, Not(HasSubstr("a fault of skidimm itself"))) << name;
  }
}

TEST(Cli, RunMergesFilesByTimeAndSteadiesAtAFixedRate) {
  const fs::path dir = test_directory();
  const SplitLog log = split_example(dir);
  const std::string bank = kSource + "/configs/ltc_terrains.yaml";
  const Result events = run_skidimm("run -q --bank " + bank + " --input " + log.slow.string() + " --input " +
                                    log.fast.string() + " --output " + (dir / "events.csv").string());
  ASSERT_EQ(events.exit_code, 0) << events.err;
  const auto rows = read_csv(dir / "events.csv");
  // A step per time stamp until the slow file (the inputs) ends.
  EXPECT_GT(rows.size(), static_cast<std::size_t>(log.fast_rows - 10));
  long right = 0;
  for (std::size_t i = 1; i < rows.size(); ++i) right += rows[i][column(rows[0], "mode")] == rows[i][column(rows[0], "truth_mode")];
  EXPECT_GT(static_cast<double>(right) / static_cast<double>(rows.size() - 1), 0.85);

  const Result fixed = run_skidimm("run --bank " + bank + " --input " + log.slow.string() + "+" + log.fast.string() +
                                   " --rate 10 --output " + (dir / "fixed.csv").string());
  ASSERT_EQ(fixed.exit_code, 0) << fixed.err;
  const auto steps = read_csv(dir / "fixed.csv");
  EXPECT_NEAR(static_cast<double>(steps.size() - 1), 300.0, 2.0) << "30 s at 10 Hz";
  EXPECT_THAT(fixed.err, HasSubstr("measurement 'omega': "));
  EXPECT_THAT(fixed.err, HasSubstr("replaced by a later one in the same step"));
}

TEST(CliIo, RunReadsLogsFromStandardInputPipesAndFifos) {
  const fs::path dir = test_directory();
  const fs::path reference = dir / "reference.csv";
  ASSERT_EQ(run_pipeline(run_command(kTerrains, kSwitching, reference.string())).exit_code, 0);
  const std::string expected = read_file(reference);
  ASSERT_GT(expected.size(), 1000u);
  struct Case {
    std::string name, script;
  };
  const fs::path out = dir / "out.csv";
  const std::vector<Case> cases = {
      {"--input -", "cat " + kSwitching + " | " + run_command(kTerrains, "-", out.string())},
      {"/dev/stdin", "cat " + kSwitching + " | " + run_command(kTerrains, "/dev/stdin", out.string())},
      {"<(...)", run_command(kTerrains, "<(cat " + kSwitching + ")", out.string())},
      {"FIFO", "mkfifo " + (dir / "fifo").string() + " && { cat " + kSwitching + " > " + (dir / "fifo").string() +
                   " & } && " + run_command(kTerrains, (dir / "fifo").string(), out.string())},
      {"--output -", "cat " + kSwitching + " | " + run_command(kTerrains, "-", "-") + " > " + out.string()},
  };
  for (const Case& c : cases) {
    fs::remove(out);
    const Result r = run_pipeline(c.script);
    EXPECT_EQ(r.exit_code, 0) << c.name << ": " << r.err;
    EXPECT_EQ(read_file(out), expected) << c.name;
    EXPECT_FALSE(fs::exists(out.string() + ".partial")) << c.name;
  }
  // Standard input twice in one log cannot be.
  const Result twice = run_pipeline("cat " + kSwitching + " | " + run_command(kTerrains, "- --input -", out.string()));
  EXPECT_EQ(twice.exit_code, 1);
  EXPECT_THAT(twice.err, HasSubstr("standard input ('-') can be one file of a log, not several"));
}

// A reader that goes away (`| head`) is an error run says and handles: it
// ended silently on SIGPIPE (status 141), before it could say what it kept
// or why it wrote no checkpoint.
TEST(CliIo, RunSaysWhenTheReaderOfItsOutputGoesAway) {
  const fs::path dir = test_directory();
  const fs::path checkpoint = dir / "state.yaml";
  const Result r =
      run_shell(run_command(kTerrains, kSwitching, "-") + " --flush --save-checkpoint " + checkpoint.string() + " 2>" +
                (dir / "err").string() + " | head -2 >/dev/null; echo \"status ${PIPESTATUS[0]}\"");
  EXPECT_THAT(r.out, HasSubstr("status 1\n"));
  const std::string err = read_file(dir / "err");
  EXPECT_THAT(err, HasSubstr("skidimm run: error: standard output: cannot write: Broken pipe"));
  EXPECT_THAT(err, HasSubstr("the rows handed over before the error went to standard output"));
  EXPECT_THAT(err, Not(HasSubstr("rows computed before the error are in")));
  EXPECT_THAT(err, HasSubstr("no checkpoint written: the filter went past a row the output refused"));
  EXPECT_FALSE(fs::exists(checkpoint));
}

// The coprocess: writes one row, waits for its output row, then writes the next.
TEST(CliIo, RunFlushWritesEachRowBeforeTheNextIsRead) {
  int to_child[2], from_child[2];
  ASSERT_EQ(::pipe(to_child), 0);
  ASSERT_EQ(::pipe(from_child), 0);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    ::dup2(to_child[0], 0);
    ::dup2(from_child[1], 1);
    ::close(to_child[1]);
    ::close(from_child[0]);
    ::execl(kSkidimm.c_str(), kSkidimm.c_str(), "run", "-q", "--flush", "--bank", kTerrains.c_str(), "--plugin-path",
            kPlugins.c_str(), "--input", "-", "--output", "-", static_cast<char*>(nullptr));
    ::_exit(127);
  }
  ::close(to_child[0]);
  ::close(from_child[1]);
  std::FILE* in = ::fdopen(to_child[1], "w");
  std::FILE* out = ::fdopen(from_child[0], "r");
  ASSERT_NE(in, nullptr);
  ASSERT_NE(out, nullptr);
  std::ifstream log(kSwitching);
  std::string line;
  std::getline(log, line);
  std::fprintf(in, "%s\n", line.c_str());
  std::fflush(in);
  auto read_line = [&] {
    char buffer[4096];
    if (std::fgets(buffer, sizeof(buffer), out) == nullptr) return std::string("<end>");
    return std::string(buffer);
  };
  EXPECT_THAT(read_line(), HasSubstr("t,mu_asphalt,mu_grass,mu_crushed_concrete"));
  for (int row = 0; row < 5 && std::getline(log, line); ++row) {
    std::fprintf(in, "%s\n", line.c_str());
    std::fflush(in);
    // Blocks until the row for this input row is written: the input is still open.
    const std::string output = read_line();
    EXPECT_EQ(output.substr(0, output.find(',')), line.substr(0, line.find(','))) << "row " << row;
  }
  std::fclose(in);
  EXPECT_EQ(read_line(), "<end>");
  std::fclose(out);
  int status = 0;
  ::waitpid(child, &status, 0);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
}

// --likelihood-weight overrides the bank's: 1 is the plain IMM to the byte,
// below 1 the probabilities are less sure of every mode; out of (0, 1] it
// is a usage error.
TEST(CliIo, RunLikelihoodWeightOverridesTheBanksAndIsChecked) {
  const fs::path dir = test_directory();
  const auto mean_largest_probability = [](const fs::path& file) {
    const auto rows = read_csv(file);
    double sum = 0.0;
    for (std::size_t i = 1; i < rows.size(); ++i) {
      sum += std::max({std::stod(rows[i][1]), std::stod(rows[i][2]), std::stod(rows[i][3])});
    }
    return sum / static_cast<double>(rows.size() - 1);
  };
  ASSERT_EQ(run_pipeline(run_command(kTerrains, kSwitching, (dir / "plain.csv").string())).exit_code, 0);
  ASSERT_EQ(run_pipeline(run_command(kTerrains, kSwitching, (dir / "one.csv").string()) + " --likelihood-weight 1").exit_code, 0);
  EXPECT_EQ(read_file(dir / "one.csv"), read_file(dir / "plain.csv"));
  const Result tempered =
      run_pipeline(run_command(kTerrains, kSwitching, (dir / "tempered.csv").string()) + " --likelihood-weight 0.05");
  ASSERT_EQ(tempered.exit_code, 0) << tempered.err;
  EXPECT_LT(mean_largest_probability(dir / "tempered.csv"), mean_largest_probability(dir / "plain.csv") - 0.05);
  for (const std::string bad : {"0", "1.5", "-0.2", "nan", "abc"}) {
    const Result refused =
        run_pipeline(run_command(kTerrains, kSwitching, (dir / "bad.csv").string()) + " --likelihood-weight " + bad);
    EXPECT_EQ(refused.exit_code, 2) << bad;
    EXPECT_THAT(refused.err, HasSubstr("--likelihood-weight")) << bad;
    EXPECT_FALSE(fs::exists(dir / "bad.csv")) << bad;
  }
}

// The bundled switching log with one measurement cell replaced: data row
// `row` (1-based, file line row + 1), column V.
fs::path log_with_outlier(const fs::path& dir, int row, const std::string& value) {
  std::string log = read_file(kSource + "/configs/examples/ltc_switching.csv");
  std::size_t at = 0;
  for (int line = 0; line < row; ++line) at = log.find('\n', at) + 1;
  std::size_t cell = at;
  for (int c = 0; c < 3; ++c) cell = log.find(',', cell) + 1;  // t, phi_dot_L, phi_dot_R, V
  log.replace(cell, log.find(',', cell) - cell, value);
  return write_file(dir / ("outlier_" + value + ".csv"), log);
}

// A bank with an unknown hypothesis writes its probability after the modes'
// and names it as the most likely when a measurement misses every mode by far
// (V = 5 m/s at row 300, where the robot drives at about 1). Past the first
// 2 s that is the only such row; in them, as the robot sets off and every
// filter is still settling, the modes miss too and "unknown" leads for about
// a second. `eval` scores such a step as wrong, from the run's output as when
// it runs the IMM itself.
// The bundled terrains given narrow fitted ranges (every terrain [0, 1] rad/s
// on both wheels): run reports the share of rows outside the most likely
// terrain's (here every terrain's) ranges and the farthest. With an
// extrapolation_scale, every terrain far out is equally unsure, each such row
// counts almost nothing, and the estimate is less sure than without.
TEST(Cli, RunReportsTheRowsOutsideTheFittedInputsAndTheDiscountMakesThemLessSure) {
  const fs::path dir = test_directory();
  std::string narrow = read_file(kTerrains);
  ASSERT_EQ(with_fitted_inputs(&narrow, "{phi_dot_L: [0, 1], phi_dot_R: [0, 1]}"), 3);
  const RowsOutside outside = switching_rows_outside(0.0, 1.0);
  ASSERT_GT(outside.outside, 0);
  ASSERT_LT(outside.outside, outside.rows);
  const fs::path plain_bank = write_file(dir / "narrow.yaml", narrow);
  const Result plain = run_skidimm("run --bank " + plain_bank.string() + " --plugin-path " + kPlugins + " --input " +
                                   kSwitching + " --output " + (dir / "plain.csv").string());
  ASSERT_EQ(plain.exit_code, 0) << plain.err;
  EXPECT_THAT(plain.err, HasSubstr("inputs outside the ranges the most likely class was fitted on: " + outside.percent +
                                   " of the rows (farthest: "));
  EXPECT_THAT(plain.err, HasSubstr("fitted on 0 to 1)"));

  const fs::path discounted_bank = write_file(dir / "discounted.yaml", "extrapolation_scale: 0.01\n" + narrow);
  ASSERT_EQ(
      run_pipeline(run_command(discounted_bank.string(), kSwitching, (dir / "discounted.csv").string())).exit_code, 0);
  const auto mean_top_probability = [](const fs::path& file) {
    const auto out = read_csv(file);
    double sum = 0.0;
    for (std::size_t i = 1; i < out.size(); ++i) {
      sum += std::max({std::stod(out[i][1]), std::stod(out[i][2]), std::stod(out[i][3])});
    }
    return sum / static_cast<double>(out.size() - 1);
  };
  EXPECT_LT(mean_top_probability(dir / "discounted.csv"), mean_top_probability(dir / "plain.csv") - 0.05);
  std::string none = read_file(kTerrains);
  with_fitted_inputs(&none, "");
  const Result without = run_skidimm("run --bank " + write_file(dir / "none.yaml", none).string() + " --plugin-path " +
                                     kPlugins + " --input " + kSwitching + " --output " + (dir / "none.csv").string());
  ASSERT_EQ(without.exit_code, 0) << without.err;
  EXPECT_THAT(without.err, ::testing::Not(HasSubstr("inputs outside")));
}

TEST(Cli, RunWritesTheUnknownHypothesisProbabilityAndEvalCountsItWrong) {
  const fs::path dir = test_directory();
  const fs::path bank =
      write_file(dir / "unknown.yaml", "unknown: {inflation: 100, enter: 0.001, leave: 0.5}\n" + read_file(kTerrains));
  const fs::path log = log_with_outlier(dir, 300, "5");
  const fs::path out = dir / "out.csv";
  const Result r = run_pipeline(run_command(bank.string(), log.string(), out.string()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto rows = read_csv(out);
  EXPECT_EQ(std::vector<std::string>(rows[0].begin(), rows[0].begin() + 5),
            (std::vector<std::string>{"t", "mu_asphalt", "mu_grass", "mu_crushed_concrete", "unknown_probability"}));
  const int mode = column(rows[0], "mode");
  long unknown_rows = 0, unknown_rows_later = 0;
  for (std::size_t i = 1; i < rows.size(); ++i) {
    double sum = 0.0;
    for (int c = 1; c <= 4; ++c) sum += std::stod(rows[i][static_cast<std::size_t>(c)]);
    ASSERT_NEAR(sum, 1.0, 1e-9) << "row " << i;
    const bool unknown = rows[i][static_cast<std::size_t>(mode)] == "unknown";
    unknown_rows += unknown;
    unknown_rows_later += unknown && std::stod(rows[i][0]) > 2.0;
  }
  EXPECT_GT(std::stod(rows[300][4]), 0.5);
  EXPECT_EQ(rows[300][static_cast<std::size_t>(mode)], "unknown");
  EXPECT_EQ(unknown_rows_later, 1) << "the modes fit the rest of the log";
  EXPECT_LT(unknown_rows, 100);
  // The plain bank writes no such column.
  ASSERT_EQ(run_pipeline(run_command(kTerrains, log.string(), (dir / "plain.csv").string())).exit_code, 0);
  const auto plain_header = read_csv(dir / "plain.csv")[0];
  EXPECT_EQ(std::count(plain_header.begin(), plain_header.end(), "unknown_probability"), 0);
  // eval from the file and eval running the bank agree, "unknown" counted wrong.
  const Result from_file = run_skidimm("eval --json --estimates " + out.string());
  ASSERT_EQ(from_file.exit_code, 0) << from_file.err;
  const Result live = run_skidimm("eval --json --bank " + bank.string() + " --input " + log.string() +
                                  " --plugin-path " + kPlugins);
  ASSERT_EQ(live.exit_code, 0) << live.err;
  const auto accuracy = [](const std::string& s) {
    const auto at = s.find("\"accuracy\": ");
    return at == std::string::npos ? std::string() : s.substr(at, 30);
  };
  EXPECT_NE(accuracy(live.out), "");
  EXPECT_EQ(accuracy(from_file.out), accuracy(live.out));
}

// Every state finite and every variance >= 0 on every row.
void expect_sound_rows(const std::vector<std::vector<std::string>>& rows, const std::string& where) {
  const auto& header = rows[0];
  for (const char* name : {"V", "omega", "var_V", "var_omega"}) {
    const int c = column(header, name);
    for (std::size_t r = 1; r < rows.size(); ++r) {
      const double value = std::stod(rows[r][static_cast<std::size_t>(c)]);
      ASSERT_TRUE(std::isfinite(value)) << where << ", row " << r << ", " << name;
      if (name[0] == 'v') {
        ASSERT_GE(value, 0.0) << where << ", row " << r << ", " << name;
      }
    }
  }
}

// One measurement cell of 1e150 left every later row
// all_modes_rejected with a negative var_V, exit 0.
TEST(Cli, RunRecoversFromA1e150MeasurementWithinAFewRows) {
  const fs::path dir = test_directory();
  const fs::path input = log_with_outlier(dir, 187, "1e150");
  const fs::path out = dir / "out.csv";
  const std::string run = "run --bank " + kSource + "/configs/ltc_terrains.yaml --output " + out.string() +
                          " --plugin-path " + kPlugins + " --input ";
  const Result r = run_skidimm(run + input.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto rows = read_csv(out);
  expect_sound_rows(rows, "1e150");
  const int status = column(rows[0], "status"), reason = column(rows[0], "reason");
  EXPECT_EQ(rows[187][status], "all_modes_rejected");
  EXPECT_EQ(rows[187][reason], "asphalt: diverged, reset; grass: diverged, reset; crushed_concrete: diverged, reset");
  for (std::size_t k = 190; k < rows.size(); ++k) ASSERT_EQ(rows[k][status], "updated") << "row " << k;
  EXPECT_EQ(rows[186][reason], "");
  EXPECT_THAT(r.err, HasSubstr("1 rows had at least one mode's filter rejected and reset"));
  EXPECT_THAT(r.err, HasSubstr("because the filter diverged"));
  // The estimates a few rows later are the clean log's.
  const fs::path clean_out = dir / "clean.csv";
  ASSERT_EQ(run_skidimm("run -q --bank " + kSource + "/configs/ltc_terrains.yaml --output " + clean_out.string() +
                        " --plugin-path " + kPlugins + " --input " + kSource + "/configs/examples/ltc_switching.csv")
                .exit_code,
            0);
  const auto clean = read_csv(clean_out);
  const int v = column(rows[0], "V"), mode = column(rows[0], "mode");
  for (std::size_t k = 195; k < rows.size(); ++k) {
    ASSERT_NEAR(std::stod(rows[k][static_cast<std::size_t>(v)]), std::stod(clean[k][static_cast<std::size_t>(v)]), 0.02)
        << "row " << k;
  }
  EXPECT_EQ(rows.back()[mode], clean.back()[mode]);

  // With the smoother too: nothing non-finite, no negative variance.
  const Result smoothed = run_skidimm(run + input.string() + " --smooth");
  ASSERT_EQ(smoothed.exit_code, 0) << smoothed.err;
  expect_sound_rows(read_csv(out), "1e150, smoothed");
  const Result lagged = run_skidimm(run + input.string() + " --lag 0.5 --innovation-gate 0.9999");
  ASSERT_EQ(lagged.exit_code, 0) << lagged.err;
  const auto lagged_rows = read_csv(out);
  expect_sound_rows(lagged_rows, "1e150, gated, lag 0.5");
  EXPECT_EQ(lagged_rows[187][status], "gated");
}

TEST(Cli, RunStaysSoundForOutliersFrom1e6To1e300AndTheGateRemovesThem) {
  const fs::path dir = test_directory();
  const fs::path out = dir / "out.csv";
  const std::string run =
      "run --bank " + kSource + "/configs/ltc_terrains.yaml --output " + out.string() + " --plugin-path " + kPlugins;
  for (int exponent = 6; exponent <= 300; exponent += exponent < 140 || exponent >= 160 ? 20 : 2) {
    const std::string value = "1e" + std::to_string(exponent);
    const fs::path input = log_with_outlier(dir, 187, value);
    const Result plain = run_skidimm(run + " -q --input " + input.string());
    ASSERT_EQ(plain.exit_code, 0) << value << ": " << plain.err;
    expect_sound_rows(read_csv(out), value);

    const Result gated = run_skidimm(run + " --innovation-gate 0.9999 --input " + input.string());
    ASSERT_EQ(gated.exit_code, 0) << value << ": " << gated.err;
    const auto rows = read_csv(out);
    expect_sound_rows(rows, value + ", gated");
    const int status = column(rows[0], "status"), reason = column(rows[0], "reason");
    EXPECT_EQ(rows[187][status], "gated") << value;
    EXPECT_THAT(rows[187][reason], HasSubstr("asphalt: gated (NIS ")) << value;
    EXPECT_EQ(rows[188][status], "updated") << value;
    EXPECT_THAT(gated.err, HasSubstr("innovation gate 0.9999: ")) << value;
  }
}

TEST(Cli, StrictStopsAtTheFirstRejectionNamingRowModePluginAndReasonAndKeepsTheRows) {
  const fs::path dir = test_directory();
  const fs::path out = dir / "out.csv";
  const std::string input = kSource + "/configs/examples/ltc_switching.csv";
  const std::string faulty = kFixturePlugins + "/faulty";
  const Result r =
      run_skidimm("run --strict --bank " + faulty_bank(dir, "predict_throws").string() + " --input " + input +
                  " --output " + out.string() + " --plugin-path " + kPlugins + " --plugin-path " + faulty);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("mode 'slippery' (plugin faulty_model 0.0.2 (" + faulty +
                               "/faulty_plugin.so)) was rejected: the model failed: predict_fixed() threw"));
  EXPECT_THAT(r.err, HasSubstr("--strict stops at the first rejection"));
  EXPECT_FALSE(fs::exists(out));
  const auto rows = read_csv(dir / "out.csv.partial");
  ASSERT_GE(rows.size(), 3u);
  // The error names the last row written, which carries the reason.
  const std::size_t last = rows.size() - 1;
  EXPECT_THAT(r.err, HasSubstr("row " + std::to_string(last) + " (t = " + rows[last][0] + "): mode 'slippery'"));
  EXPECT_EQ(rows[last][column(rows[0], "status")], "mode_reset");
  EXPECT_THAT(rows[last][column(rows[0], "reason")], HasSubstr("slippery: model failed, reset: predict_fixed() threw"));
  EXPECT_THAT(r.err, HasSubstr("the " + std::to_string(last) + " rows computed before the error are in"));

  // The same run without --strict goes to the end; a diverged filter stops a strict run too.
  const Result outlier = run_skidimm("run --strict --bank " + kSource + "/configs/ltc_terrains.yaml --input " +
                                     log_with_outlier(dir, 187, "1e150").string() + " --output " + out.string() +
                                     " --plugin-path " + kPlugins);
  EXPECT_EQ(outlier.exit_code, 1);
  EXPECT_THAT(outlier.err, HasSubstr("row 187 (t = 3.714): mode 'asphalt' (plugin ltc_linear 1.0.0 ("));
  EXPECT_THAT(outlier.err, HasSubstr("was rejected: the filter diverged"));
}

// A log in pieces, each run resumed from the checkpoint the run before left:
// the rows are the rows of one run over the whole log, byte for byte. A run
// that fails on a bad row leaves the checkpoint after its last good row.
TEST(Cli, RunResumedFromACheckpointGoesOnAsOneRunOverTheWholeLog) {
  const fs::path dir = test_directory();
  std::vector<std::string> lines;
  {
    std::ifstream in(kSwitching);
    for (std::string line; std::getline(in, line);) lines.push_back(line);
  }
  const auto piece = [&](const std::string& name, std::size_t from, std::size_t to, const std::string& bad_row = "") {
    std::ofstream out(dir / name);
    out << lines[0] << "\n";
    for (std::size_t k = from; k < to; ++k) out << lines[k] << "\n";
    if (!bad_row.empty()) out << bad_row << "\n";
    return (dir / name).string();
  };
  const std::size_t rows = lines.size() - 1;
  const std::string whole = (dir / "whole.csv").string(), state = (dir / "state.yaml").string();
  ASSERT_EQ(run_skidimm("run -q --bank " + kTerrains + " --input " + kSwitching + " --output " + whole).exit_code, 0);
  // The second piece ends in a row the reader refuses: an error, after its
  // rows so far and the filter after them are kept.
  const std::string bad = "1e400,1,1,1,1,1,1,1,1,1,1,1,1,1,1,1,1,1,1";
  const std::string a = piece("a.csv", 1, 301), b = piece("b.csv", 301, 800, bad), c = piece("c.csv", 800, rows + 1);
  const Result first = run_skidimm("run --bank " + kTerrains + " --input " + a + " --output " +
                                   (dir / "a_out.csv").string() + " --save-checkpoint " + state);
  ASSERT_EQ(first.exit_code, 0) << first.err;
  EXPECT_THAT(first.err, HasSubstr("the filter after its last step (t = "));
  const Result second =
      run_skidimm("run -q --bank " + kTerrains + " --input " + b + " --output " + (dir / "b_out.csv").string() +
                  " --resume " + state + " --save-checkpoint " + state);
  EXPECT_EQ(second.exit_code, 1);
  EXPECT_THAT(second.err, HasSubstr("the 499 rows computed before the error are in"));
  EXPECT_THAT(second.err, HasSubstr("is in " + state + " (--resume goes on from it)"));
  const Result third = run_skidimm("run -q --bank " + kTerrains + " --input " + c + " --output " +
                                   (dir / "c_out.csv").string() + " --resume " + state);
  ASSERT_EQ(third.exit_code, 0) << third.err;
  const std::string b_rows = read_file(dir / "b_out.csv.partial");
  const std::string c_rows = read_file(dir / "c_out.csv");
  EXPECT_EQ(read_file(dir / "a_out.csv") + b_rows.substr(b_rows.find('\n') + 1) + c_rows.substr(c_rows.find('\n') + 1),
            read_file(whole));

  // Another bank's checkpoint, a clock that goes back, and smoothing are refused before any row.
  const Result other = run_skidimm("run -q --bank " + kSource + "/configs/stc_slip4.yaml --input " + c +
                                   " --output - --resume " + state);
  EXPECT_EQ(other.exit_code, 1);
  EXPECT_THAT(other.err, HasSubstr("--resume " + state +
                                   ": cannot restore this checkpoint: it was made by a bank of "
                                   "modes [asphalt, grass, crushed_concrete], this bank's are [no_slip, "));
  const Result back = run_skidimm("run -q --bank " + kTerrains + " --input " + a + " --output - --resume " + state);
  EXPECT_EQ(back.exit_code, 1);
  EXPECT_THAT(back.err, HasSubstr("the log's first step, at t = 0 s, does not come after the checkpoint's last"));
  EXPECT_EQ(std::count(back.out.begin(), back.out.end(), '\n'), 1) << "the header alone";
  // A gap from the checkpoint longer than the bank's max_gap, as within a log.
  write_file(dir / "late.csv", lines[0] + "\n1000" + lines[800].substr(lines[800].find(',')) + "\n");
  const Result late = run_skidimm("run -q --bank " + kTerrains + " --input " + (dir / "late.csv").string() +
                                  " --output - --resume " + state);
  EXPECT_EQ(late.exit_code, 1);
  EXPECT_THAT(late.err, HasSubstr("s after the checkpoint's last, at t = 16.0025 s: longer than the bank's "
                                  "sampling.max_gap (10 s)"));
  const Result smoothed =
      run_skidimm("run -q --bank " + kTerrains + " --input " + c + " --output - --smooth --resume " + state);
  EXPECT_EQ(smoothed.exit_code, 2);
  EXPECT_THAT(smoothed.err, HasSubstr("--smooth and --lag smooth a log as a whole"));
  std::ofstream(dir / "broken.yaml") << "skidimm_checkpoint: 1\nbank: {modes: [a]}\n";
  const Result broken = run_skidimm("run -q --bank " + kTerrains + " --input " + c + " --output - --resume " +
                                    (dir / "broken.yaml").string());
  EXPECT_EQ(broken.exit_code, 1);
  EXPECT_THAT(broken.err, HasSubstr("broken.yaml:2: bank.states: missing (required)"));
}

// A live run killed outright (SIGKILL: no chance to save at the end) has
// left, with --checkpoint-every, a checkpoint at most that many seconds of
// the log's time old; a run resumed from it over the rows after it writes
// what the run that was never killed wrote for them.
TEST(Cli, ALiveRunKilledOutrightLeavesARecentCheckpointToResumeFrom) {
  const fs::path dir = test_directory();
  const std::string whole = (dir / "whole.csv").string(), state = (dir / "state.yaml").string();
  ASSERT_EQ(run_skidimm("run -q --bank " + kTerrains + " --input " + kSwitching + " --output " + whole).exit_code, 0);
  // 400 rows (t from 0 to 7.98 s) through a FIFO that stays open; killed once
  // a checkpoint at t >= 7 s is there.
  const Result killed =
      run_shell("cd " + dir.string() + " && mkfifo rows\n" + kSkidimm + " run -q --bank " + kTerrains +
                " --input rows --output out.csv --save-checkpoint state.yaml --checkpoint-every 1 & pid=$!\n"
                "exec 3>rows\nhead -n 401 " +
                kSwitching +
                " >&3\n"
                "for i in $(seq 1200); do grep -q '^t: 7' state.yaml 2>/dev/null && break; sleep 0.05; done\n"
                "kill -9 $pid; wait $pid; echo \"status $?\"; grep '^t:' state.yaml");
  ASSERT_THAT(killed.out, HasSubstr("status 137")) << killed.err;
  ASSERT_THAT(killed.out, HasSubstr("t: 7")) << "no checkpoint at t >= 7 s within a minute";
  const double saved = std::stod(killed.out.substr(killed.out.find("t: ") + 3));
  // The rows after the checkpoint, resumed.
  std::ifstream in(kSwitching);
  std::string line;
  std::getline(in, line);
  std::string rest = line + "\n";
  for (; std::getline(in, line);) {
    if (std::stod(line.substr(0, line.find(','))) > saved) rest += line + "\n";
  }
  write_file(dir / "rest.csv", rest);
  const Result resumed = run_skidimm("run -q --bank " + kTerrains + " --input " + (dir / "rest.csv").string() +
                                     " --output - --resume " + state);
  ASSERT_EQ(resumed.exit_code, 0) << resumed.err;
  std::string expected;
  std::ifstream out(whole);
  std::getline(out, line);
  expected = line + "\n";
  for (; std::getline(out, line);) {
    if (std::stod(line.substr(0, line.find(','))) > saved) expected += line + "\n";
  }
  EXPECT_EQ(resumed.out, expected);
  EXPECT_GT(std::count(expected.begin(), expected.end(), '\n'), 1000);
  const Result alone =
      run_skidimm("run -q --bank " + kTerrains + " --input " + kSwitching + " --output - --checkpoint-every 5");
  EXPECT_EQ(alone.exit_code, 2);
  EXPECT_THAT(alone.err, HasSubstr("--checkpoint-every requires --save-checkpoint"));
}

}  // namespace
}  // namespace skidimm_test
