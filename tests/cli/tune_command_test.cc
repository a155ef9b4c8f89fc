// `skidimm tune` on real runs.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "cli/cli_test_support.h"
#include "core/sanitizer.h"
#include "skidimm/config/bank.h"

namespace skidimm_test {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
namespace fs = std::filesystem;

// A second log beside the switching example, for tune, which refuses the
// same file twice: a copy of it in `dir`.
fs::path switching_copy(const fs::path& dir) {
  const fs::path copy = dir / "switching_copy.csv";
  fs::copy_file(kSwitching, copy, fs::copy_options::overwrite_existing);
  return copy;
}

// On real runs the plain IMM (likelihood weight 1) counts the same evidence
// many times: nine features averaged over overlapping windows, whose errors
// move together. `tune --tune likelihood-weight` leaves the weight at 1
// unless a smaller one scores the held-out runs better, so a weight below 1
// in the written bank is that finding, on runs the fit never saw.
// Where tune writes is checked before the fits and searches, which a
// mistyped path found at the end would lose.
TEST(CliIo, TuneChecksWhereItWritesBeforeTheWork) {
  const fs::path dir = test_directory();
  const fs::path copy = switching_copy(dir);
  const std::string tune = kSkidimm + " tune --bank " + kTerrains + " --plugin-path " + kPlugins + " --log " +
                           kSwitching + " --log " + copy.string() + " --objective none --tune dwell --no-assess";
  const fs::path missing = dir / "no_such_directory" / "tuned.yaml";
  expect_refused_before(tune + " --output-bank " + missing.string(),
                        "--output-bank " + missing.string() + ": cannot write there: No such file or directory",
                        "work:");
  expect_refused_before(tune + " --table " + dir.string(), "--table " + dir.string() + ": is a directory", "work:");
  const fs::path file = write_file(dir / "a_file", "not a directory\n");
  expect_refused_before(tune + " --estimates " + file.string(),
                        "--estimates " + file.string() + ": cannot make this directory", "work:");
  // A directory that does not exist yet is made.
  const Result made = run_pipeline(tune + " --estimates " + (dir / "new" / "estimates").string());
  EXPECT_EQ(made.exit_code, 0) << made.err;
  EXPECT_TRUE(fs::is_directory(dir / "new" / "estimates"));
  // A folder an earlier run wrote: eval --estimates on it would score both
  // runs' files as one (9 logs where 4 were tuned). Refused; a folder this
  // run does not write is not. (The lockbox's folder, without an
  // assessment: the same check as a protocol's, at a fraction of the work.)
  const fs::path estimates = dir / "estimates";
  const fs::path third = dir / "third.csv";
  fs::copy_file(kSwitching, third);
  const std::string boxed = tune + " --lockbox " + third.string() + " --estimates " + estimates.string();
  const Result first = run_pipeline(boxed);
  ASSERT_EQ(first.exit_code, 0) << first.err;
  ASSERT_TRUE(fs::exists(estimates / "lockbox" / "002_third.csv"));
  // Runs of several folders that share file names (a folder per terrain) are told apart by their folder.
  for (const char* terrain : {"pavement", "ice", "snow"}) {
    fs::create_directories(dir / terrain);
    fs::copy_file(kSwitching, dir / terrain / "run_00.csv");
  }
  const Result foldered =
      run_pipeline(kSkidimm + " tune --bank " + kTerrains + " --plugin-path " + kPlugins + " --log " +
                   (dir / "pavement" / "run_00.csv").string() + " --log " + (dir / "ice" / "run_00.csv").string() +
                   " --lockbox " + (dir / "snow" / "run_00.csv").string() +
                   " --objective none --tune dwell --no-assess --estimates " + (dir / "foldered").string());
  ASSERT_EQ(foldered.exit_code, 0) << foldered.err;
  EXPECT_TRUE(fs::exists(dir / "foldered" / "lockbox" / "002_snow_run_00.csv"));
  expect_refused_before(boxed,
                        "--estimates " + estimates.string() + ": " + (estimates / "lockbox").string() +
                            " already holds 1 file(s), from an earlier run",
                        "work:");
  fs::create_directories(dir / "other" / "logs");
  const Result other = run_pipeline(boxed + "/../other");
  EXPECT_EQ(other.exit_code, 0) << other.err;
}

// A log given twice, or kept in the lockbox and trained on, would make the
// scores optimistic without a word; an output over a log would replace it;
// a log without labelled time would score as the best there is. All are
// refused before the work, naming what is wrong.
TEST(CliIo, TuneRefusesRepeatedLogsOutputsOverLogsAndLogsWithNothingToScore) {
  const fs::path dir = test_directory();
  const fs::path copy = switching_copy(dir);
  const std::string tune = kSkidimm + " tune --bank " + kTerrains + " --plugin-path " + kPlugins +
                           " --objective none --tune dwell --no-assess --log " + kSwitching + " --log " + copy.string();
  const std::string twice = "the log ltc_switching.csv is given twice (--log " + kSwitching;
  expect_refused_before(tune + " --log " + (fs::path(kSwitching).parent_path() / "." / "ltc_switching.csv").string(),
                        twice, "work:");
  expect_refused_before(tune + " --lockbox " + kSwitching, twice + " and --lockbox " + kSwitching + ")", "work:");
  // A lockbox log's label is the lockbox's, not blamed on --log.
  expect_refused_before(tune + " --lockbox mud=" + kSwitching,
                        "--lockbox 'mud=" + kSwitching + "': 'mud' is neither a mode nor a class of bank", "work:");
  expect_refused_before(tune + " --table " + copy.string(),
                        "--table " + copy.string() + " is the log file " + copy.string() + " itself", "work:");
  expect_refused_before(tune + " --output-bank " + copy.string(), "is the log file " + copy.string() + " itself",
                        "work:");
  EXPECT_EQ(read_file(copy), read_file(kSwitching));
  // The table over the bank or the sessions file it reads, or over the tuned bank.
  const fs::path bank = write_file(dir / "bank.yaml", read_file(kTerrains));
  const fs::path sessions = write_file(dir / "sessions.txt", kSwitching + "\n" + copy.string() + "\n");
  const std::string tune_bank = kSkidimm + " tune --bank " + bank.string() + " --plugin-path " + kPlugins +
                                " --objective none --tune dwell --assess sessions --log " + kSwitching + " --log " +
                                copy.string() + " --sessions " + sessions.string();
  expect_refused_before(tune_bank + " --table " + bank.string(),
                        "--table " + bank.string() + " is the file of --bank (" + bank.string() + ")", "work:");
  expect_refused_before(tune_bank + " --output-bank " + sessions.string(),
                        "--output-bank " + sessions.string() + " is the file of --sessions", "work:");
  const fs::path out = dir / "out.yaml";
  expect_refused_before(tune_bank + " --table " + out.string() + " --output-bank " + out.string(),
                        "--table and --output-bank name the same file (" + out.string() + ")", "work:");
  EXPECT_EQ(read_file(bank), read_file(kTerrains));
  EXPECT_FALSE(fs::exists(out));
  // One row: no interval, so no labelled time.
  const fs::path one_row = one_row_log(dir);
  const Result short_log = run_pipeline(tune + " --log asphalt=" + one_row.string());
  EXPECT_EQ(short_log.exit_code, 1);
  EXPECT_THAT(short_log.err, HasSubstr("asphalt=" + one_row.string() + ": no labelled time to score"));
  // A file that is not there is said to be missing, not to be a pipe.
  const Result missing = run_pipeline(tune + " --log " + (dir / "no_such.csv").string());
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_THAT(missing.err, HasSubstr((dir / "no_such.csv").string() + ": no such log file"));
  EXPECT_THAT(missing.err, Not(HasSubstr("can be read only once")));
}

// A corrupt cell fails the fit on every log, which tune made last, after every
// search and assessment (their folds may keep a mode's starting values; the
// final fit may not): all that work was lost to an error fit gives at once.
// That fit now comes first.
TEST(CliIo, TuneFailsOnACorruptCellBeforeItsSearches) {
  const fs::path dir = test_directory();
  std::ifstream in(kSwitching);
  std::string text, line;
  for (int row = 0; std::getline(in, line); ++row) {
    if (row == 100)
      line = line.substr(0, line.find(',') + 1) + "1e100" + line.substr(line.find(',', line.find(',') + 1));
    text += line + "\n";
  }
  const fs::path corrupt = write_file(dir / "corrupt.csv", text);
  const fs::path table = dir / "table.csv";
  const Result r =
      run_pipeline(kSkidimm + " tune --bank " + kTerrains + " --plugin-path " + kPlugins +
                   " --objective window --tune dwell --inner-folds 2 --log " + kSwitching + " --log " +
                   switching_copy(dir).string() + " --log " + corrupt.string() + " --table " + table.string());
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_THAT(r.err, HasSubstr(corrupt.string() + "[0-9.9905 s]: the prediction from step 100 (t = 2.009000 s)"));
  EXPECT_THAT(r.err, HasSubstr("an absurd input or measurement there"));
  EXPECT_THAT(r.err, Not(HasSubstr("window: dwell"))) << "no search ran";
  EXPECT_THAT(r.err, HasSubstr("3 modes; 13 fits, ")) << "the final fit counted once among them";
  EXPECT_FALSE(fs::exists(table));
}

// Options the command would ignore, or whose outputs would mix, are refused.
// As fit refuses it (FitRefusesHoldUnexcitedWhereNoFitHoldsAnything): a
// bank with a state no measurement observes alone gives the likelihood's
// fits no window fit to hold anything in.
TEST(CliIo, TuneRefusesHoldUnexcitedWhereNoFitHoldsAnything) {
  const fs::path dir = test_directory();
  const fs::path bank = terrains_measuring_v_only(dir);
  const Result tuned = run_pipeline(kSkidimm + " tune --bank " + bank.string() + " --plugin-path " + kPlugins +
                                    " --objective likelihood,none --hold-unexcited --tune dwell --no-assess --log " +
                                    kSwitching + " --log " + switching_copy(dir).string());
  EXPECT_EQ(tuned.exit_code, 2) << tuned.err;
  EXPECT_THAT(tuned.err, HasSubstr("skidimm tune: error: --hold-unexcited would do nothing in the likelihood "
                                   "objective's fits: the bank does not measure [omega] directly"));
  EXPECT_THAT(tuned.err, Not(HasSubstr("work:")));
}

TEST(CliIo, TuneRefusesFitOptionsWithoutAFitAndProtocolsOfOneName) {
  const fs::path dir = test_directory();
  const fs::path copy = switching_copy(dir);
  const std::string tune = kSkidimm + " tune --bank " + kTerrains + " --plugin-path " + kPlugins +
                           " --tune dwell --log " + kSwitching + " --log " + copy.string();
  // A bad command line: exit 2, before anything is read.
  for (const std::string option : {"--parameter-uncertainty", "--residual-correlation", "--pooled-q"}) {
    const Result none = run_pipeline(tune + " --objective none --no-assess " + option);
    EXPECT_EQ(none.exit_code, 2) << none.err;
    EXPECT_THAT(none.err, HasSubstr(option + " is estimated by the window objective; every objective of --objective "
                                             "must be window (got 'none')"));
    EXPECT_THAT(none.err, Not(HasSubstr("work:")));
  }
  // An extrapolation protocol's expression is the command line's: its errors do not blame the bank.
  for (const auto& [expression, said] : std::vector<std::pair<std::string, std::string>>{
           {"nosuch+", "cannot parse \"nosuch+\""}, {"nosuch", "no column 'nosuch'; columns present"}}) {
    const Result r = run_pipeline(tune + " --objective none --assess 'extrapolation:x=" + expression + "'");
    EXPECT_EQ(r.exit_code, 1) << r.err;
    EXPECT_THAT(r.err, HasSubstr("--assess extrapolation:x=" + expression + ": ")) << expression;
    EXPECT_THAT(r.err, HasSubstr(said)) << expression;
    EXPECT_THAT(r.err, Not(HasSubstr("columns.inputs"))) << expression;
  }
  // A number is decimal, as in a bank (CLI11 alone took 0x10 as 16).
  const Result hex = run_pipeline(tune + " --objective none --no-assess --rate 0x10");
  EXPECT_EQ(hex.exit_code, 2) << hex.err;
  EXPECT_THAT(hex.err, HasSubstr("--rate: expected a finite number, got '0x10'"));
  // One log cannot be cross-validated: said before the bank is read (here one that would not load).
  const fs::path broken = write_file(dir / "broken.yaml", "modes: [\n");
  const Result one = run_pipeline(kSkidimm + " tune --bank " + broken.string() + " --log " + kSwitching +
                                  " --objective none --tune dwell --no-assess");
  EXPECT_EQ(one.exit_code, 2) << one.err;
  EXPECT_THAT(one.err, HasSubstr("tune needs at least two logs to cross-validate (--log): one given"));
  EXPECT_THAT(one.err, Not(HasSubstr("broken.yaml")));
  const Result fit_r = run_pipeline(tune + " --objective window --no-assess --fit-r");
  EXPECT_EQ(fit_r.exit_code, 2) << fit_r.err;
  EXPECT_THAT(fit_r.err, HasSubstr("--fit-r is an option of the likelihood objective"));
  // --objective none fits nothing: the fit options were ignored without a word.
  for (const std::string option : {"--full-q", "--hold-unexcited"}) {
    const Result unfitted = run_pipeline(tune + " --objective none --no-assess " + option);
    EXPECT_EQ(unfitted.exit_code, 2) << unfitted.err;
    EXPECT_THAT(unfitted.err,
                HasSubstr(option + " is an option of the fits, and --objective (none) names none that fits"));
    EXPECT_THAT(unfitted.err, Not(HasSubstr("work:")));
  }
  expect_refused_before(
      tune + " --objective none --assess 'extrapolation:v=abs(phi_dot_L),extrapolation:v=abs(phi_dot_R)'",
      "--assess: two protocols named 'extrapolation in v'", "work:");
  // An expression the log cannot give is the protocol's, and said so.
  const Result undefined =
      run_pipeline(tune + " --objective none --inner-folds 2 --assess 'extrapolation:d=1/(phi_dot_L-phi_dot_L)'");
  EXPECT_EQ(undefined.exit_code, 1);
  EXPECT_THAT(undefined.err, HasSubstr("--assess extrapolation:d=1/(phi_dot_L-phi_dot_L): "));
  // --window without the window objective, and a --tune that names nothing ('' tuned the defaults,
  // ',' nothing), were taken without a word.
  const Result window = run_pipeline(tune + " --objective none --no-assess --window 1");
  EXPECT_EQ(window.exit_code, 2) << window.err;
  EXPECT_THAT(window.err, HasSubstr("--window is the window objective's, which --objective (none) does not name"));
  const std::string untuned = kSkidimm + " tune --bank " + kTerrains + " --plugin-path " + kPlugins + " --log " +
                              kSwitching + " --log " + copy.string() + " --objective none --no-assess --tune ";
  for (const std::string knobs : {"''", "','"}) {
    const Result none = run_pipeline(untuned + knobs);
    EXPECT_EQ(none.exit_code, 2) << knobs << ": " << none.err;
    EXPECT_THAT(none.err, HasSubstr("--tune: expected one or more settings")) << knobs;
  }
  // A mistyped name in --objective, --tune or --assess is a bad command line, found before the logs are read.
  const std::string logs = kSkidimm + " tune --bank " + kTerrains + " --plugin-path " + kPlugins + " --log " +
                           kSwitching + " --log " + copy.string();
  for (const auto& [option, expected] :
       {std::make_pair(
            std::string(" --objective windw"),
            std::string(
                "--objective: unknown fit objective 'windw' (expected likelihood or window), or none (no fit)")),
        std::make_pair(std::string(" --objective none --tune dwell,dwel"),
                       std::string("--tune: unknown setting 'dwel'")),
        std::make_pair(std::string(" --objective none --assess session"),
                       std::string("--assess: unknown protocol 'session'")),
        std::make_pair(std::string(" --objective none --assess extrapolation:v:2"),
                       std::string("--assess: protocol 'extrapolation:v:2': expected a fraction in (0, 1)"))}) {
    const Result typo = run_pipeline(logs + option);
    EXPECT_EQ(typo.exit_code, 2) << option << ": " << typo.err;
    EXPECT_THAT(typo.err, HasSubstr(expected)) << option;
    EXPECT_THAT(typo.err, Not(HasSubstr("work:"))) << option;
  }
  // --sessions without the protocol that holds sessions out was checked against the logs and ignored.
  const fs::path sessions = write_file(dir / "sessions.txt", kSwitching + " a\n" + copy.string() + " b\n");
  for (const std::string assess : {" --assess logs", " --no-assess"}) {
    const Result unused = run_pipeline(tune + " --objective none" + assess + " --sessions " + sessions.string());
    EXPECT_EQ(unused.exit_code, 2) << assess << ": " << unused.err;
    EXPECT_THAT(unused.err, HasSubstr("--sessions " + sessions.string() +
                                      ": the sessions are used only by --assess sessions, which this command does "
                                      "not run"))
        << assess;
    EXPECT_THAT(unused.err, Not(HasSubstr("work:"))) << assess;
  }
}

// Three BorealTC runs each of flooring and ice (those present), as `--log`
// arguments.
std::string flooring_and_ice_runs(const std::string& boreal,
                                  const std::vector<std::string>& terrains = {"FLOORING", "ICE"}) {
  std::string logs;
  for (const std::string& terrain : terrains) {
    for (const std::string run : {"00", "01", "05"}) {
      if (!fs::exists(boreal + "/" + terrain + "/pro_" + run + ".csv")) continue;
      logs += " --log '" + terrain + "=" + boreal + "/" + terrain + "/pro_" + run + ".csv+" + boreal + "/" + terrain +
              "/imu_" + run + ".csv'";
    }
  }
  return logs;
}

// The BorealTC start bank tuned (the floor alone) on flooring_and_ice_runs()
// (of `terrains`), with the fit options `common`, without and with `option`:
// the two banks written.
std::pair<skidimm::BankConfig, skidimm::BankConfig> tuned_without_and_with(
    const fs::path& dir, const std::string& boreal, const std::string& common, const std::string& option,
    const std::vector<std::string>& terrains = {"FLOORING", "ICE"}) {
  const std::string tune = "tune -q --bank " + kSource + "/configs/borealtc/terrains_start.yaml" +
                           flooring_and_ice_runs(boreal, terrains) +
                           " --objective window --hold-unexcited --tune floor --no-assess --threads 2 " + common +
                           " --plugin-path " + kPlugins + " --output-bank ";
  const Result without = run_skidimm(tune + (dir / "without.yaml").string());
  EXPECT_EQ(without.exit_code, 0) << without.err;
  const Result with = run_skidimm(tune + (dir / "with.yaml").string() + " " + option);
  EXPECT_EQ(with.exit_code, 0) << with.err;
  return {skidimm::load_bank_config(dir / "without.yaml"), skidimm::load_bank_config(dir / "with.yaml")};
}

TEST(Cli, TuneTempersTheEvidenceOfABankThatOvercountsItOnRealRuns) {
  SKIDIMM_SKIP_UNDER_SANITIZERS_STATISTICAL();  // Tune.* and HostileInput.Tune* run the same code under them
  const std::string boreal = std::string(SKIDIMM_SHARED_DATA_DIR) + "/borealtc";
  if (!fs::exists(boreal)) GTEST_SKIP() << "no shared data at " << boreal;
  const fs::path dir = test_directory();
  const std::string logs = flooring_and_ice_runs(boreal);
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

// tune chooses by the probabilities; a decision threshold they rarely reach
// with the chosen settings leaves the robot's decision `unknown`, which the
// accuracy of the most likely class does not show: tune reports the
// decision and warns.
TEST(Cli, TuneSaysWhenTheChosenSettingsLeaveTheDecisionUnknown) {
  const std::string boreal = std::string(SKIDIMM_SHARED_DATA_DIR) + "/borealtc";
  if (!fs::exists(boreal)) GTEST_SKIP() << "no shared data at " << boreal;
  const fs::path dir = test_directory();
  std::string text = read_file(kSource + "/configs/borealtc/terrains_start.yaml");
  const std::string decision = "decision: {enter: 0.5,";
  ASSERT_NE(text.find(decision), std::string::npos);
  text.replace(text.find(decision), decision.size(), "decision: {enter: 0.99,");
  const fs::path bank = write_file(dir / "enter_099.yaml", text);
  const Result tune = run_skidimm("tune -q --bank " + bank.string() + flooring_and_ice_runs(boreal) +
                                  " --objective window --hold-unexcited --full-q --tune likelihood-weight --no-assess"
                                  " --threads 2 --plugin-path " +
                                  kPlugins);
  ASSERT_EQ(tune.exit_code, 0) << tune.err;
  EXPECT_THAT(tune.out, HasSubstr("  the decision (enter 0.99, leave 0.05, hold 1 s): right "));
  EXPECT_THAT(tune.err, HasSubstr("skidimm tune: warning: with the chosen settings the bank's decision (enter 0.99, "
                                  "leave 0.05, hold 1 s) is `unknown` "));
  EXPECT_THAT(tune.err, HasSubstr("A lower enter decides more often"));
}

// --uncertainty-per-log reaches every fit tune makes: on real runs, each
// mode's parameter covariance in the tuned bank is the independent rows' or
// larger, and larger for some mode, each run being missed by an offset of
// its own.
TEST(Cli, TuneCountsEachLogsRowsAsCorrelatedWhenAsked) {
  const std::string boreal = std::string(SKIDIMM_SHARED_DATA_DIR) + "/borealtc";
  if (!fs::exists(boreal)) GTEST_SKIP() << "no shared data at " << boreal;
  const fs::path dir = test_directory();
  const auto [a, b] = tuned_without_and_with(dir, boreal, "--parameter-uncertainty", "--uncertainty-per-log");
  ASSERT_EQ(a.modes.size(), b.modes.size());
  int widened = 0;
  for (std::size_t j = 0; j < a.modes.size(); ++j) {
    const Eigen::VectorXd before = a.modes[j].parameter_covariance.diagonal();
    const Eigen::VectorXd after = b.modes[j].parameter_covariance.diagonal();
    if (before.size() == 0) continue;  // a mode without logs here keeps its start
    ASSERT_EQ(after.size(), before.size()) << a.modes[j].name;
    for (Eigen::Index i = 0; i < before.size(); ++i) {
      EXPECT_GE(after[i], before[i] * (1.0 - 1e-9)) << a.modes[j].name << " " << i;
    }
    widened += (after.array() > 2.0 * before.array()).any() ? 1 : 0;
  }
  EXPECT_GT(widened, 0);
}

// --partial-pooling reaches the fits tune makes from per-mode fits: on real
// runs of three terrains, the modes of a regime (one fit_when) that all three
// fitted have their estimates drawn together (their slopes' spread over the
// terrains narrower) and their covariances narrower on the whole; a regime
// of fewer than three fitted modes (these runs leave one terrain without
// steps of one regime) and the terrains without logs keep their own.
// Without --parameter-uncertainty it is a bad command line.
TEST(Cli, TunePoolsTheFitsOfEachRegimesModesPartiallyWhenAsked) {
  const std::string boreal = std::string(SKIDIMM_SHARED_DATA_DIR) + "/borealtc";
  if (!fs::exists(boreal)) GTEST_SKIP() << "no shared data at " << boreal;
  const fs::path dir = test_directory();
  const auto [a, b] = tuned_without_and_with(dir, boreal, "--parameter-uncertainty", "--partial-pooling",
                                             {"FLOORING", "ICE", "SANDY_LOAM"});
  ASSERT_EQ(a.modes.size(), b.modes.size());
  const auto slopes = [](const skidimm::ModeConfig& mode) {
    const Eigen::MatrixXd* b = mode.params.find("B");
    return b == nullptr ? Eigen::VectorXd() : Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(b->data(), b->size()));
  };
  std::map<std::string, std::vector<std::size_t>> regimes;  // fitted modes by fit_when
  for (std::size_t j = 0; j < a.modes.size(); ++j) {
    if (a.modes[j].parameter_covariance.size() > 0) regimes[a.modes[j].fit_when].push_back(j);
  }
  int pooled_regimes = 0;
  for (std::size_t j = 0; j < a.modes.size(); ++j) {
    const bool fitted = a.modes[j].parameter_covariance.size() > 0;
    if (!fitted || regimes.at(a.modes[j].fit_when).size() < 3) {
      EXPECT_EQ(slopes(b.modes[j]), slopes(a.modes[j])) << "its own: " << a.modes[j].name;
    }
  }
  for (const auto& [fit_when, members] : regimes) {
    if (members.size() < 3) continue;
    ++pooled_regimes;
    ASSERT_EQ(members.size(), 3u);
    std::vector<Eigen::VectorXd> own, pooled;
    double variance_own = 0.0, variance_pooled = 0.0;
    for (std::size_t j : members) {
      own.push_back(slopes(a.modes[j]));
      pooled.push_back(slopes(b.modes[j]));
      EXPECT_GT((pooled.back() - own.back()).norm(), 1e-6 * own.back().norm()) << a.modes[j].name;
      variance_own += a.modes[j].parameter_covariance.trace();
      variance_pooled += b.modes[j].parameter_covariance.trace();
    }
    double spread_own = 0.0, spread_pooled = 0.0;
    for (std::size_t m = 0; m < 3; ++m) {
      spread_own += (own[m] - (own[0] + own[1] + own[2]) / 3.0).squaredNorm();
      spread_pooled += (pooled[m] - (pooled[0] + pooled[1] + pooled[2]) / 3.0).squaredNorm();
    }
    EXPECT_LT(spread_pooled, spread_own) << "fit_when '" << fit_when << "'";
    EXPECT_LT(variance_pooled, variance_own) << "fit_when '" << fit_when << "'";
  }
  EXPECT_EQ(pooled_regimes, 1);
  const Result refused = run_skidimm("tune --bank " + kSource + "/configs/borealtc/terrains_start.yaml" +
                                     flooring_and_ice_runs(boreal) + " --objective window --partial-pooling");
  EXPECT_EQ(refused.exit_code, 2) << refused.err;
  EXPECT_THAT(refused.err, HasSubstr("--parameter-uncertainty"));
}

// --pooled-q reaches every fit tune makes, the separable folds' included:
// in the tuned bank every mode fitted on these real runs has one Q, the mean
// of the Q each has without it (the knob tuned, the floor, leaves Q alone).
TEST(Cli, TuneGivesEveryFittedModeThePooledQWhenAsked) {
  const std::string boreal = std::string(SKIDIMM_SHARED_DATA_DIR) + "/borealtc";
  if (!fs::exists(boreal)) GTEST_SKIP() << "no shared data at " << boreal;
  const fs::path dir = test_directory();
  const auto [a, b] = tuned_without_and_with(dir, boreal, "--full-q", "--pooled-q");
  std::vector<std::size_t> fitted;
  for (std::size_t j = 0; j < a.modes.size(); ++j) {
    if (a.modes[j].name.rfind("FLOORING", 0) == 0 || a.modes[j].name.rfind("ICE", 0) == 0) fitted.push_back(j);
  }
  ASSERT_EQ(fitted.size(), 4u);
  Eigen::MatrixXd mean = Eigen::MatrixXd::Zero(a.modes[0].q_intensity.rows(), a.modes[0].q_intensity.cols());
  for (std::size_t j : fitted) mean += a.modes[j].q_intensity / 4.0;
  EXPECT_GT((a.modes[fitted[0]].q_intensity - a.modes[fitted[3]].q_intensity).norm(), 0.1 * mean.norm());
  for (std::size_t j : fitted) {
    // The bank file keeps 7 significant digits.
    EXPECT_LT((b.modes[j].q_intensity - mean).norm(), 1e-5 * mean.norm()) << b.modes[j].name;
  }
  for (std::size_t j = 0; j < a.modes.size(); ++j) {
    if (std::find(fitted.begin(), fitted.end(), j) == fitted.end()) {
      EXPECT_EQ(b.modes[j].q_intensity, a.modes[j].q_intensity) << "no logs: its start, " << a.modes[j].name;
    }
  }
}

// A bank tuned at --rate steps at it: its fits and its scores are of steps
// of that length, and its aggregated features measure what they measure
// there only (as fit, fit_command_test.cc).
TEST(Cli, ABankTunedAtAnotherRateIsWrittenWithIt) {
  const std::string boreal = std::string(SKIDIMM_SHARED_DATA_DIR) + "/borealtc";
  if (!fs::exists(boreal)) GTEST_SKIP() << "no shared data at " << boreal;
  const fs::path dir = test_directory();
  std::string tune = "tune -q --bank " + kSource +
                     "/configs/borealtc/wheels_start.yaml --objective window --hold-unexcited --tune floor "
                     "--no-assess --threads 2";
  for (const char* log : {"ASPHALT/pro_00", "ASPHALT/pro_01", "ICE/pro_00", "ICE/pro_02"}) {
    const std::string path(log);
    tune += " --log '" + path.substr(0, path.find('/')) + "=" + boreal + "/" + path + ".csv'";
  }
  const Result at_4 = run_skidimm(tune + " --rate 4 --output-bank " + (dir / "at_4.yaml").string());
  ASSERT_EQ(at_4.exit_code, 0) << at_4.err;
  EXPECT_THAT(read_file(dir / "at_4.yaml"), HasSubstr("\nsampling:\n  rate: 4\nmeasurement:\n"));
  EXPECT_EQ(skidimm::load_bank_config(dir / "at_4.yaml").sampling.rate, 4.0);
  const Result own = run_skidimm(tune + " --output-bank " + (dir / "own.yaml").string());
  ASSERT_EQ(own.exit_code, 0) << own.err;
  EXPECT_THAT(read_file(dir / "own.yaml"), HasSubstr("sampling:\n  rate: 2                                # Hz:"));
}

// Logs that cannot assess what tune reports: one class only (its verdict
// read "told apart"), a class of one log (held out, its modes are fitted on
// nothing), or classes of none (their modes compete unfitted). Said before
// the work.
TEST(Cli, TuneWarnsOfClassesWithTooFewLogs) {
  const std::string boreal = std::string(SKIDIMM_SHARED_DATA_DIR) + "/borealtc";
  if (!fs::exists(boreal)) GTEST_SKIP() << "no shared data at " << boreal;
  const std::string tune = "tune -q --bank " + kSource +
                           "/configs/borealtc/wheels_start.yaml --objective window --hold-unexcited --tune floor "
                           "--threads 2";
  const auto logs = [&](std::initializer_list<const char*> runs) {
    std::string out;
    for (const char* run : runs) {
      const std::string path(run);
      out += " --log '" + path.substr(0, path.find('/')) + "=" + boreal + "/" + path + ".csv'";
    }
    return out;
  };
  const Result one_class = run_skidimm(tune + logs({"ASPHALT/pro_00", "ASPHALT/pro_01", "ASPHALT/pro_03"}));
  ASSERT_EQ(one_class.exit_code, 0) << one_class.err;
  EXPECT_THAT(one_class.err, HasSubstr("warning: the development logs show one class only (ASPHALT): there is "
                                       "nothing to tell apart"));
  const Result one_log = run_skidimm(tune + logs({"ASPHALT/pro_00", "SNOW/pro_00", "SNOW/pro_03"}));
  ASSERT_EQ(one_log.exit_code, 0) << one_log.err;
  EXPECT_THAT(one_log.err, HasSubstr("warning: class ASPHALT has one development log: a fold that holds such a log "
                                     "out has no log to fit its class's modes on"));
  EXPECT_THAT(one_log.err, Not(HasSubstr("one class only")));
  EXPECT_THAT(one_log.err, Not(HasSubstr("--tune dwell"))) << "the dwell time is not searched";
  // Logs of one class each show no change: a dwell time tuned on them only grows.
  std::string dwell = tune;
  dwell.replace(dwell.find("--tune floor"), 12, "--tune dwell --no-assess");
  const Result sticky = run_skidimm(dwell + logs({"ASPHALT/pro_00", "ASPHALT/pro_01", "SNOW/pro_00", "SNOW/pro_03"}));
  ASSERT_EQ(sticky.exit_code, 0) << sticky.err;
  EXPECT_THAT(sticky.err, HasSubstr("warning: --tune dwell on logs that each hold one class: none shows a change"));
  // The default settings leave the dwell time to the bank there, and say so.
  std::string defaults = tune;
  defaults.replace(defaults.find("--tune floor"), 12, "--no-assess");
  const Result by_default =
      run_skidimm(defaults + logs({"ASPHALT/pro_00", "ASPHALT/pro_01", "SNOW/pro_00", "SNOW/pro_03"}));
  ASSERT_EQ(by_default.exit_code, 0) << by_default.err;
  EXPECT_THAT(by_default.err, HasSubstr("the dwell time is left out of the default settings"));
  EXPECT_THAT(by_default.err, Not(HasSubstr("warning: --tune dwell")));
  EXPECT_THAT(by_default.out, HasSubstr("dwell 10 s")) << "wheels_start.yaml's, not searched";
  // The classes no log shows compete unfitted, where tune fits.
  EXPECT_THAT(one_log.err, HasSubstr("warning: classes FLOORING, ICE, SANDY_LOAM have no development log: no fit "
                                     "gives their modes anything to learn"));
  const fs::path tuned = test_directory() / "tuned.yaml";
  const Result enough = run_skidimm(tune + logs({"ASPHALT/pro_00", "ASPHALT/pro_01", "SNOW/pro_00", "SNOW/pro_03"}) +
                                    " --output-bank " + tuned.string());
  ASSERT_EQ(enough.exit_code, 0) << enough.err;
  // The tuned bank's header says how its nested score stands against a
  // guess, as the report does: read alone, it must not read better. Two
  // logs of each class say too little of how logs differ for a range.
  const std::string header = read_file(tuned);
  EXPECT_THAT(header, ::testing::ContainsRegex("Nested cross-validated accuracy [0-9.]+, mean log p\\(truth\\) "
                                               "[-0-9.]+ \\(mean over classes of the mean over their logs; too few "
                                               "logs for a range of what others would score; each "
                                               "log's mean, averaged, [-0-9.]+ against a uniform guess over 5 "
                                               "classes, -1.609: (the classes are told apart|unclear whether|the "
                                               "classes are not told apart|worse than the guess)"));
  EXPECT_THAT(enough.err, Not(HasSubstr("one development log")));
  EXPECT_THAT(enough.err, Not(HasSubstr("one class only")));
}

// Under each held-out table tune says where another set of logs would
// score, of the counts --range-for gives: the same range that `eval
// --range-for` gives on the held-out outputs tune wrote (another path through
// the code, from the files). Counts that cannot fit: a class that is not the
// bank's, or that no development log holds, is refused before the work; a
// set that leaves out a scored class is said where the range would be.
TEST(Cli, TuneGivesTheRangeOfAccuracyOfTheCountsAskedForAsEvalDoes) {
  const std::string boreal = std::string(SKIDIMM_SHARED_DATA_DIR) + "/borealtc";
  if (!fs::exists(boreal)) GTEST_SKIP() << "no shared data at " << boreal;
  std::string tune = "tune -q --bank " + kSource +
                     "/configs/borealtc/wheels_start.yaml --objective window --hold-unexcited --tune floor --threads 2";
  for (const char* run : {"ASPHALT/pro_00", "ASPHALT/pro_01", "ASPHALT/pro_03", "SNOW/pro_00", "SNOW/pro_03",
                          "SNOW/pro_06", "SNOW/pro_07"}) {
    const std::string path(run);
    tune += " --log '" + path.substr(0, path.find('/')) + "=" + boreal + "/" + path + ".csv'";
  }
  const fs::path dir = test_directory();
  const fs::path tuned = dir / "tuned.yaml", estimates = dir / "held_out";
  const Result asked = run_skidimm(tune + " --range-for ASPHALT=2,SNOW=9 --estimates " + estimates.string() +
                                   " --output-bank " + tuned.string());
  ASSERT_EQ(asked.exit_code, 0) << asked.err;
  const std::string sentence_start =
      "another 11 logs drawn like these (ASPHALT 2, SNOW 9) would score a mean over "
      "classes between ";
  const std::size_t at = asked.out.find(sentence_start);
  ASSERT_NE(at, std::string::npos) << asked.out;
  const std::string sentence = asked.out.substr(at, asked.out.find('\n', at) - at);
  EXPECT_THAT(sentence, HasSubstr("5 degrees of freedom")) << "(3 - 1) + (4 - 1) from the logs scored";
  const Result eval = run_skidimm("eval --estimates " + (estimates / "logs").string() + " --bank " + tuned.string() +
                                  " --range-for ASPHALT=2,SNOW=9");
  ASSERT_EQ(eval.exit_code, 0) << eval.err;
  EXPECT_THAT(eval.out, HasSubstr(sentence));
  // The bank's header says it too, in its own words.
  const std::string low_high = sentence.substr(sentence_start.size(), 18);  // "0.xxx and 0.yyy (a"
  ASSERT_EQ(low_high.substr(5, 5), " and ") << sentence;
  EXPECT_THAT(read_file(tuned), HasSubstr("; 11 other logs like these (ASPHALT 2, SNOW 9), 90% range " +
                                          low_high.substr(0, 5) + " to " + low_high.substr(10, 5) + ";"));
  // Without it, as many as were scored.
  const Result own = run_skidimm(tune);
  ASSERT_EQ(own.exit_code, 0) << own.err;
  EXPECT_THAT(own.out, HasSubstr("another 7 logs drawn like these (ASPHALT 3, SNOW 4) would score"));

  const Result not_a_class = run_skidimm(tune + " --range-for ASPHALT=2,MUD=3");
  EXPECT_EQ(not_a_class.exit_code, 2);
  EXPECT_THAT(not_a_class.err, HasSubstr("--range-for: 'MUD' is not a class of the bank"));
  EXPECT_THAT(not_a_class.err, HasSubstr("(its classes: ASPHALT, FLOORING, ICE, SANDY_LOAM, SNOW)"));
  const Result not_held = run_skidimm(tune + " --range-for ASPHALT=2,ICE=4,SNOW=9");
  EXPECT_EQ(not_held.exit_code, 2);
  EXPECT_THAT(not_held.err, HasSubstr("--range-for: no development log (--log) holds class 'ICE'"));
  EXPECT_TRUE(not_held.out.empty()) << "refused before the work";
  const Result malformed = run_skidimm(tune + " --range-for ASPHALT=two");
  EXPECT_EQ(malformed.exit_code, 2);
  EXPECT_THAT(malformed.err, HasSubstr("'ASPHALT=two' is not CLASS=COUNT"));
  const Result no_table = run_skidimm(tune + " --range-for ASPHALT=2,SNOW=9 --no-assess");
  EXPECT_EQ(no_table.exit_code, 2);
  EXPECT_THAT(no_table.err, HasSubstr("--no-assess without --lockbox prints none"));
  const Result leaves_out = run_skidimm(tune + " --range-for ASPHALT=2");
  ASSERT_EQ(leaves_out.exit_code, 0) << leaves_out.err;
  EXPECT_THAT(leaves_out.out, HasSubstr("no range for --range-for: the other set leaves out class 'SNOW'"));
}

// The bundled switching log in four parts, as `--log` arguments.
std::string switching_log_in_four_parts(const fs::path& dir) {
  const std::string log = read_file(kSwitching);
  const std::size_t header_end = log.find('\n') + 1;
  std::vector<std::string> rows;
  for (std::size_t at = header_end; at < log.size();) {
    const std::size_t end = log.find('\n', at);
    rows.push_back(log.substr(at, end - at + 1));
    at = end + 1;
  }
  std::string logs;
  for (std::size_t part = 0; part < 4; ++part) {
    std::string text = log.substr(0, header_end);
    for (std::size_t r = part * rows.size() / 4; r < (part + 1) * rows.size() / 4; ++r) text += rows[r];
    logs += " --log " + write_file(dir / ("part" + std::to_string(part) + ".csv"), text).string();
  }
  return logs;
}

// Logs of two folders with the same file names (as BorealTC's terrains
// have) were named alike in tune's tables and --table: each is named by the
// folder that tells it apart.
TEST(Cli, TuneNamesLogsOfTheSameFileNameByTheirFolders) {
  const fs::path dir = test_directory();
  fs::create_directories(dir / "a");
  fs::create_directories(dir / "b");
  const std::string logs = switching_log_in_four_parts(dir / "a") + switching_log_in_four_parts(dir / "b");
  const fs::path table = dir / "scores.csv";
  const Result tune = run_skidimm("tune --bank " + kTerrains + logs + " --objective none --tune dwell --assess logs " +
                                  "--threads 1 --plugin-path " + kPlugins + " --table " + table.string());
  ASSERT_EQ(tune.exit_code, 0) << tune.err;
  const std::string scores = read_file(table);
  for (const std::string folder : {"a", "b"}) {
    for (int part = 0; part < 4; ++part) {
      const std::string name = folder + "/part" + std::to_string(part) + ".csv";
      EXPECT_THAT(scores, HasSubstr("," + name + ",")) << scores;
      EXPECT_THAT(tune.out, HasSubstr("  " + name + " ")) << tune.out;
    }
  }
  EXPECT_THAT(scores, Not(::testing::ContainsRegex(",part[0-9][.]csv,")));
}

// `--tune unknown-inflation` chooses the unknown hypothesis' covariance
// factor in each fold and writes it into the bank with its enter and leave
// as they were; a bank without `unknown:` has nothing to tune and says so.
// The bundled switching log in four parts, the bank's models as they are.
TEST(Cli, TuneChoosesTheUnknownInflationOfABankThatHasOne) {
  const fs::path dir = test_directory();
  const std::string logs = switching_log_in_four_parts(dir);
  const fs::path bank =
      write_file(dir / "unknown.yaml", "unknown: {inflation: 100, enter: 0.01, leave: 0.2}\n" + read_file(kTerrains));
  const std::string args = logs + " --objective none --tune unknown-inflation --no-assess --threads 1 --plugin-path " +
                           kPlugins + " --output-bank " + (dir / "tuned.yaml").string();
  const Result tune = run_skidimm("tune --bank " + bank.string() + args);
  ASSERT_EQ(tune.exit_code, 0) << tune.err;
  EXPECT_THAT(tune.err, HasSubstr("unknown inflation"));
  const skidimm::BankConfig tuned = skidimm::load_bank_config(dir / "tuned.yaml");
  EXPECT_TRUE(tuned.unknown.enabled());
  EXPECT_EQ(tuned.unknown.enter, 0.01);
  EXPECT_EQ(tuned.unknown.leave, 0.2);
  EXPECT_THAT(read_file(dir / "tuned.yaml"), HasSubstr("unknown inflation"));  // the header's chosen settings
  const Result plain = run_skidimm("tune --bank " + kTerrains + args);
  EXPECT_NE(plain.exit_code, 0);
  EXPECT_THAT(plain.err, HasSubstr("--tune unknown-inflation needs a bank with an unknown hypothesis"));
}

// The settings scored, from the last progress line ("searches: N settings scored, ...").
long settings_scored(const std::string& err) {
  const std::size_t at = err.rfind("searches: ");
  return at == std::string::npos ? -1 : std::stol(err.substr(at + std::string("searches: ").size()));
}

// `--walk` walks each setting's grid instead of scoring all of it: fewer
// settings scored, and the tuned bank says how to reproduce it. The bundled
// switching log in four parts, the bank's models as they are.
TEST(Cli, TuneWalksEachSettingsGridWhenAskedTo) {
  const fs::path dir = test_directory();
  const std::string args = switching_log_in_four_parts(dir) +
                           " --objective none --tune likelihood-weight,q-scale --no-assess --threads 1 --plugin-path " +
                           kPlugins + " --output-bank ";
  const Result grid = run_skidimm("tune --bank " + kTerrains + args + (dir / "grid.yaml").string());
  ASSERT_EQ(grid.exit_code, 0) << grid.err;
  const Result walk = run_skidimm("tune --walk --bank " + kTerrains + args + (dir / "walk.yaml").string());
  ASSERT_EQ(walk.exit_code, 0) << walk.err;
  EXPECT_GT(settings_scored(walk.err), 2) << walk.err;
  EXPECT_LT(settings_scored(walk.err), settings_scored(grid.err)) << walk.err << grid.err;
  EXPECT_THAT(read_file(dir / "walk.yaml"), HasSubstr("skidimm tune --walk --bank "));
  EXPECT_THAT(read_file(dir / "grid.yaml"), Not(HasSubstr("--walk")));
}

// A fold without logs of a mode keeps that mode's starting values, which a
// fit must say; `--objective none` keeps every mode's anyway, so it says
// nothing. The first and last quarters of the bundled switching log, which
// leave out at least one of its three terrains.
TEST(Cli, TuneWithoutAFitSaysNothingOfModesWithoutLogs) {
  const fs::path dir = test_directory();
  const std::string logs = switching_log_in_four_parts(dir);
  const std::string two_parts = " --log " + (dir / "part0.csv").string() + " --log " + (dir / "part3.csv").string();
  ASSERT_THAT(logs, HasSubstr((dir / "part3.csv").string()));
  const std::string args = two_parts + " --tune dwell --no-assess --threads 1 --plugin-path " + kPlugins +
                           " --output-bank " + (dir / "tuned.yaml").string();
  const Result fitted = run_skidimm("tune --bank " + kTerrains + args + " --objective window");
  ASSERT_EQ(fitted.exit_code, 0) << fitted.err;
  EXPECT_THAT(fitted.err, HasSubstr("kept their starting values (objective window)"));
  const Result kept = run_skidimm("tune --bank " + kTerrains + args + " --objective none");
  ASSERT_EQ(kept.exit_code, 0) << kept.err;
  EXPECT_THAT(kept.err, Not(HasSubstr("starting values"))) << kept.err;
}

// `--tune extrapolation-scale` searches the scale with "off" among the
// candidates and says what it chose; each nested assessment reports the share
// of its held-out steps outside the ranges the true class was fitted on. The
// bundled terrains given narrow ranges (every terrain [0, 1] rad/s on both
// wheels), the bank's models as they are, so the share is that of the rows.
TEST(Cli, TuneSearchesTheExtrapolationScaleAndReportsTheHeldOutStepsOutsideTheFittedRanges) {
  const fs::path dir = test_directory();
  const std::string logs = switching_log_in_four_parts(dir);
  std::string narrow = read_file(kTerrains);
  ASSERT_EQ(with_fitted_inputs(&narrow, "{phi_dot_L: [0, 1], phi_dot_R: [0, 1]}"), 3);
  const RowsOutside outside = switching_rows_outside(0.0, 1.0);
  ASSERT_GT(outside.outside, 0);
  const fs::path bank = write_file(dir / "narrow.yaml", narrow);
  const Result tune =
      run_skidimm("tune --bank " + bank.string() + logs +
                  " --objective none --tune extrapolation-scale --assess logs --threads 1 --plugin-path " + kPlugins +
                  " --output-bank " + (dir / "tuned.yaml").string());
  ASSERT_EQ(tune.exit_code, 0) << tune.err;
  EXPECT_THAT(tune.err, HasSubstr("extrapolation scale"));
  EXPECT_THAT(tune.out, HasSubstr(", extrapolation scale "));  // "chosen: ...": a scale, or "off"
  EXPECT_THAT(tune.out, HasSubstr("inputs outside the ranges the true class was fitted on: " + outside.percent +
                                  " of the labelled steps; the most likely class right on "));
  const skidimm::BankConfig tuned = skidimm::load_bank_config(dir / "tuned.yaml");
  EXPECT_EQ(tuned.extrapolation_scale > 0.0, tune.out.find(", extrapolation scale off") == std::string::npos);
  // Ranges every row is inside: the accuracy over all the steps, and no
  // empty side ("-") to report.
  std::string wide = read_file(kTerrains);
  ASSERT_EQ(with_fitted_inputs(&wide, "{phi_dot_L: [-100, 100], phi_dot_R: [-100, 100]}"), 3);
  const Result inside =
      run_skidimm("tune --bank " + write_file(dir / "wide.yaml", wide).string() + logs +
                  " --objective none --tune dwell --assess logs --threads 1 --plugin-path " + kPlugins);
  ASSERT_EQ(inside.exit_code, 0) << inside.err;
  EXPECT_THAT(inside.out, ::testing::ContainsRegex("inputs outside the ranges the true class was fitted on: 0.0% of "
                                                   "the labelled steps; the most likely class right on "
                                                   "[0-9]+[.][0-9]% of the steps\n"));
  EXPECT_THAT(inside.out, Not(HasSubstr("right on -")));
  // A bank without ranges: nothing to report.
  std::string none = read_file(kTerrains);
  with_fitted_inputs(&none, "");
  const Result plain =
      run_skidimm("tune --bank " + write_file(dir / "none.yaml", none).string() + logs +
                  " --objective none --tune dwell --assess logs --threads 1 --plugin-path " + kPlugins);
  ASSERT_EQ(plain.exit_code, 0) << plain.err;
  EXPECT_THAT(plain.out, ::testing::Not(HasSubstr("inputs outside")));
}

}  // namespace
}  // namespace skidimm_test
