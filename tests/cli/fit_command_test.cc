// `skidimm fit` end to end: the paper's loop (fit a new terrain from logs,
// append it to a bank, identify it without rebuilding), modes taken from a
// truth column or a class label, the likelihood objective and the bank's R,
// bad logs, non-finite or absurd cells and fitter errors named by log, row
// and option with nothing appended. It says what it fitted on: it counts
// logs (files), not the segments a truth column cuts them into, and writes a
// model's parameters in the order of its own table.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "cli/cli_test_support.h"
#include "skidimm/config/bank.h"
#include "skidimm/io/csv.h"

namespace skidimm_test {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
namespace fs = std::filesystem;

TEST(FitCommand, CountsLogsNotTheSegmentsTheirTruthCutsThemInto) {
  // The switching log with its first 5 s relabelled asphalt: asphalt is then
  // the truth of two stretches of one file.
  auto rows = read_csv(kSource + "/configs/examples/ltc_switching.csv");
  const int t = column(rows[0], "t"), mode = column(rows[0], "mode");
  for (std::size_t i = 1; i < rows.size(); ++i) {
    if (std::stod(rows[i][static_cast<std::size_t>(t)]) < 5.0) rows[i][static_cast<std::size_t>(mode)] = "asphalt";
  }
  const fs::path dir = test_directory();
  const fs::path first = write_file(dir / "first.csv", csv_text(rows));
  const fs::path second = write_file(dir / "second.csv", csv_text(rows));
  const Result r = run_skidimm("fit --bank " + kSource + "/configs/ltc_terrains.yaml --plugin-path " + kPlugins +
                               " --objective window --window 0.5 --log " + first.string() + " --log " + second.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.err, HasSubstr("mode 'asphalt': 2 log(s) (4 segments), "));
  EXPECT_THAT(r.err, HasSubstr("mode 'grass': 2 log(s), "));
  EXPECT_THAT(r.out, HasSubstr("fitted by skidimm fit (window 0.5 s, huber) from 2 log(s); "));
  EXPECT_THAT(r.out, ::testing::Not(HasSubstr("from 4 log(s)")));
}

// The parameter names `skidimm plugins` lists for `plugin`, in its table's order.
std::vector<std::string> parameter_table(const std::string& plugin) {
  const Result r = run_skidimm("plugins --plugin-path " + kPlugins);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  std::vector<std::string> names;
  const std::size_t start = r.out.find("\n" + plugin + " ");
  const std::size_t table = r.out.find("    parameters:\n", start);
  const std::size_t end = r.out.find("\n\n", table);
  static const std::regex row(R"(^      (\w+) \()");
  std::istringstream lines(r.out.substr(table, end - table));
  std::string line;
  while (std::getline(lines, line)) {
    std::smatch match;
    if (std::regex_search(line, match, row)) names.push_back(match[1]);
  }
  return names;
}

TEST(FitCommand, WritesParametersInTheOrderOfTheModelsTable) {
  const std::vector<std::string> table = parameter_table("stc_sided");
  ASSERT_GE(table.size(), 7u);
  const fs::path entries = test_directory() / "entries.yaml";
  const Result r = run_skidimm("fit --bank " + kSource + "/configs/stc_sided4.yaml --plugin-path " + kPlugins +
                               " --objective window --window 1 --hold-unexcited --log " + kSource +
                               "/configs/examples/stc_switching.csv --output-entry " + entries.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string text = skidimm_test::read_file(entries);
  const std::size_t params = text.find("params: {");
  ASSERT_NE(params, std::string::npos) << text;
  std::vector<std::string> written;
  static const std::regex key(R"(([A-Za-z_]\w*): )");
  const std::string line = text.substr(params + 9, text.find('}', params) - params - 9);
  for (std::sregex_iterator it(line.begin(), line.end(), key), end; it != end; ++it) written.push_back((*it)[1]);
  std::vector<std::string> expected;
  for (const std::string& name : table) {
    if (std::find(written.begin(), written.end(), name) != written.end()) expected.push_back(name);
  }
  ASSERT_EQ(written.size(), 7u) << line;
  EXPECT_EQ(written, expected) << line;
}

// The loop the paper describes, with no compilation: drive a new terrain,
// fit a model from the logs, append it to a bank, identify the terrain.
TEST(Cli, AFittedTerrainAppendedToABankIsIdentifiedWithoutRebuilding) {
  const fs::path dir = test_directory();
  const fs::path bank = dir / "terrains.yaml";
  fs::copy_file(kSource + "/configs/ltc_terrains.yaml", bank);
  std::string logs;
  const std::vector<std::pair<std::string, std::string>> maneuvers = {
      {"skidpad_left", "{type: skidpad, speed: 0.9, radius: 1.5}"},
      {"skidpad_right", "{type: skidpad, speed: 0.9, radius: 1.5, direction: right}"},
      {"sinusoidal", "{type: sinusoidal, speed: 0.7, yaw_rate_amplitude: 0.9, period: 5}"}};
  for (const auto& [name, maneuver] : maneuvers) {
    write_file(dir / (name + ".yaml"), "name: ice_" + name +
                                           "\nduration: 20\nmodes: {ice: {terrain: ice}}\nmode: ice\n" +
                                           "maneuver: " + maneuver + "\nsensors: {rate: 50, jitter: 0.3}\n");
    const Result sim = run_skidimm("simulate -q --scenario " + (dir / (name + ".yaml")).string() + " --output " +
                                   (dir / (name + ".csv")).string() + " --seed 3");
    ASSERT_EQ(sim.exit_code, 0) << sim.err;
    logs += " --log " + (dir / (name + ".csv")).string();
  }
  const Result fit = run_skidimm("fit --bank " + bank.string() + " --mode asphalt --name ice --objective window --window 0.5" + logs +
                                 " --append-to " + bank.string() + " --plugin-path " + kPlugins);
  ASSERT_EQ(fit.exit_code, 0) << fit.err;
  EXPECT_THAT(fit.err, HasSubstr("mode 'ice': 3 log(s)"));
  EXPECT_THAT(fit.err, HasSubstr("appended mode 'ice' to"));
  const std::string text = read_file(bank);
  EXPECT_THAT(text, HasSubstr("# Written by skidimm fit; reproduce with:")) << "the bank's comments are kept";
  EXPECT_THAT(text, HasSubstr("  - name: ice\n    model: ltc_linear\n"));

  // Fresh runs the fit never saw: other speeds, radii and periods, another
  // seed. (Ice shows itself where the tyres approach its friction limit; on a
  // gentle spiral it drives like asphalt, see docs/results.md.)
  const std::vector<std::tuple<std::string, std::string, double>> checks = {
      {"skidpad", "{type: skidpad, speed: 1.0, radius: 1.0}", 0.95},
      {"sinusoidal", "{type: sinusoidal, speed: 0.8, yaw_rate_amplitude: 1.1, period: 4}", 0.75}};
  for (const auto& [name, maneuver, threshold] : checks) {
    write_file(dir / ("fresh_" + name + ".yaml"),
               "name: fresh\nduration: 30\nmodes: {ice: {terrain: ice}}\nmode: ice\n" + std::string("maneuver: ") +
                   maneuver + "\nsensors: {rate: 50, jitter: 0.3}\n");
    ASSERT_EQ(run_skidimm("simulate -q --scenario " + (dir / ("fresh_" + name + ".yaml")).string() + " --output " +
                          (dir / ("fresh_" + name + ".csv")).string() + " --seed 99")
                  .exit_code,
              0);
    const Result run =
        run_skidimm("run -q --bank " + bank.string() + " --input " + (dir / ("fresh_" + name + ".csv")).string() +
                    " --output " + (dir / "out.csv").string() + " --plugin-path " + kPlugins);
    ASSERT_EQ(run.exit_code, 0) << run.err;
    const auto rows = read_csv(dir / "out.csv");
    long ice = 0;
    for (std::size_t i = 1; i < rows.size(); ++i) ice += rows[i][column(rows[0], "mode")] == "ice";
    EXPECT_GT(static_cast<double>(ice) / static_cast<double>(rows.size() - 1), threshold) << name;
  }
}

// A mode whose model has nothing of its own to fit is evaluated on its logs
// (its one-step RMSE and a consistent Q). Where the model fails (its refusal,
// above 0.5 m/s here) those steps used to be left out without a word, and Q
// came from the steps before the first failure. The fit is refused, with the
// count and the first failure in the model's words, as a fit refuses a model
// failing at its starting values; a held-out log it fails on is warned of.
TEST(Cli, AModelWithNothingToFitThatFailsOnItsLogsIsNamed) {
  const fs::path dir = test_directory();
  const auto bank = [&](const std::string& above) {
    return write_file(dir / ("faulty_" + above + ".yaml"), R"(name: faulty
states: [V, omega]
inputs: [phi_dot_L, phi_dot_R]
columns: {time: t, truth_mode: mode}
measurement: {observe: [V, omega], R: {std: [0.05, 0.02]}}
transition: {mean_dwell_time: 10.0}
initial: {covariance: {std: [0.5, 0.5]}}
modes:
  - {name: slippery, model: faulty_model, params: {failure: false, above: )" +
                                                               above +
                                                               R"(}, Q: {diagonal: [0.01, 0.01]}}
)");
  };
  const std::string log = kSource + "/configs/examples/ltc_switching.csv";
  const std::string plugins = " --plugin-path " + kPlugins + " --plugin-path " + kFixturePlugins + "/faulty";
  const fs::path out = dir / "out.yaml";
  const Result refused =
      run_skidimm("fit --bank " + bank("0.5").string() + " --mode slippery --objective window --log " + log +
                  " --output-bank " + out.string() + plugins);
  EXPECT_EQ(refused.exit_code, 1);
  EXPECT_THAT(refused.err, HasSubstr("mode 'slippery' (nothing of its own to fit): the model failed 1440 of its 1486 "
                                     "predictions on these logs (the first: " +
                                     log + ": step 43 (t = 0.853000 s): the slip ratio is undefined at this speed)"));
  EXPECT_FALSE(fs::exists(out));
  // Fitted where it never fails (the first 40 rows), held out where it does.
  const fs::path slow = dir / "slow.csv";
  std::ifstream source(log);
  std::ofstream first_rows(slow);
  std::string line;
  for (int row = 0; row <= 40 && std::getline(source, line); ++row) first_rows << line << "\n";
  first_rows.close();
  const Result held = run_skidimm("fit --bank " + bank("0.5").string() + " --mode slippery --objective window --log " +
                                  slow.string() + " --held-out " + log + " --output-bank " + out.string() + plugins);
  EXPECT_EQ(held.exit_code, 0) << held.err;
  EXPECT_THAT(held.err, Not(HasSubstr("slippery' (nothing of its own")));
  EXPECT_THAT(held.err, HasSubstr("warning: the model failed 1440 of its 1486 predictions on these logs (the first: " +
                                  log + ": step 43"));
  // A model that never fails is evaluated as before, with no warning.
  const Result clean = run_skidimm("fit --bank " + bank("100").string() + " --mode slippery --objective window --log " +
                                   log + " --output-bank " + out.string() + plugins);
  EXPECT_EQ(clean.exit_code, 0) << clean.err;
  EXPECT_THAT(clean.err, Not(HasSubstr("failed")));
  EXPECT_THAT(clean.err,
              HasSubstr("mode 'slippery': 1 log(s): nothing of its own to fit; evaluated at its parameters"));
  EXPECT_THAT(clean.err, Not(HasSubstr("0 iterations"))) << "no solve ran";
  // By likelihood only its noise is fitted: said as such, not as "none derivatives".
  const Result noise =
      run_skidimm("fit --bank " + bank("100").string() + " --mode slippery --objective likelihood --log " + log +
                  " --output-bank " + out.string() + plugins);
  EXPECT_EQ(noise.exit_code, 0) << noise.err;
  EXPECT_THAT(noise.err, HasSubstr(" residuals, no model parameters (noise only), "));
}

TEST(Cli, FitReportsBadLogsAndUnknownModes) {
  const fs::path dir = test_directory();
  const fs::path log = write_file(dir / "log.csv", "t,phi_dot_L,phi_dot_R,V\n0,1,1,0\n");
  const std::string bank = kSource + "/configs/ltc_terrains.yaml";
  const Result missing = run_skidimm("fit --bank " + bank + " --mode asphalt --log " + log.string());
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_THAT(missing.err, HasSubstr("no column 'omega' (the bank's columns.measurements.omega)"));
  const Result unknown = run_skidimm("fit --bank " + bank + " --log mud=" + log.string());
  EXPECT_EQ(unknown.exit_code, 1);
  EXPECT_THAT(unknown.err, HasSubstr("'mud' is neither a mode nor a class of bank 'ltc_terrains'; its modes: asphalt, "
                                     "grass, crushed_concrete"));
  // Without MODE= or --mode, the bank's truth column says which mode: here it is absent.
  const fs::path complete = write_file(dir / "complete.csv", "t,phi_dot_L,phi_dot_R,V,omega\n0,1,1,0,0\n");
  const Result unlabelled = run_skidimm("fit --bank " + bank + " --log " + complete.string());
  EXPECT_EQ(unlabelled.exit_code, 1);
  EXPECT_THAT(unlabelled.err, HasSubstr("say which mode it shows (MODE=FILE) or give --mode; its truth column 'mode' "
                                        "is absent or empty"));
}

TEST(Cli, FitByLikelihoodWritesTheBanksRAndRefusesTheWindowsOptions) {
  const fs::path dir = test_directory();
  const std::string bank = kSource + "/configs/ltc_terrains.yaml";
  const std::string log = kSource + "/configs/examples/ltc_switching.csv";
  const Result window = run_skidimm("fit --bank " + bank + " --window 3 --log " + log);
  EXPECT_EQ(window.exit_code, 2);
  EXPECT_THAT(window.err, HasSubstr("--window is an option of the window objective; add --objective window"));
  const Result append = run_skidimm("fit --bank " + bank + " --fit-r --mode asphalt --append-to " + bank + " --log " + log);
  EXPECT_EQ(append.exit_code, 1);
  EXPECT_THAT(append.err, HasSubstr("--fit-r fits the bank's R, which --append-to cannot change: use --output-bank"));
  // The example log's truth column gives each mode its segments; R is fitted over all of them.
  const fs::path out = dir / "fitted.yaml";
  const Result fit = run_skidimm("fit --bank " + bank + " --fit-r --log " + log + " --output-bank " + out.string() +
                                 " --plugin-path " + kPlugins);
  ASSERT_EQ(fit.exit_code, 0) << fit.err;
  EXPECT_THAT(fit.err, HasSubstr("fitted bank R = "));
  EXPECT_THAT(fit.err, HasSubstr("mean NIS (1 when consistent)"));
  const skidimm::BankConfig fitted = skidimm::load_bank_config(out);
  const skidimm::BankConfig shipped = skidimm::load_bank_config(bank);
  EXPECT_NE(fitted.measurement.r, shipped.measurement.r) << "the fitted R is written";
  EXPECT_THAT(read_file(out), HasSubstr("# innovation RMSE V "));
  const Result run = run_skidimm("eval --bank " + out.string() + " --input " + log + " --plugin-path " + kPlugins);
  ASSERT_EQ(run.exit_code, 0) << run.err;
}

// --parameter-uncertainty: fit writes each fitted mode's parameter
// covariance (parameter_covariance:), run reads it back (its probabilities
// then differ from the same bank's without it), and the likelihood objective
// refuses the option.
TEST(Cli, FitWritesTheParameterCovarianceAndRunReadsIt) {
  const fs::path dir = test_directory();
  write_file(dir / "features.yaml", R"(name: features
states: [f]
inputs: [v]
columns: {truth_mode: mode}
measurement: {observe: [f], R: {std: [0.05]}}
transition: {stay: 0.99}
initial: {covariance: {std: [1]}}
modes:
  - name: slow
    model: linear_features
    params: {A: [-5], B: [[1]], c: [0], fixed: [A]}
    Q: {diagonal: [0.1]}
  - name: fast
    model: linear_features
    params: {A: [-5], B: [[1]], c: [0], fixed: [A]}
    Q: {diagonal: [0.1]}
)");
  // Each mode relaxes f towards its own line in v (slow: 2 v + 1, fast: 4 v),
  // with deterministic wiggles for noise; v sweeps a narrow range.
  std::string log = "t,v,f,mode\n";
  double f = 0.0;
  for (int k = 0; k < 600; ++k) {
    const double t = 0.1 * k, v = 1.0 + 0.3 * std::sin(0.37 * t);
    const bool slow = k < 300;
    log += std::to_string(t) + "," + std::to_string(v) + "," + std::to_string(f + 0.05 * std::sin(7.1 * t)) + "," +
           (slow ? "slow" : "fast") + "\n";
    const double target = slow ? 2.0 * v + 1.0 : 4.0 * v;
    f = std::exp(-0.5) * f + (1.0 - std::exp(-0.5)) * target + 0.1 * std::cos(3.3 * t);
  }
  write_file(dir / "log.csv", log);
  const fs::path out = dir / "fitted.yaml";
  const Result fit = run_skidimm("fit --bank " + (dir / "features.yaml").string() + " --objective window " +
                                 "--parameter-uncertainty --log " + (dir / "log.csv").string() + " --output-bank " +
                                 out.string() + " --plugin-path " + kPlugins);
  ASSERT_EQ(fit.exit_code, 0) << fit.err;
  const std::string text = read_file(out);
  ASSERT_THAT(text, HasSubstr("    parameter_covariance: [\n        ["));
  const skidimm::BankConfig fitted = skidimm::load_bank_config(out);
  for (const skidimm::ModeConfig& mode : fitted.modes) {
    ASSERT_EQ(mode.parameter_covariance.rows(), 2) << mode.name;  // B[0,0] and c[0]
    EXPECT_GT(mode.parameter_covariance(0, 0), 0.0) << mode.name;
    EXPECT_GT(mode.parameter_covariance(1, 1), 0.0) << mode.name;
  }
  // The same bank without the key: every parameter_covariance block removed.
  std::string plain = text;
  for (std::size_t at; (at = plain.find("    parameter_covariance:")) != std::string::npos;) {
    const std::size_t end = plain.find("]]\n", at);
    plain.erase(at, end + 3 - at);
  }
  write_file(dir / "plain.yaml", plain);
  // A drive far outside the fitted speeds.
  std::string far = "t,v,f,mode\n";
  for (int k = 0; k < 100; ++k) far += std::to_string(0.1 * k) + ",5," + std::to_string(20.0 + 0.1 * std::sin(k)) + ",fast\n";
  write_file(dir / "far.csv", far);
  const Result with = run_skidimm("run -q --bank " + out.string() + " --plugin-path " + kPlugins + " --input " +
                                  (dir / "far.csv").string() + " --output " + (dir / "with.csv").string());
  const Result without = run_skidimm("run -q --bank " + (dir / "plain.yaml").string() + " --plugin-path " + kPlugins +
                                     " --input " + (dir / "far.csv").string() + " --output " +
                                     (dir / "without.csv").string());
  ASSERT_EQ(with.exit_code, 0) << with.err;
  ASSERT_EQ(without.exit_code, 0) << without.err;
  EXPECT_NE(read_file(dir / "with.csv"), read_file(dir / "without.csv"));
  const Result likelihood = run_skidimm("fit --bank " + (dir / "features.yaml").string() +
                                        " --parameter-uncertainty --log " + (dir / "log.csv").string());
  EXPECT_EQ(likelihood.exit_code, 2);
  EXPECT_THAT(likelihood.err, HasSubstr("--parameter-uncertainty is an option of the window objective"));
}

// --partial-pooling pools the three terrains fitted together from the
// bundled example (their parameters drawn together, the covariance written)
// and says so where it has nothing to pool (one mode, --mode); without
// --parameter-uncertainty it is a bad command line.
TEST(Cli, FitPoolsTheModesFittedTogetherAndSaysWhenThereIsNothingToPool) {
  const fs::path dir = test_directory();
  const std::string fit = "fit --bank " + kSource + "/configs/ltc_terrains.yaml --plugin-path " + kPlugins +
                          " --objective window --parameter-uncertainty --log " + kSource +
                          "/configs/examples/ltc_switching.csv";
  const Result own = run_skidimm(fit + " --output-bank " + (dir / "own.yaml").string());
  ASSERT_EQ(own.exit_code, 0) << own.err;
  const Result pooled = run_skidimm(fit + " --partial-pooling --output-bank " + (dir / "pooled.yaml").string());
  ASSERT_EQ(pooled.exit_code, 0) << pooled.err;
  EXPECT_THAT(pooled.err + pooled.out, Not(HasSubstr("pooled nothing")));
  const skidimm::BankConfig a = skidimm::load_bank_config(dir / "own.yaml");
  const skidimm::BankConfig b = skidimm::load_bank_config(dir / "pooled.yaml");
  double spread_own = 0.0, spread_pooled = 0.0;
  for (const char* key : {"A", "B"}) {
    for (const auto* config : {&a, &b}) {
      Eigen::MatrixXd mean = Eigen::MatrixXd::Zero(2, 2);
      for (const auto& mode : config->modes) mean += *mode.params.find(key) / 3.0;
      for (const auto& mode : config->modes) {
        (config == &a ? spread_own : spread_pooled) += (*mode.params.find(key) - mean).squaredNorm();
      }
    }
  }
  EXPECT_LT(spread_pooled, spread_own);
  for (const auto& mode : b.modes) EXPECT_GT(mode.parameter_covariance.size(), 0) << mode.name;
  const Result one = run_skidimm(fit + " --partial-pooling --mode grass");
  ASSERT_EQ(one.exit_code, 0) << one.err;
  EXPECT_THAT(one.err + one.out, HasSubstr("partial pooling pooled nothing: it pools the modes of one model and "
                                           "fit_when fitted together, three or more"));
  const Result refused = run_skidimm("fit --bank " + kSource +
                                     "/configs/ltc_terrains.yaml --objective window "
                                     "--partial-pooling --log " +
                                     kSource + "/configs/examples/ltc_switching.csv");
  EXPECT_EQ(refused.exit_code, 2) << refused.err;
  EXPECT_THAT(refused.err, HasSubstr("--parameter-uncertainty"));
}

// --uncertainty-per-log: three logs of one mode, each missed by an offset of
// its own for its whole length. Counted as correlated within each log, the
// parameter covariance is the independent rows' times each channel's design
// effect, here far above 1; the option needs --parameter-uncertainty, for fit
// and tune alike.
TEST(Cli, FitCountsEachLogsRowsAsCorrelatedWhenAsked) {
  const fs::path dir = test_directory();
  write_file(dir / "feature.yaml", R"(name: feature
states: [f]
inputs: [v]
measurement: {observe: [f], R: {std: [0.05]}}
transition: {stay: 0.99}
initial: {covariance: {std: [1]}}
modes:
  - name: only
    model: linear_features
    params: {A: [-5], B: [[1]], c: [0], fixed: [A]}
    Q: {diagonal: [0.1]}
)");
  std::string logs;
  const double offsets[] = {0.4, -0.5, 0.1};
  for (int g = 0; g < 3; ++g) {
    std::string log = "t,v,f\n";
    double f = 0.0;
    for (int k = 0; k < 200; ++k) {
      const double t = 0.1 * k, v = 1.0 + 0.3 * std::sin(0.37 * t + g);
      log += std::to_string(t) + "," + std::to_string(v) + "," + std::to_string(f + 0.05 * std::sin(7.1 * t)) + "\n";
      f = std::exp(-0.5) * f + (1.0 - std::exp(-0.5)) * (2.0 * v + 1.0 + offsets[g]) + 0.1 * std::cos(3.3 * t + g);
    }
    const fs::path file = dir / ("log" + std::to_string(g) + ".csv");
    write_file(file, log);
    logs += " --log only=" + file.string();
  }
  const std::string fit = "fit --bank " + (dir / "feature.yaml").string() + " --objective window" + logs +
                          " --plugin-path " + kPlugins + " --parameter-uncertainty --output-bank ";
  const Result independent = run_skidimm(fit + (dir / "independent.yaml").string());
  ASSERT_EQ(independent.exit_code, 0) << independent.err;
  const Result per_log = run_skidimm(fit + (dir / "per_log.yaml").string() + " --uncertainty-per-log");
  ASSERT_EQ(per_log.exit_code, 0) << per_log.err;
  const Eigen::MatrixXd a = skidimm::load_bank_config(dir / "independent.yaml").modes[0].parameter_covariance;
  const Eigen::MatrixXd b = skidimm::load_bank_config(dir / "per_log.yaml").modes[0].parameter_covariance;
  ASSERT_EQ(a.rows(), 2);
  ASSERT_EQ(b.rows(), 2);
  // One channel: one factor for the whole matrix, the offsets' sums far
  // above the rows' own errors'.
  const double factor = b(1, 1) / a(1, 1);
  EXPECT_GT(factor, 20.0);
  EXPECT_NEAR(b(0, 0), factor * a(0, 0), 1e-6 * b(0, 0));
  EXPECT_NEAR(b(0, 1), factor * a(0, 1), 1e-6 * b(0, 0));
  // The option alone: a usage error, for fit and for tune.
  const Result alone = run_skidimm("fit --bank " + (dir / "feature.yaml").string() + " --objective window" + logs +
                                   " --plugin-path " + kPlugins + " --uncertainty-per-log");
  EXPECT_EQ(alone.exit_code, 2);
  EXPECT_THAT(alone.err, HasSubstr("--uncertainty-per-log requires --parameter-uncertainty"));
  const Result tune_alone = run_skidimm("tune --bank " + (dir / "feature.yaml").string() + " --objective window" +
                                        logs + " --plugin-path " + kPlugins + " --uncertainty-per-log");
  EXPECT_EQ(tune_alone.exit_code, 2);
  EXPECT_THAT(tune_alone.err, HasSubstr("--uncertainty-per-log requires --parameter-uncertainty"));
}

// --residual-correlation: fit estimates each mode's lag-1 correlation of its
// whitened one-step errors and writes it; tune does the same on its folds'
// training logs. Each mode's feature follows its line in v (at the input
// held over the step) plus an AR(1)
// miss (rho 0.8 for one mode, 0.2 for the other) from a generator of the
// test's own; a feature relaxing within a step (A = -60/s, 0.1 s) makes the
// one-step error that miss. The expected rho is the generated misses' own
// lag-1 correlation, computed here.
TEST(Cli, FitAndTuneEstimateEachModesResidualCorrelation) {
  const fs::path dir = test_directory();
  write_file(dir / "features.yaml", R"(name: features
states: [f]
inputs: [v]
columns: {truth_mode: mode}
measurement: {observe: [f], R: {std: [0.001]}}
transition: {stay: 0.99}
initial: {covariance: {std: [1]}}
modes:
  - name: sticky
    model: linear_features
    params: {A: [-60], B: [[1]], c: [0], fixed: [A]}
    Q: {diagonal: [0.1]}
  - name: loose
    model: linear_features
    params: {A: [-60], B: [[1]], c: [0], fixed: [A]}
    Q: {diagonal: [0.1]}
)");
  std::uint64_t state = 12345;
  auto uniform = [&state] {  // a 64-bit LCG (Knuth's MMIX constants), in [-0.5, 0.5)
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    return static_cast<double>(state >> 11) / 9007199254740992.0 - 0.5;
  };
  double expected[2] = {0.0, 0.0};
  std::string logs[2][2];
  for (int mode = 0; mode < 2; ++mode) {
    const double rho = mode == 0 ? 0.8 : 0.2;
    double lag = 0.0, power = 0.0;
    for (int part = 0; part < 2; ++part) {
      std::string log = "t,v,f,mode\n";
      double miss = 0.0, last = 0.0, held = 1.0 + 0.5 * std::sin(part);
      for (int k = 0; k < 400; ++k) {
        const double t = 0.1 * k, v = 1.0 + 0.5 * std::sin(0.37 * t + part);
        miss = rho * miss + std::sqrt(1.0 - rho * rho) * 0.3 * uniform();
        // The line at the input held over the step that led here (the zero-order hold).
        log += std::to_string(t) + "," + std::to_string(v) + "," + std::to_string(2.0 * held + 1.0 + miss) + "," +
               (mode == 0 ? "sticky" : "loose") + "\n";
        held = v;
        if (k >= 2) {  // one-step errors exist from row 1; pairs from row 2
          lag += miss * last;
          power += 0.5 * (miss * miss + last * last);
        }
        last = miss;
      }
      logs[mode][part] = (dir / ("log" + std::to_string(mode) + std::to_string(part) + ".csv")).string();
      write_file(logs[mode][part], log);
    }
    expected[mode] = lag / power;
  }
  ASSERT_GT(expected[0], 0.6);
  ASSERT_LT(expected[1], 0.4);
  const std::string all_logs =
      " --log " + logs[0][0] + " --log " + logs[0][1] + " --log " + logs[1][0] + " --log " + logs[1][1];
  const fs::path out = dir / "fitted.yaml";
  const Result fit =
      run_skidimm("fit --bank " + (dir / "features.yaml").string() + " --objective window --residual-correlation" +
                  all_logs + " --output-bank " + out.string() + " --plugin-path " + kPlugins);
  ASSERT_EQ(fit.exit_code, 0) << fit.err;
  ASSERT_THAT(read_file(out), HasSubstr("    residual_correlation: "));
  const skidimm::BankConfig fitted = skidimm::load_bank_config(out);
  // The fitted line differs a little from the generating one, and the
  // feature relaxes to it within exp(-6) of a step: close, not exact.
  EXPECT_NEAR(fitted.modes[0].residual_correlation, expected[0], 0.03);
  EXPECT_NEAR(fitted.modes[1].residual_correlation, expected[1], 0.03);
  // Without the flag the bank's value (0) stays.
  const Result plain = run_skidimm("fit --bank " + (dir / "features.yaml").string() + " --objective window" + all_logs +
                                   " --output-bank " + (dir / "plain.yaml").string() + " --plugin-path " + kPlugins);
  ASSERT_EQ(plain.exit_code, 0) << plain.err;
  EXPECT_EQ(skidimm::load_bank_config(dir / "plain.yaml").modes[0].residual_correlation, 0.0);

  // tune: each fold fits it; the written bank carries the development fit's.
  const Result tune = run_skidimm("tune --bank " + (dir / "features.yaml").string() +
                                  " --objective window --residual-correlation --tune likelihood-weight --no-assess" +
                                  " --threads 1 --quiet" + all_logs + " --output-bank " +
                                  (dir / "tuned.yaml").string() + " --plugin-path " + kPlugins);
  ASSERT_EQ(tune.exit_code, 0) << tune.err;
  const skidimm::BankConfig tuned = skidimm::load_bank_config(dir / "tuned.yaml");
  EXPECT_NEAR(tuned.modes[0].residual_correlation, fitted.modes[0].residual_correlation, 1e-6);
  EXPECT_NEAR(tuned.modes[1].residual_correlation, fitted.modes[1].residual_correlation, 1e-6);

  // The likelihood objective cannot give it.
  const Result likelihood =
      run_skidimm("fit --bank " + (dir / "features.yaml").string() + " --residual-correlation --log " + logs[0][0]);
  EXPECT_EQ(likelihood.exit_code, 2);
  EXPECT_THAT(likelihood.err, HasSubstr("--residual-correlation is an option of the window objective"));
  const Result tune_likelihood = run_skidimm("tune --bank " + (dir / "features.yaml").string() +
                                             " --objective likelihood --residual-correlation --no-assess" + all_logs +
                                             " --plugin-path " + kPlugins);
  EXPECT_NE(tune_likelihood.exit_code, 0);
  EXPECT_THAT(tune_likelihood.err, HasSubstr("--residual-correlation is estimated by the window objective"));
}

TEST(Cli, FitTakesEachModeFromTheTruthColumnAndEvalTakesLabelsAndPatterns) {
  const fs::path dir = test_directory();
  // One log, three terrains: the truth column splits it into each mode's segments.
  const Result fit = run_skidimm("fit --bank " + kSource + "/configs/physical/ltc_terrains.yaml --objective window --window 0.5 --log " +
                                 kSource + "/configs/examples/ltc_switching.csv --output-bank " +
                                 (dir / "fitted.yaml").string() + " --plugin-path " + kPlugins);
  ASSERT_EQ(fit.exit_code, 0) << fit.err;
  for (const char* mode : {"asphalt", "grass", "crushed_concrete"}) {
    EXPECT_THAT(fit.err, HasSubstr(std::string("mode '") + mode + "': 1 log(s)"));
  }
  EXPECT_THAT(read_file(dir / "fitted.yaml"), ::testing::Not(HasSubstr("not fitted")));
  EXPECT_THAT(fit.err, ::testing::Not(HasSubstr("by a label")));
  // A label overrides the truth column, as documented, but mixing three
  // terrains into one mode is rarely meant: a warning names what it mixed.
  const std::string switching = kSource + "/configs/examples/ltc_switching.csv";
  const Result labelled =
      run_skidimm("fit --bank " + kSource +
                  "/configs/physical/ltc_terrains.yaml --objective "
                  "window --window 0.5 --mode asphalt --log " +
                  switching + " --output-bank " + (dir / "mixed.yaml").string() + " --plugin-path " + kPlugins);
  ASSERT_EQ(labelled.exit_code, 0) << labelled.err;
  EXPECT_THAT(labelled.err, HasSubstr("skidimm fit: warning: " + switching +
                                      ": fitted as mode 'asphalt' by a label (--mode, or MODE=), though its truth "
                                      "column 'mode' names crushed_concrete, grass at some of its steps"));
  // A label the bank does not know is a new terrain's: fitting it from a
  // starting mode (README, step 5) is what --mode is for.
  std::string renamed = read_file(switching);
  for (const char* terrain : {"crushed_concrete", "grass", "asphalt"}) {
    for (std::size_t at = renamed.find(std::string(",") + terrain + ","); at != std::string::npos;
         at = renamed.find(std::string(",") + terrain + ",", at)) {
      renamed.replace(at, std::string(terrain).size() + 2, ",ice,");
    }
  }
  const fs::path ice_log = write_file(dir / "ice.csv", renamed);
  const Result new_terrain =
      run_skidimm("fit --bank " + kSource +
                  "/configs/physical/ltc_terrains.yaml --objective "
                  "window --window 0.5 --mode asphalt --name ice --log " +
                  ice_log.string() + " --output-bank " + (dir / "ice.yaml").string() + " --plugin-path " + kPlugins);
  ASSERT_EQ(new_terrain.exit_code, 0) << new_terrain.err;
  EXPECT_THAT(new_terrain.err, ::testing::Not(HasSubstr("by a label")));

  // Labels and '*' patterns: the same file twice, labelled as the terrain it is not and is.
  fs::create_directories(dir / "runs");
  write_file(dir / "runs" / "a_1.csv", read_file(kSource + "/configs/examples/ltc_switching.csv"));
  write_file(dir / "runs" / "a_2.csv", read_file(kSource + "/configs/examples/ltc_switching.csv"));
  const Result eval = run_skidimm("eval --bank " + kSource + "/configs/ltc_terrains.yaml --input 'grass=" +
                                  (dir / "runs" / "a_*.csv").string() + "' --json --plugin-path " + kPlugins);
  ASSERT_EQ(eval.exit_code, 0) << eval.err;
  EXPECT_THAT(eval.out, HasSubstr("\"grass\": {\"logs\": 2"));
  const Result bad = run_skidimm("eval --bank " + kSource + "/configs/ltc_terrains.yaml --input 'mud=" +
                                 (dir / "runs" / "a_*.csv").string() + "'");
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_THAT(bad.err, HasSubstr("'mud' is neither a mode nor a class of bank 'ltc_terrains'; its modes: asphalt, "
                                 "grass, crushed_concrete\n"));
  // A name in the wrong case is pointed out, with the classes of a bank that has them.
  const Result upper = run_skidimm("eval --bank " + kSource + "/configs/ltc_terrains.yaml --input 'GRASS=" +
                                   (dir / "runs" / "a_*.csv").string() + "'");
  EXPECT_EQ(upper.exit_code, 1);
  EXPECT_THAT(upper.err, HasSubstr("its modes: asphalt, grass, crushed_concrete; names are case-sensitive: 'grass'?"));
  const Result ice = run_skidimm("run --bank " + kSource + "/configs/borealtc/terrains.yaml --input 'ice=" +
                                 (dir / "runs" / "a_1.csv").string() + "' --output " + (dir / "ice.csv").string());
  EXPECT_EQ(ice.exit_code, 1);
  EXPECT_THAT(ice.err, HasSubstr("'ice' is neither a mode nor a class of bank 'borealtc_terrains'; its classes: "
                                 "ASPHALT, FLOORING, ICE, SANDY_LOAM, SNOW; its modes: "));
  EXPECT_THAT(ice.err, HasSubstr("; names are case-sensitive: 'ICE'?"));
  const Result none = run_skidimm("eval --bank " + kSource + "/configs/ltc_terrains.yaml --input '" +
                                  (dir / "runs" / "b_*.csv").string() + "'");
  EXPECT_EQ(none.exit_code, 1);
  EXPECT_THAT(none.err, HasSubstr("no file matches"));
}

// A bank is fitted at --rate when it is given, and its aggregated features
// (BorealTC's means and standard deviations over a step) measure what they
// measure at that rate only: the written bank steps at the rate it was fitted
// at, and a fit that joins a bank stepping at another, or that is written as
// entries alone, says so before or after the work.
TEST(Cli, AFitAtAnotherRateWritesThatRateAsTheBanks) {
  const std::string boreal = std::string(SKIDIMM_SHARED_DATA_DIR) + "/borealtc";
  if (!fs::exists(boreal)) GTEST_SKIP() << "no shared data at " << boreal;
  const fs::path dir = test_directory();
  const std::string start = kSource + "/configs/borealtc/wheels_start.yaml";
  const std::string fit = "fit --bank " + start + " --objective window --hold-unexcited --log 'ASPHALT=" + boreal +
                          "/ASPHALT/pro_00.csv' --log 'ICE=" + boreal + "/ICE/pro_00.csv'";
  const Result at_4 = run_skidimm(fit + " --rate 4 --output-bank " + (dir / "at_4.yaml").string());
  ASSERT_EQ(at_4.exit_code, 0) << at_4.err;
  const std::string written = read_file(dir / "at_4.yaml");
  EXPECT_THAT(written, HasSubstr("\nsampling:\n  rate: 4\nmeasurement:\n"));
  EXPECT_EQ(skidimm::load_bank_config(dir / "at_4.yaml").sampling.rate, 4.0);
  EXPECT_THAT(at_4.err, Not(HasSubstr("should step at that rate")));
  // Modes no log gave a step keep the start's values in the written bank: said.
  EXPECT_THAT(at_4.err, HasSubstr("'SNOW_turning', 'SNOW_straight' have no step in the logs (no log of their class, "
                                  "or none where their fit_when holds): " +
                                  (dir / "at_4.yaml").string() + " keeps their starting values from " + start));
  // At the bank's own rate the template's block stays as it was, comment included.
  const Result at_2 = run_skidimm(fit + " --rate 2 --output-bank " + (dir / "at_2.yaml").string());
  ASSERT_EQ(at_2.exit_code, 0) << at_2.err;
  EXPECT_THAT(read_file(dir / "at_2.yaml"), HasSubstr("sampling:\n  rate: 2                                # Hz:"));
  // The entries alone cannot carry the rate: the fit says what the bank needs.
  const Result entries = run_skidimm(fit + " --rate 4");
  ASSERT_EQ(entries.exit_code, 0) << entries.err;
  EXPECT_THAT(entries.err, HasSubstr("skidimm fit: the entries were fitted on steps every 0.25 s (4 Hz): the bank "
                                     "they join should step at that rate (its sampling.rate: 4)"));
  EXPECT_THAT(entries.err, Not(HasSubstr("no step in the logs"))) << "entries name their modes themselves";
  // Appended to a bank of another rate, the mode is warned of before the fit.
  const fs::path target = write_file(dir / "wheels.yaml", read_file(kSource + "/configs/borealtc/wheels.yaml"));
  const std::string append = "fit --bank " + start + " --objective window --hold-unexcited --mode ASPHALT_straight " +
                             "--log " + boreal + "/ASPHALT/pro_00.csv --append-to " + target.string();
  const Result other = run_skidimm(append + " --rate 4 --name FAST");
  ASSERT_EQ(other.exit_code, 0) << other.err;
  const std::string warning = "skidimm fit: warning: --append-to " + target.string() +
                              " steps every 0.5 s (2 Hz), its sampling.rate, and this fit every 0.25 s (4 Hz): "
                              "columns.measurements.current, ";
  EXPECT_THAT(other.err, HasSubstr(warning));
  EXPECT_LT(other.err.find(warning), other.err.find("residuals"));  // before the fit
  const Result same = run_skidimm(append + " --name SAME");
  ASSERT_EQ(same.exit_code, 0) << same.err;
  EXPECT_THAT(same.err, Not(HasSubstr(" steps every ")));
  // The bank tune wrote carries its tuned scales in every mode; the appended
  // mode's fit carries none: said, with what tune chose. A bank tune did not
  // write is not warned of.
  EXPECT_THAT(same.err, HasSubstr("skidimm fit: warning: --append-to " + target.string() +
                                  ": a bank skidimm tune wrote (chosen: objective window, R x "));
  EXPECT_THAT(same.err, HasSubstr("Tune the bank again with the new mode's logs among the others"));
  // Renaming a mode its class lists by name (--name with --output-bank)
  // would make the written bank invalid: refused before the fit.
  expect_refused_before(kSkidimm + " fit --bank " + start +
                            " --objective window --hold-unexcited --mode "
                            "ASPHALT_straight --log " +
                            boreal + "/ASPHALT/pro_00.csv --name RENAMED --output-bank " +
                            (dir / "renamed.yaml").string(),
                        "--name 'RENAMED': the written bank would rename mode 'ASPHALT_straight' to 'RENAMED', and "
                        "class ASPHALT of ",
                        "residuals");
  EXPECT_FALSE(fs::exists(dir / "renamed.yaml"));
  // A class's modes keep their names: --name with a class is refused, written bank or not.
  expect_refused_before(kSkidimm + " fit --bank " + start +
                            " --objective window --hold-unexcited --mode ASPHALT --log " + boreal +
                            "/ASPHALT/pro_00.csv --name RENAMED",
                        "--name 'RENAMED': the name renames one mode, and 'ASPHALT' is a class of ", "residuals");
  const fs::path untuned = write_file(dir / "untuned.yaml", read_file(kSource + "/configs/borealtc/wheels_start.yaml"));
  const Result plain =
      run_skidimm("fit --bank " + start + " --objective window --hold-unexcited --mode ASPHALT_straight " + "--log " +
                  boreal + "/ASPHALT/pro_00.csv --append-to " + untuned.string() + " --name PLAIN");
  ASSERT_EQ(plain.exit_code, 0) << plain.err;
  EXPECT_THAT(plain.err, Not(HasSubstr("warning: --append-to")));
}

// The window objective's Q search ends at 1000: a state in large units (a
// current in mA) needs more, and its Q stopped there without a word, its
// filter overconfident. The fit says so; in A it does not need to.
TEST(Cli, AProcessNoiseAtTheCeilingOfItsSearchIsSaid) {
  const std::string boreal = std::string(SKIDIMM_SHARED_DATA_DIR) + "/borealtc";
  if (!fs::exists(boreal)) GTEST_SKIP() << "no shared data at " << boreal;
  const fs::path dir = test_directory();
  const std::string amps = read_file(kSource + "/configs/borealtc/wheels_start.yaml");
  std::string milliamps = amps;
  const std::string current = "current: \"mean(curL + curR)\"";
  ASSERT_NE(milliamps.find(current), std::string::npos);
  milliamps.replace(milliamps.find(current), current.size(), "current: \"mean(curL + curR) * 1000\"");
  const std::string fit = " --objective window --hold-unexcited --log 'ASPHALT=" + boreal + "/ASPHALT/pro_00.csv'";
  const Result in_milliamps = run_skidimm("fit --bank " + write_file(dir / "ma.yaml", milliamps).string() + fit);
  ASSERT_EQ(in_milliamps.exit_code, 0) << in_milliamps.err;
  EXPECT_THAT(in_milliamps.err,
              HasSubstr("warning: the process noise of 'current' is at the ceiling of its search, 1000, and its filter "
                        "is still overconfident there (mean NIS above 1)"));
  const Result in_amps = run_skidimm("fit --bank " + kSource + "/configs/borealtc/wheels_start.yaml" + fit);
  ASSERT_EQ(in_amps.exit_code, 0) << in_amps.err;
  EXPECT_THAT(in_amps.err, Not(HasSubstr("ceiling")));
  // Where a mode's errors are above "nothing changes", the report says on
  // which measurements: here the straight mode's current levels.
  EXPECT_THAT(in_amps.err, HasSubstr("worse than no change on current, current_diff: a motion model that does not "
                                     "beat it is not worth having"));
}

// The physical terrain bank with crushed concrete split into a class of two
// modes, `first` (fit_when: `condition`) and `second`, written to `file`.
fs::path bank_with_concrete_split(const fs::path& file, const std::string& first, const std::string& condition,
                                  const std::string& second) {
  std::string bank = read_file(kSource + "/configs/physical/ltc_terrains.yaml");
  const std::string from = "  - name: crushed_concrete\n";
  const auto at = bank.find(from);
  EXPECT_NE(at, std::string::npos);
  const auto end = bank.find("\n  - name:", at + 1);
  const std::string entry = bank.substr(at, end == std::string::npos ? std::string::npos : end - at + 1);
  std::string a = entry, b = entry;
  a.replace(0, from.size(), "  - name: " + first + "\n    fit_when: " + condition + "\n");
  b.replace(0, from.size(), "  - name: " + second + "\n");
  bank.replace(at, entry.size(), a + b);
  bank += "\nclasses:\n  crushed_concrete: [" + first + ", " + second + "]\n";
  return write_file(file, bank);
}

TEST(Cli, AClassLabelTrainsItsModesByTheirFitWhen) {
  const fs::path dir = test_directory();
  // Two modes for crushed concrete, one per turning direction.
  bank_with_concrete_split(dir / "sided.yaml", "concrete_left", "phi_dot_R > phi_dot_L", "concrete_right");
  // A log that turns left for 5 s, then right for 5 s.
  // States from eq. 2 (A = diag(-5, -4)) with varied wheel speeds, and a little deterministic noise.
  std::string log = "t,phi_dot_L,phi_dot_R,V,omega\n";
  double v = 0.0, w = 0.0;
  for (int k = 0; k < 1000; ++k) {
    const double t = 0.02 * k, turn = k < 500 ? 1.0 : -1.0;
    const double l = 4.0 - turn + 1.5 * std::sin(1.3 * t), r = 4.0 + turn + 1.5 * std::cos(0.7 * t);
    log += std::to_string(t) + "," + std::to_string(l) + "," + std::to_string(r) + "," +
           std::to_string(v + 0.01 * std::sin(37.0 * t)) + "," + std::to_string(w + 0.01 * std::cos(41.0 * t)) + "\n";
    const double v_next = v + 0.02 * (-5.0 * v + 0.4 * l + 0.4 * r);
    w += 0.02 * (-4.0 * w - 0.8 * l + 0.8 * r);
    v = v_next;
  }
  write_file(dir / "concrete.csv", log);
  const Result fit = run_skidimm("fit --bank " + (dir / "sided.yaml").string() + " --objective window --window 0.5 --log " +
                                 "crushed_concrete=" + (dir / "concrete.csv").string() + " --plugin-path " + kPlugins);
  EXPECT_EQ(fit.exit_code, 0) << fit.err;
  // Each mode gets the steps of its turning direction (several segments each: dv changes sign in both halves).
  EXPECT_THAT(fit.err, HasSubstr("mode 'concrete_left': 1 log(s) (3 segments), 1054 residuals"));
  EXPECT_THAT(fit.err, HasSubstr("mode 'concrete_right': 1 log(s) (3 segments), 934 residuals"));
  EXPECT_THAT(fit.err, HasSubstr("B[1,1] = 0.79"));
  EXPECT_THAT(fit.out, HasSubstr("- name: concrete_left\n    model: ltc_linear"));
}

// A condition undefined for some inputs (NaN, which compares unequal to 0)
// is an error naming the mode, the log and the time, not a condition that holds.
TEST(Cli, AFitWhenThatIsNotANumberIsAnErrorNotTrue) {
  const fs::path dir = test_directory();
  bank_with_concrete_split(dir / "undefined.yaml", "concrete_a", "\"log(phi_dot_L - 100)\"", "concrete_b");
  const Result fit =
      run_skidimm("fit --bank " + (dir / "undefined.yaml").string() +
                  " --objective window --log crushed_concrete=" + kSwitching + " --plugin-path " + kPlugins);
  EXPECT_EQ(fit.exit_code, 1);
  EXPECT_THAT(fit.err, HasSubstr("ltc_switching.csv"));
  EXPECT_THAT(fit.err, HasSubstr("t = 0 s: fit_when \"log(phi_dot_L - 100)\" of mode 'concrete_a' is not a number"));
}

// Inputs and measurements that never move leave no direction to name: the
// error says the logs carry nothing, not "the combinations ;".
TEST(Cli, AFitOnLogsThatNeverMoveSaysTheyCarryNothing) {
  const fs::path dir = test_directory();
  std::string log = "t,phi_dot_L,phi_dot_R,V,omega\n";
  for (int k = 0; k < 200; ++k) log += std::to_string(0.02 * k) + ",0,0,0,0\n";
  write_file(dir / "still.csv", log);
  for (const std::string hold : {"", " --hold-unexcited"}) {
    const Result fit = run_skidimm("fit --bank " + kTerrains + " --objective window --mode asphalt --log " +
                                   (dir / "still.csv").string() + hold + " --plugin-path " + kPlugins);
    EXPECT_EQ(fit.exit_code, 1) << hold;
    EXPECT_THAT(fit.err, HasSubstr("the logs carry no information on any parameter")) << hold;
    EXPECT_THAT(fit.err, Not(HasSubstr("combinations ;"))) << hold;
  }
}

// A log whose input at row 100 is `value` (1e200 makes every cost infinite).
fs::path corrupt_log(const fs::path& dir, const std::string& value = "1e200") {
  std::ifstream in(kSwitching);
  std::string text, line;
  for (int row = 0; std::getline(in, line) && row < 400; ++row) {
    if (row == 100) line = line.substr(0, line.find(',') + 1) + value + line.substr(line.find(',', line.find(',') + 1));
    text += line + "\n";
  }
  return write_file(dir / "corrupt.csv", text);
}

TEST(CliIo, FittingANonFiniteCostIsAnErrorNamingTheLogAndAppendsNothing) {
  const fs::path dir = test_directory();
  const fs::path bank = dir / "bank.yaml";
  fs::copy_file(kTerrains, bank);
  const std::string before = read_file(bank);
  const fs::path log = corrupt_log(dir);
  for (const std::string objective : {"likelihood", "window"}) {
    const Result fit = run_pipeline(kSkidimm + " fit --bank " + bank.string() + " --plugin-path " + kPlugins +
                                 " --objective " + objective + " --mode asphalt --name ice --log " + log.string() +
                                 " --append-to " + bank.string());
    EXPECT_EQ(fit.exit_code, 1) << objective << ": " << fit.err;
    EXPECT_THAT(fit.err, HasSubstr(log.string())) << objective;
    EXPECT_THAT(fit.err, HasSubstr("not finite")) << objective;
    EXPECT_THAT(fit.err, ::testing::Not(HasSubstr("appended"))) << objective;
    EXPECT_EQ(read_file(bank), before) << objective;
  }
}

// An input of 1e100 keeps every cost finite, but the fit would be that one
// row's: it ended "converged" with a one-step RMSE of 6e79, wrote the bank
// and exited 0 (with --hold-unexcited). The window fit names the window.
TEST(CliIo, FittingWithAFiniteButAbsurdCellIsAnErrorNamingWhereAndAppendsNothing) {
  const fs::path dir = test_directory();
  const fs::path bank = dir / "bank.yaml";
  fs::copy_file(kTerrains, bank);
  const std::string before = read_file(bank);
  const fs::path log = corrupt_log(dir, "1e100");
  for (const std::string extra : {"", " --hold-unexcited"}) {
    const Result fit = run_pipeline(kSkidimm + " fit --bank " + bank.string() + " --plugin-path " + kPlugins +
                                 " --objective window --mode asphalt --name ice --log " + log.string() +
                                 " --append-to " + bank.string() + extra);
    EXPECT_EQ(fit.exit_code, 1) << extra << ": " << fit.err;
    // The window from the corrupt row (data row 100, t = 2.009 s).
    EXPECT_THAT(fit.err, HasSubstr(log.string() + ": the prediction from step 100 (t = 2.009000 s)")) << extra;
    EXPECT_THAT(fit.err, HasSubstr("an absurd input or measurement there")) << extra;
    EXPECT_EQ(read_file(bank), before) << extra;
  }
  // The likelihood fit starts from the window fit where every state is
  // measured, so it names the window too.
  const Result likelihood = run_pipeline(kSkidimm + " fit --bank " + bank.string() + " --plugin-path " + kPlugins +
                                      " --mode asphalt --name ice --log " + log.string() + " --append-to " +
                                      bank.string());
  EXPECT_EQ(likelihood.exit_code, 1) << likelihood.err;
  EXPECT_THAT(likelihood.err, HasSubstr("an absurd input or measurement there"));
  EXPECT_EQ(read_file(bank), before);
  // The same log without the corrupt cell fits: the check does not fire on a clean log.
  const Result clean = run_pipeline(kSkidimm + " fit --bank " + bank.string() + " --plugin-path " + kPlugins +
                                 " --objective window --mode asphalt --log " + corrupt_log(dir, "0.1").string() +
                                 " --output-bank " + (dir / "clean.yaml").string());
  EXPECT_EQ(clean.exit_code, 0) << clean.err;
}

// A --name the written bank would refuse failed only after the fit, and an
// --output-entry was written with it unchecked.
TEST(CliIo, FitChecksTheNameOfTheFittedModeBeforeFitting) {
  const fs::path dir = test_directory();
  const std::string fit = kSkidimm + " fit --bank " + kTerrains + " --plugin-path " + kPlugins +
                          " --objective window --mode asphalt --log asphalt=" + kSwitching;
  expect_refused_before(fit + " --name grass --output-bank " + (dir / "b.yaml").string(),
                        "--name 'grass': the bank (" + kTerrains + ") already has a mode of that name", "residuals");
  expect_refused_before(fit + " --name unknown --output-entry " + (dir / "e.yaml").string(),
                        "--name: 'unknown' is the decision's answer", "residuals");
  const fs::path target = write_file(dir / "target.yaml", read_file(kTerrains));
  expect_refused_before(fit + " --name grass --append-to " + target.string(),
                        "--name 'grass': --append-to " + target.string() + " already has a mode of that name",
                        "residuals");
  EXPECT_FALSE(fs::exists(dir / "e.yaml"));
  EXPECT_EQ(read_file(target), read_file(kTerrains));
  // The fitted mode keeping its own name is no clash.
  EXPECT_EQ(run_pipeline(fit + " --name asphalt --output-bank " + (dir / "b.yaml").string()).exit_code, 0);
  // A --mode the bank lacks is named as --mode's, before any log is read (it was blamed on --log).
  expect_refused_before(kSkidimm + " fit --bank " + kTerrains + " --plugin-path " + kPlugins +
                            " --objective window --mode gravel --log " + kSwitching,
                        "--mode 'gravel': the bank (" + kTerrains +
                            "): 'gravel' is neither a mode nor a class of bank 'ltc_terrains'; its modes: asphalt, "
                            "grass, crushed_concrete",
                        "--log");
  // Without --mode every mode is fitted and --name renamed none, with exit 0.
  const std::string every = kSkidimm + " fit --bank " + kTerrains + " --plugin-path " + kPlugins +
                            " --objective window --log " + kSwitching + " --name gravel --output-entry " +
                            (dir / "every.yaml").string();
  const Result unnamed = run_pipeline(every);
  EXPECT_EQ(unnamed.exit_code, 2) << unnamed.err;
  EXPECT_THAT(unnamed.err, HasSubstr("--name renames the mode of --mode, and every mode is fitted without it"));
  EXPECT_FALSE(fs::exists(dir / "every.yaml"));
}

// The written bank's header repeats the command line: a log whose name holds
// a newline made the rest of the name a line of the bank, here a key that
// loaded (innovation_gate: 0.5). It is written as an escape, in the comment.
TEST(CliIo, AFileNameWithANewlineStaysInTheWrittenBanksComment) {
  const fs::path dir = test_directory();
  const fs::path log = write_file(dir / "inj\ninnovation_gate: 0.5 #.csv", read_file(kSwitching));
  const fs::path out = dir / "out.yaml";
  const Result fit = run_skidimm("fit --bank " + kTerrains + " --plugin-path " + kPlugins +
                                 " --objective window --log '" + log.string() + "' --output-bank " + out.string());
  ASSERT_EQ(fit.exit_code, 0) << fit.err;
  const std::string bank = read_file(out);
  EXPECT_THAT(bank, HasSubstr("--log " + dir.string() + "/inj\\ninnovation_gate: 0.5 #.csv --output-bank"));
  EXPECT_THAT(bank, Not(HasSubstr("\ninnovation_gate")));
  EXPECT_EQ(run_skidimm("validate " + out.string() + " --plugin-path " + kPlugins).exit_code, 0);
}

// A bank written with --parameter-uncertainty (as the bundled BorealTC banks
// are) adds the covariance to each mode's process noise; refitted by the
// default objective, the error named an internal enum ("process noise
// kKeep") as the way out. It names the two a user has.
TEST(CliIo, RefittingABankWithParameterCovarianceByLikelihoodSaysWhatToDo) {
  const fs::path dir = test_directory();
  const fs::path uncertain = dir / "uncertain.yaml";
  const Result first = run_pipeline(kSkidimm + " fit --bank " + kTerrains + " --plugin-path " + kPlugins +
                                    " --objective window --parameter-uncertainty --log " + kSwitching +
                                    " --output-bank " + uncertain.string());
  ASSERT_EQ(first.exit_code, 0) << first.err;
  ASSERT_THAT(read_file(uncertain), HasSubstr("parameter_covariance"));
  const Result again = run_pipeline(kSkidimm + " fit --bank " + uncertain.string() + " --plugin-path " + kPlugins +
                                    " --log " + kSwitching + " --output-bank " + (dir / "again.yaml").string());
  EXPECT_EQ(again.exit_code, 1) << again.err;
  EXPECT_THAT(again.err, HasSubstr("its parameter_covariance (the uncertainty of the fit it came from) is added to its "
                                   "process noise, which the likelihood objective cannot fit Q through; fit it by the "
                                   "window objective"));
  EXPECT_THAT(again.err, Not(HasSubstr("kKeep")));
  const Result window =
      run_pipeline(kSkidimm + " fit --bank " + uncertain.string() + " --plugin-path " + kPlugins +
                   " --objective window --log " + kSwitching + " --output-bank " + (dir / "window.yaml").string());
  EXPECT_EQ(window.exit_code, 0) << window.err;
}

// A window fit whose windows end before their measurements reach the
// corrupt input (the GPS one row in five, one-second windows) fitted without
// it, and then printed a one-step RMSE of inf or 1e97 with Q at a bound, and
// wrote the bank: the one-step evaluation names the prediction instead.
TEST(CliIo, AnAbsurdCellNoWindowReachedIsNamedByTheOneStepEvaluation) {
  const fs::path dir = test_directory();
  const std::string source = read_file(kSource + "/configs/examples/stc_switching.csv");
  std::vector<std::string> lines;
  std::size_t from = 0;
  while (lines.size() < 300) {
    const std::size_t end = source.find('\n', from);
    lines.push_back(source.substr(from, end - from));
    from = end + 1;
  }
  for (const std::string value : {"1e308", "1e100"}) {
    std::string text;
    for (std::size_t i = 0; i < lines.size(); ++i) {
      // Line 50, data row 49: its first input, phi_dot_L.
      text += i == 49 ? lines[i].substr(0, lines[i].find(',')) + "," + value +
                            lines[i].substr(lines[i].find(',', lines[i].find(',') + 1))
                      : lines[i];
      text += "\n";
    }
    const fs::path log = write_file(dir / ("corrupt_" + value + ".csv"), text);
    const fs::path out = dir / ("fitted_" + value + ".yaml");
    const Result fit =
        run_pipeline(kSkidimm + " fit --bank " + kSource + "/configs/stc_slip4.yaml --plugin-path " + kPlugins +
                     " --objective window --window 1 --log " + log.string() + " --output-bank " + out.string());
    EXPECT_EQ(fit.exit_code, 1) << value << ": " << fit.err;
    EXPECT_THAT(fit.err, HasSubstr("the one-step prediction of " + log.string() +
                                   "[0-6.0655 s]: step 52 (t = 1.016500 s, predicted from step 47 with the inputs "
                                   "between) misses 'X' by "))
        << value;
    EXPECT_THAT(fit.err, HasSubstr("an absurd input or measurement there")) << value;
    EXPECT_THAT(fit.err, Not(HasSubstr("RMSE: X inf"))) << value;
    EXPECT_FALSE(fs::exists(out)) << value;
  }
}

// With a state no sensor measures (V here) there is no window fit to start
// from: the likelihood objective itself names the row. A measurement of
// 1e100 used to end in "the logs do not identify every parameter".
TEST(CliIo, TheLikelihoodFitNamesAnAbsurdRowWhenAStateIsUnmeasured) {
  const fs::path dir = test_directory();
  std::string text = read_file(kTerrains);
  const auto replace = [&text](const std::string& from, const std::string& to) {
    const std::size_t at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
  };
  replace("observe: [V, omega]", "observe: [omega]");
  replace("R: {std: [0.05, 0.02]}", "R: {std: [0.02]}");
  const fs::path bank = write_file(dir / "omega_only.yaml", text);
  // Column 5 of the log is omega.
  std::ifstream in(kSwitching);
  std::string log_text, line;
  for (int row = 0; std::getline(in, line) && row < 400; ++row) {
    if (row == 100) {
      std::size_t at = 0;
      for (int comma = 0; comma < 4; ++comma) at = line.find(',', at) + 1;
      line = line.substr(0, at) + "1e100" + line.substr(line.find(',', at));
    }
    log_text += line + "\n";
  }
  const fs::path log = write_file(dir / "absurd_omega.csv", log_text);
  const Result fit = run_pipeline(kSkidimm + " fit --bank " + bank.string() + " --plugin-path " + kPlugins +
                               " --mode asphalt --log " + log.string() + " --output-bank " + (dir / "out.yaml").string());
  EXPECT_EQ(fit.exit_code, 1) << fit.err;
  EXPECT_THAT(fit.err, HasSubstr(log.string() + ": row 100 (t = 2.009 s) has a term of")) << fit.err;
  EXPECT_THAT(fit.err, HasSubstr("an absurd input or measurement there"));
  EXPECT_FALSE(fs::exists(dir / "out.yaml"));
}

// A bank with a state no measurement observes alone: the likelihood fits
// without the window fit it starts from elsewhere, which alone holds what
// the logs do not excite. --hold-unexcited was taken, and the fit failed on
// the parameters it was given to hold; it is refused, naming the state.
TEST(CliIo, FitRefusesHoldUnexcitedWhereNoFitHoldsAnything) {
  const fs::path dir = test_directory();
  const fs::path bank = terrains_measuring_v_only(dir);
  const std::string fit =
      kSkidimm + " fit --bank " + bank.string() + " --plugin-path " + kPlugins + " --mode grass --log " + kSwitching;
  const Result plain = run_pipeline(fit);
  EXPECT_EQ(plain.exit_code, 1) << plain.err;
  EXPECT_THAT(plain.err, HasSubstr("the logs do not identify every parameter"));
  const Result held = run_pipeline(fit + " --hold-unexcited");
  EXPECT_EQ(held.exit_code, 2) << held.err;
  EXPECT_THAT(held.err, HasSubstr("skidimm fit: error: --hold-unexcited would do nothing: the bank does not measure "
                                  "[omega] directly (measurement.observe), so the likelihood objective fits without "
                                  "the one-step window fit"));
  EXPECT_THAT(held.err, HasSubstr("; leave it out"));
  EXPECT_THAT(held.err, Not(HasSubstr("parameters (likelihood objective)"))) << "refused before the work";
  // Where every state is measured, it holds in the window fit the likelihood starts from.
  const Result measured = run_pipeline(kSkidimm + " fit --bank " + kTerrains + " --plugin-path " + kPlugins +
                                       " --mode grass --hold-unexcited --log " + kSwitching);
  EXPECT_EQ(measured.exit_code, 0) << measured.err;
}

// A bank the fitted mode cannot join was found only after the fit, which
// was then lost, and the error named the temporary file the result was
// checked in. The entry of the starting values is checked before the fit:
// per-mode dwell times without one for the new mode, a transition matrix of
// the old size, a floor too high for one more mode, another state size.
TEST(CliIo, FitChecksThatTheAppendedModeCanJoinTheBankBeforeFitting) {
  const fs::path dir = test_directory();
  const std::string fit = kSkidimm + " fit --bank " + kTerrains + " --plugin-path " + kPlugins +
                          " --objective window --mode asphalt --name ice --log " + kSwitching + " --append-to ";
  const std::string terrains = read_file(kTerrains);
  const std::string dwell = "  mean_dwell_time: 10.0     # s; the paper's switching runs hold each terrain 10 s\n";
  ASSERT_NE(terrains.find(dwell), std::string::npos);
  const auto with = [&](const std::string& name, const std::string& from, const std::string& to) {
    std::string text = terrains;
    text.replace(text.find(from), from.size(), to);
    return write_file(dir / name, text);
  };
  struct Case {
    fs::path bank;
    std::string complaint;
  };
  const std::vector<Case> cases = {
      {with("per_mode.yaml", dwell, "  mean_dwell_time: {asphalt: 20, grass: 10, crushed_concrete: 5}\n"),
       ": transition.mean_dwell_time: --append-to cannot take mode 'ice' (nothing was fitted or written): no dwell "
       "time for mode 'ice'; write the entry with --output-entry and add it to the bank by hand"},
      {with("matrix.yaml", dwell, "  matrix: [[0.98, 0.01, 0.01], [0.01, 0.98, 0.01], [0.01, 0.01, 0.98]]\n"),
       ": transition.matrix: --append-to cannot take mode 'ice'"},
      {with("floor.yaml", "transition:\n", "mode_probability_floor: 0.3\ntransition:\n"),
       ": mode_probability_floor: --append-to cannot take mode 'ice'"},
      {fs::path(kSource + "/configs/stc_slip4.yaml"), "--append-to cannot take mode 'ice'"},
  };
  for (const Case& c : cases) {
    const fs::path target = c.bank.parent_path() == dir ? c.bank : write_file(dir / "stc.yaml", read_file(c.bank));
    const std::string before = read_file(target);
    expect_refused_before(fit + target.string(), c.complaint, "residuals");
    EXPECT_EQ(read_file(target), before) << target;
    const Result r = run_pipeline(fit + target.string());
    EXPECT_THAT(r.err, HasSubstr("skidimm fit: error: " + target.string() + ":")) << r.err;
    EXPECT_THAT(r.err, Not(HasSubstr(".tmp"))) << r.err;
  }
  for (const auto& entry_in_dir : fs::directory_iterator(dir)) {
    EXPECT_EQ(entry_in_dir.path().string().find(".tmp"), std::string::npos) << entry_in_dir.path();
  }
  // A block after modes: is named at its own line, not the line it has
  // with the entry inserted before it.
  std::string late = terrains;
  const std::string transition = "transition:\n" + dwell;
  ASSERT_NE(late.find(transition), std::string::npos);
  late.erase(late.find(transition), transition.size());
  late += "transition:\n  mean_dwell_time: {asphalt: 20, grass: 10, crushed_concrete: 5}\n";
  const fs::path moved = write_file(dir / "late.yaml", late);
  const int line = 1 + static_cast<int>(std::count(late.begin(), late.begin() + late.rfind("  mean_dwell_time"), '\n'));
  expect_refused_before(fit + moved.string(),
                        moved.string() + ":" + std::to_string(line) + ": transition.mean_dwell_time: ", "residuals");
  // The fitted mode keeping a name the bank has: said so, with what to do.
  expect_refused_before(kSkidimm + " fit --bank " + kTerrains + " --plugin-path " + kPlugins +
                            " --objective window --mode asphalt --log " + kSwitching + " --append-to " +
                            write_file(dir / "same.yaml", terrains).string(),
                        "mode 'asphalt': --append-to " + (dir / "same.yaml").string() +
                            " already has a mode of that name: give the fitted mode another with --name",
                        "residuals");
  // A file of the name the check might have used is the user's, and stays.
  const fs::path users = write_file(dir / "per_mode.yaml.check", "mine\n");
  expect_refused_before(fit + cases[0].bank.string(), "no dwell time for mode 'ice'", "residuals");
  EXPECT_EQ(read_file(users), "mine\n");
  fs::remove(users);
  for (const auto& entry_in_dir : fs::directory_iterator(dir)) {
    EXPECT_EQ(entry_in_dir.path().string().find(".check"), std::string::npos) << entry_in_dir.path();
  }
  // A bank it can join takes the fitted mode.
  const fs::path plain = write_file(dir / "plain.yaml", terrains);
  const Result appended = run_pipeline(fit + plain.string());
  ASSERT_EQ(appended.exit_code, 0) << appended.err;
  EXPECT_THAT(read_file(plain), HasSubstr("name: ice"));
}

// What the fit is written to or scored on is checked before it starts: a
// mistyped directory, label or --append-to found after a long fit would lose
// it. Each of these fails before the first mode's report.
TEST(CliIo, FitChecksItsOutputsAndHeldOutLogsBeforeFitting) {
  const fs::path dir = test_directory();
  const std::string fit = kSkidimm + " fit --bank " + kTerrains + " --plugin-path " + kPlugins +
                          " --objective window --log " + kSwitching;
  const fs::path missing = dir / "no_such_directory" / "fitted.yaml";
  expect_refused_before(fit + " --output-bank " + missing.string(),
                        "--output-bank " + missing.string() + ": cannot write there: No such file or directory",
                        "residuals");
  expect_refused_before(fit + " --output-entry " + dir.string(), "--output-entry " + dir.string() + ": is a directory",
                        "residuals");
  expect_refused_before(fit + " --held-out mud=" + kSwitching, "'mud' is neither a mode nor a class of bank",
                        "residuals");
  // A file of a --held-out log that is not there is blamed on --held-out, as a label is.
  const std::string missing_part = (dir / "no_such.csv").string();
  expect_refused_before(fit + " --held-out '" + kSwitching + "+" + missing_part + "'",
                        "--held-out '" + kSwitching + "+" + missing_part + "': " + missing_part + ": no such log file",
                        "residuals");
  // One row cannot score a one-step prediction: said so, where its errors
  // used to print as 0.
  const fs::path one_row = one_row_log(dir);
  const Result short_held = run_pipeline(fit + " --held-out asphalt=" + one_row.string());
  EXPECT_EQ(short_held.exit_code, 0) << short_held.err;
  EXPECT_THAT(short_held.err, HasSubstr("held out asphalt=" + one_row.string() +
                                        " (asphalt): 1 row(s), too few to score a one-step prediction (two in a row)"));
  EXPECT_THAT(short_held.err,
              ::testing::Not(HasSubstr("held out asphalt=" + one_row.string() + " (asphalt): one-step")));
  EXPECT_THAT(short_held.err, ::testing::Not(HasSubstr("worse than no change"))) << "the LTC modes beat it";
  // A log (another path to it) as an output: refused, the log kept.
  const fs::path log = write_file(dir / "log.csv", read_file(kSwitching));
  const std::string fit_log = kSkidimm + " fit --bank " + kTerrains + " --plugin-path " + kPlugins +
                              " --objective window --log " + log.string();
  for (const std::string option : {"--output-bank", "--output-entry"}) {
    expect_refused_before(
        fit_log + " " + option + " " + (dir / "." / "log.csv").string(),
        option + " " + (dir / "." / "log.csv").string() + " is the log file " + log.string() + " itself", "residuals");
  }
  expect_refused_before(fit + " --held-out " + log.string() + " --output-bank " + log.string(),
                        "is the log file " + log.string() + " itself", "residuals");
  EXPECT_EQ(read_file(log), read_file(kSwitching));
  // Two outputs of one file, or the entries over the bank they were fitted
  // from: one write would replace the other, or the bank, with a fragment.
  const fs::path bank = write_file(dir / "bank.yaml", read_file(kTerrains));
  const std::string fit_bank = kSkidimm + " fit --bank " + bank.string() + " --plugin-path " + kPlugins +
                               " --objective window --log asphalt=" + kSwitching + " --mode asphalt";
  expect_refused_before(fit_bank + " --output-entry " + (dir / "." / "bank.yaml").string(),
                        "--output-entry " + (dir / "." / "bank.yaml").string() + " is the file of --bank (" +
                            bank.string() + "), which this command reads",
                        "residuals");
  expect_refused_before(fit_bank + " --name ice --append-to " + bank.string() + " --output-entry " + bank.string(),
                        "--append-to and --output-entry name the same file (" + bank.string() + ")", "residuals");
  const fs::path fresh = dir / "fresh.yaml";  // not written yet: the same path all the same
  expect_refused_before(
      fit + " --output-bank " + fresh.string() + " --output-entry " + (dir / "." / "fresh.yaml").string(),
      "--output-bank and --output-entry name the same file", "residuals");
  EXPECT_FALSE(fs::exists(fresh));
  EXPECT_EQ(read_file(bank), read_file(kTerrains));
  // A bank fitted over the one it was read from is an update in place, and allowed.
  const Result in_place = run_pipeline(fit_bank + " --output-bank " + bank.string());
  EXPECT_EQ(in_place.exit_code, 0) << in_place.err;
  EXPECT_NE(read_file(bank), read_file(kTerrains));
  // Three modes in the log, one to append.
  const fs::path target = write_file(dir / "target.yaml", read_file(kTerrains));
  expect_refused_before(fit + " --append-to " + target.string(), "--append-to takes the fit of exactly one mode",
                        "residuals");
  EXPECT_EQ(read_file(target), read_file(kTerrains));
  // The check leaves nothing behind, and a good path still gets the bank.
  const fs::path good = dir / "fitted.yaml";
  const Result written = run_pipeline(fit + " --output-bank " + good.string());
  EXPECT_EQ(written.exit_code, 0) << written.err;
  EXPECT_TRUE(fs::is_regular_file(good));
  for (const auto& entry_in_dir : fs::directory_iterator(dir)) {
    EXPECT_EQ(entry_in_dir.path().string().find(".probe"), std::string::npos) << entry_in_dir.path();
  }
}

TEST(CliIo, FitterErrorsNameTheLogAndTheOptionAndCeresStaysQuiet) {
  const fs::path dir = test_directory();
  // Too short for the window objective: two rows.
  std::ifstream in(kSwitching);
  std::string text, line;
  for (int row = 0; std::getline(in, line) && row < 3; ++row) text += line + "\n";
  const fs::path short_log = write_file(dir / "short.csv", text);
  const Result fit = run_pipeline(kSkidimm + " fit --bank " + kTerrains + " --plugin-path " + kPlugins +
                               " --objective window --mode asphalt --log " + short_log.string());
  EXPECT_EQ(fit.exit_code, 1);
  EXPECT_THAT(fit.err, HasSubstr(short_log.string()));
  // A bad held-out log is blamed on --held-out, not --log.
  const fs::path bad = write_file(dir / "bad.csv", "t,phi_dot_L,phi_dot_R,V\n0,1,1,0\n");
  const Result held = run_pipeline(kSkidimm + " fit --bank " + kTerrains + " --plugin-path " + kPlugins +
                                " --objective window --log " + kSwitching + " --held-out asphalt=" + bad.string());
  EXPECT_EQ(held.exit_code, 1);
  EXPECT_THAT(held.err, HasSubstr("no column 'omega'"));
  EXPECT_THAT(held.err, ::testing::Not(HasSubstr("--log '")));
  const Result held_label = run_pipeline(kSkidimm + " fit --bank " + kTerrains + " --plugin-path " + kPlugins +
                                      " --objective window --log " + kSwitching + " --held-out mud=" +
                                      kSwitching);
  EXPECT_EQ(held_label.exit_code, 1);
  EXPECT_THAT(held_label.err, HasSubstr("--held-out 'mud=" + kSwitching +
                                        "': 'mud' is neither a mode nor a class of bank 'ltc_terrains'"));
  // Ceres' glog warnings are summarised after the error, not printed raw as
  // they come. (A bank measuring only omega, and a left wheel speed of 1e4: wild
  // enough to upset L-BFGS, not so wild that it is caught before Ceres runs,
  // as 1e100 is by the test above.)
  const fs::path absurd = corrupt_log(dir, "1e4");
  std::string omega_only = read_file(kTerrains);
  for (const auto& [from, to] : {std::pair<std::string, std::string>{"observe: [V, omega]", "observe: [omega]"},
                                 {"R: {std: [0.05, 0.02]}", "R: {std: [0.02]}"}}) {
    ASSERT_NE(omega_only.find(from), std::string::npos) << from;
    omega_only.replace(omega_only.find(from), from.size(), to);
  }
  const fs::path omega_bank = write_file(dir / "omega_only.yaml", omega_only);
  const Result quiet = run_pipeline(kSkidimm + " fit --bank " + omega_bank.string() + " --plugin-path " + kPlugins +
                                    " --mode asphalt --log " + absurd.string());
  EXPECT_EQ(quiet.exit_code, 1);
  EXPECT_THAT(quiet.err, HasSubstr("(logs: " + absurd.string() + "): the logs do not identify every parameter"));
  EXPECT_THAT(quiet.err, ::testing::ContainsRegex("skidimm fit: Ceres reported [0-9]+ warning\\(s\\) or error\\(s\\):\n  "
                                                  "[a-z_]+\\.cc:[0-9]+: "));
  EXPECT_THAT(quiet.err, ::testing::Not(::testing::ContainsRegex("(^|\n)[IWEF][0-9]{4} ")));
}

}  // namespace
// A measurement whose expression is not finite at some steps (the log of a
// value at or below 0) is fitted without them, as missing: said, as run
// says it, where the fit's residuals fell short without a word.
TEST(Cli, FitSaysWhichMeasurementValuesWereNotFinite) {
  const fs::path dir = test_directory();
  std::string text = read_file(kTerrains);
  ASSERT_NE(text.find("  truth_mode: mode"), std::string::npos);
  text.replace(text.find("  truth_mode: mode"), 18,
               "  measurements: {V: \"log(V) * 0 + V\", omega: omega}\n  truth_mode: mode");
  const fs::path bank = write_file(dir / "log_v.yaml", text);
  const auto rows = read_csv(kSwitching);
  const std::size_t v = static_cast<std::size_t>(column(rows[0], "V"));
  long not_positive = 0;
  for (std::size_t i = 1; i < rows.size(); ++i) not_positive += std::stod(rows[i][v]) <= 0.0;
  ASSERT_GT(not_positive, 0);
  const Result fit = run_skidimm("fit --bank " + bank.string() + " --plugin-path " + kPlugins +
                                 " --objective window --mode asphalt --log " + kSwitching);
  ASSERT_EQ(fit.exit_code, 0) << fit.err;
  EXPECT_THAT(fit.err, HasSubstr("skidimm fit: " + kSwitching + ": measurement 'V': " + std::to_string(not_positive) +
                                 " value(s) of its expression were not finite (the log of 0, say) and were left out "
                                 "of the fit as missing"));
}

// Stamps in seconds read by a bank whose columns.time_unit is ms make a
// run of minutes one step long: fit says which log gave too few steps to
// learn from (it was counted among the mode's logs without a word), and run
// says the log ended within a step of its start, with the unit's question.
TEST(Cli, ALogInAnotherTimeUnitThanTheBankReadsIsSaidNotFittedOnSilently) {
  const std::string boreal = std::string(SKIDIMM_SHARED_DATA_DIR) + "/borealtc";
  if (!fs::exists(boreal)) GTEST_SKIP() << "no shared data at " << boreal;
  const fs::path dir = test_directory();
  std::string text = read_file(kSource + "/configs/borealtc/wheels_start.yaml");
  ASSERT_NE(text.find("\n  time: time\n"), std::string::npos);
  text.replace(text.find("\n  time: time\n"), 14, "\n  time: time\n  time_unit: ms\n");
  const fs::path bank = write_file(dir / "ms.yaml", text);
  std::vector<std::vector<std::string>> rows = read_csv(boreal + "/ICE/pro_00.csv");
  const auto t = static_cast<std::size_t>(column(rows[0], "time"));
  for (std::size_t i = 1; i < rows.size(); ++i) rows[i][t] = skidimm::CsvWriter::format(std::stod(rows[i][t]) * 1000.0);
  const fs::path in_ms = write_file(dir / "in_ms.csv", csv_text(rows));
  const fs::path in_s = write_file(dir / "in_s.csv", read_file(boreal + "/ICE/pro_02.csv"));
  const Result fit =
      run_skidimm("fit --bank " + bank.string() + " --plugin-path " + kPlugins +
                  " --objective window --hold-unexcited --log ICE=" + in_ms.string() + " --log ICE=" + in_s.string());
  ASSERT_EQ(fit.exit_code, 0) << fit.err;
  EXPECT_THAT(fit.err, HasSubstr("skidimm fit: warning: " + in_s.string() +
                                 ": 1 step(s) in 0 s, under a second: are its time stamps in ms (columns.time_unit)?"));
  EXPECT_THAT(fit.err, Not(HasSubstr(in_ms.string() + ": ")));
  const Result run = run_skidimm("run --bank " + bank.string() + " --plugin-path " + kPlugins + " --input " +
                                 in_s.string() + " --output " + (dir / "out.csv").string());
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_THAT(run.err, HasSubstr("the log spans 0 s in 1 step(s): are its time stamps in ms? (columns.time_unit reads "
                                 "them so; without it, in s)"));
  // A bank that steps at every row (no rate) gets as many steps, in a fraction of a second: said too, by both.
  std::string every_row = read_file(kTerrains);
  every_row.replace(every_row.find("  time: t\n"), 10, "  time: t\n  time_unit: ms\n");
  const fs::path rows_bank = write_file(dir / "rows_ms.yaml", every_row);
  const Result rows_run = run_skidimm("run --bank " + rows_bank.string() + " --plugin-path " + kPlugins + " --input " +
                                      kSwitching + " --output " + (dir / "rows.csv").string());
  ASSERT_EQ(rows_run.exit_code, 0) << rows_run.err;
  EXPECT_THAT(rows_run.err, HasSubstr(" step(s): are its time stamps in ms?"));
  const Result rows_fit = run_skidimm("fit --bank " + rows_bank.string() + " --plugin-path " + kPlugins +
                                      " --objective window --mode asphalt --log " + kSwitching);
  EXPECT_THAT(rows_fit.err, HasSubstr(" s, under a second: are its time stamps in ms (columns.time_unit)?"))
      << rows_fit.err;
  // A run of seconds in seconds: no word of it, however few of its steps a mode is fitted on.
  const Result plain = run_skidimm("fit --bank " + kTerrains + " --plugin-path " + kPlugins +
                                   " --objective window --mode asphalt --log " + kSwitching);
  EXPECT_THAT(plain.err, Not(HasSubstr("time stamps in"))) << plain.err;
}

}  // namespace skidimm_test
