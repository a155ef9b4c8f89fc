// End-to-end: the `skidimm` executable on real files.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "cli/run_skidimm.h"
#include "core/temp_files.h"
#include "skidimm/bank.h"
#include "skidimm/log_io.h"

namespace {

using skidimm_test::column;
using skidimm_test::read_csv;
using skidimm_test::read_file;
using skidimm_test::Result;
using skidimm_test::run_skidimm;
using skidimm_test::test_directory;
using skidimm_test::write_file;
using ::testing::HasSubstr;
namespace fs = std::filesystem;

const std::string kSource = SKIDIMM_SOURCE_DIR;
const std::string kPlugins = SKIDIMM_PLUGIN_DIR;

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
  EXPECT_THAT(r.err, HasSubstr("the decision (enter 0.9, leave 0.05, hold 1 s) changed 3 time(s), the most likely mode 20"));
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
  EXPECT_FALSE(fs::exists(out.string() + ".partial"));
}

// Progress (rate, time left) is for a person at a terminal: a stderr
// captured to a file gets none of it, so what a script logs is the same from
// run to run; on a terminal (a pseudo-terminal from script(1)) run shows how
// far it is, in rows.
TEST(Cli, RunAndFitShowProgressOnlyOnATerminal) {
  const fs::path dir = test_directory();
  const std::string bank = kSource + "/configs/ltc_terrains.yaml";
  const std::string log = kSource + "/configs/examples/ltc_switching.csv";  // 1487 rows: one update, at row 1024
  const std::string run = "run --bank " + bank + " --input " + log + " --output " + (dir / "out.csv").string() +
                          " --plugin-path " + kPlugins;
  const Result captured = run_skidimm(run);
  ASSERT_EQ(captured.exit_code, 0) << captured.err;
  EXPECT_THAT(captured.err, HasSubstr("skidimm run: bank 'ltc_terrains'"));  // the summary stays
  EXPECT_EQ(captured.err.find('\r'), std::string::npos);
  EXPECT_THAT(captured.err, ::testing::Not(HasSubstr("rows/s")));
  const Result fit = run_skidimm("fit --bank " + bank + " --log " + log + " --output-bank " +
                                 (dir / "fitted.yaml").string() + " --plugin-path " + kPlugins);
  ASSERT_EQ(fit.exit_code, 0) << fit.err;
  EXPECT_EQ(fit.err.find('\r'), std::string::npos);
  EXPECT_THAT(fit.err, ::testing::Not(HasSubstr("iterations/s")));

  if (std::system("script --version > /dev/null 2>&1") != 0) GTEST_SKIP() << "no script(1) for a pseudo-terminal";
  const fs::path transcript = dir / "terminal.txt";
  const std::string command = "script -qec '" + std::string(SKIDIMM_EXECUTABLE) + " " + run + "' /dev/null > " +
                              transcript.string() + " 2>&1 < /dev/null";
  ASSERT_EQ(std::system(command.c_str()), 0) << read_file(transcript);
  const std::string terminal = read_file(transcript);
  EXPECT_THAT(terminal, HasSubstr("\rskidimm run: "));
  // The rate and time left join after a second (format_rate_and_time_left,
  // tested on its own): this run is faster, so the line ends at the rows.
  EXPECT_THAT(terminal, HasSubstr("%  1024 rows\x1b[K"));
  EXPECT_THAT(terminal, HasSubstr("\r\x1b[Kskidimm run: bank 'ltc_terrains'"))
      << "the line is cleared before the summary";
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

TEST(Cli, BadRowMidLogKeepsTheRowsAlreadyComputed) {
  const fs::path dir = test_directory();
  std::string log = read_file(kSource + "/configs/examples/ltc_switching.csv");
  // Corrupt the 101st data row's wheel speed.
  std::size_t at = 0;
  for (int line = 0; line < 102; ++line) at = log.find('\n', at) + 1;
  log.replace(log.find(',', at) + 1, 1, "x");
  const fs::path input = write_file(dir / "corrupt.csv", log);
  const Result r = run_skidimm("run --bank " + kSource + "/configs/ltc_terrains.yaml --input " + input.string() +
                               " --output " + (dir / "out.csv").string() + " --plugin-path " + kPlugins);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("corrupt.csv:103: column 2 ('phi_dot_L'): expected a finite number"));
  EXPECT_THAT(r.err, HasSubstr("the 101 rows computed before the error are in"));
  EXPECT_FALSE(fs::exists(dir / "out.csv")) << "an incomplete file must not carry the final name";
  EXPECT_EQ(read_csv(dir / "out.csv.partial").size(), 102u);
}

TEST(Cli, MissingColumnNamesTheBankField) {
  const fs::path dir = test_directory();
  const fs::path input = write_file(dir / "log.csv", "t,phi_dot_L,phi_dot_R,V\n0,1,1,0\n");
  const Result r = run_skidimm("run --bank " + kSource + "/configs/ltc_terrains.yaml --input " + input.string() +
                               " --output " + (dir / "out.csv").string() + " --plugin-path " + kPlugins);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("no column 'omega' (the bank's columns.measurements.omega)"));
}

TEST(Cli, ValidateReportsTheBankAndItsModes) {
  const Result ok = run_skidimm("validate " + kSource + "/configs/stc_slip4.yaml --plugin-path " + kPlugins);
  EXPECT_EQ(ok.exit_code, 0) << ok.err;
  EXPECT_THAT(ok.out, HasSubstr("stc_slip4.yaml: OK"));
  EXPECT_THAT(ok.out, HasSubstr("angles [theta]"));
  EXPECT_THAT(ok.out, HasSubstr("slip_FR_RR"));
  const Result missing = run_skidimm("validate /nonexistent.yaml");
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_THAT(missing.err, HasSubstr("/nonexistent.yaml: no such bank file"));
}

TEST(Cli, PluginsListsTheBundledPluginsWithMetadata) {
  const Result r = run_skidimm("plugins");  // found next to the executable, no --plugin-path
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("ltc_linear 1.0.0"));
  EXPECT_THAT(r.out, HasSubstr("ltc_shared 1.0.0"));
  EXPECT_THAT(r.out, HasSubstr("stc_kinematic 1.0.0"));
  EXPECT_THAT(r.out, HasSubstr("k (scalar): longitudinal efficiency"));
}

const std::string kFixturePlugins = SKIDIMM_TEST_PLUGIN_ROOT;

// ltc_terrains' asphalt and a mode whose plugin fails as `failure` says above 0.5 m/s.
fs::path faulty_bank(const fs::path& dir, const std::string& failure) {
  return write_file(dir / "faulty.yaml", R"(
name: faulty
states: [V, omega]
inputs: [phi_dot_L, phi_dot_R]
columns: {time: t, truth_mode: mode}
measurement:
  observe: [V, omega]
  R: {std: [0.05, 0.02]}
transition: {mean_dwell_time: 10.0}
initial:
  covariance: {std: [0.5, 0.5]}
modes:
  - name: asphalt
    model: ltc_linear
    params: {A: [[-36.28555, 0.935196], [0.5454627, -29.78963]], B: [[3.164964, 2.846713], [-4.866783, 4.78034]]}
    Q: [[0.00556329, 0], [0, 0.003817253]]
  - name: slippery
    model: faulty_model
    params: {failure: )" + failure + R"(, above: 0.5}
    Q: {diagonal: [0.01, 0.01]}
)");
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

TEST(Cli, ValidateNamesEachModesPluginFileAndVersion) {
  const Result r = run_skidimm("validate " + kSource + "/configs/stc_slip4.yaml --plugin-path " + kPlugins);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("  plugins:\n    no_slip: plugin stc_kinematic 1.0.0 (" + kPlugins +
                               "/skidimm_stc_kinematic.so)"));
}

TEST(Cli, PluginsShowsStatesInputsAnglesAndFlagsDuplicates) {
  const Result r = run_skidimm("plugins --plugin-path " + kFixturePlugins + "/duplicates");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("duplicate_a.so\n    DUPLICATE: " + kFixturePlugins +
                               "/duplicates/duplicate_b.so in the same directory is also named 'duplicate_model'"));
  EXPECT_THAT(r.out, HasSubstr("DUPLICATE: " + kFixturePlugins + "/duplicates/duplicate_a.so"));
  EXPECT_THAT(r.out, HasSubstr("    states:\n      X: position in the world frame (m)\n"));
  EXPECT_THAT(r.out, HasSubstr("      theta (angle, wrapped to [-pi, pi)): heading (rad)\n"));
  EXPECT_THAT(r.out, HasSubstr("    inputs:\n      phi_dot_L: left wheel speed (rad/s)\n"));
  EXPECT_THAT(r.out, HasSubstr("    states: the bank's own (not declared by the plugin)"));  // linear_features
}

// A wrong analytic Jacobian does not stop a run, it only makes it worse:
// `validate --check` finds it at operating points of a real log (the Husky
// ice log), naming the entry, the point and both values, and passes the
// bundled bank fitted to that log.
TEST(Cli, ValidateCheckFindsAWrongJacobianAtOperatingPointsOfARealLog) {
  const std::string ice = std::string(SKIDIMM_SHARED_DATA_DIR) + "/husky_ice";
  if (!fs::exists(ice)) GTEST_SKIP() << "no shared data at " << ice;
  const std::string log = ice + "/TSyn_01.csv+" + ice + "/joint_states_01.csv";
  const std::string bundled = kSource + "/configs/husky/ice_ltc.yaml";
  const Result ok = run_skidimm("validate " + bundled + " --plugin-path " + kPlugins + " --check " + log);
  ASSERT_EQ(ok.exit_code, 0) << ok.err << ok.out;
  EXPECT_THAT(ok.out, HasSubstr("  model checks (the conformance kit's) at 20 operating points of 1 log(s):\n"
                                "    ice: ok\n"));

  // The bundled bank with its model replaced by one whose d V' / d omega has the wrong sign.
  std::string yaml = read_file(bundled);
  const std::size_t model = yaml.find("    model: ltc_linear\n");
  ASSERT_NE(model, std::string::npos);
  const std::size_t params_end = yaml.find('\n', yaml.find("    params:", model));
  yaml.replace(model, params_end - model, "    model: wrong_jacobian\n    params: {k: 8, c: 0.5}");
  yaml.replace(yaml.find("modes:\n"), 7, "shared: {r: 0.165, b: 0.555}\nmodes:\n");
  const fs::path dir = test_directory();
  const fs::path bank = write_file(dir / "wrong_jacobian.yaml", yaml);
  const std::string plugins = " --plugin-path " + kPlugins + " --plugin-path " + kFixturePlugins + "/wrong_jacobian";
  const Result wrong = run_skidimm("validate " + bank.string() + plugins + " --check " + log);
  EXPECT_EQ(wrong.exit_code, 1) << wrong.out;
  EXPECT_THAT(wrong.out, HasSubstr("    ice: FAILED at "));
  EXPECT_THAT(wrong.out, HasSubstr(" of 20 points; first at " + log + " step "));
  EXPECT_THAT(wrong.out, HasSubstr("jacobian() differs from central differences by "));
  EXPECT_THAT(wrong.out, HasSubstr(" at x = ["));
  EXPECT_THAT(wrong.err, HasSubstr("a mode's model fails the checks"));
  // The named entry is the wrong one, and its analytic value is the numeric one negated.
  const std::string entry = "entry (row 0 'V', column 1 'omega'): analytic ";
  const std::size_t at = wrong.out.find(entry);
  ASSERT_NE(at, std::string::npos) << wrong.out;
  std::istringstream values(wrong.out.substr(at + entry.size()));
  double analytic = 0.0, numeric = 0.0;
  std::string comma, word;
  values >> analytic >> comma >> word >> numeric;
  EXPECT_EQ(comma + " " + word, ", numeric");
  EXPECT_NE(analytic, 0.0);
  EXPECT_NEAR(analytic, -numeric, 1e-6 * std::abs(numeric));

  // The same model runs: the check is what finds it.
  const Result ran = run_skidimm("run -q --bank " + bank.string() + plugins + " --input " + log + " --output " +
                                 (dir / "out.csv").string());
  EXPECT_EQ(ran.exit_code, 0) << ran.err;
}

TEST(Cli, PluginsAndValidateRefuseAPluginOfAnotherStandardLibraryWithoutCrashing) {
  const std::string dir = kFixturePlugins + "/old_string_abi";
  const Result listed = run_skidimm("plugins --plugin-path " + dir);
  ASSERT_EQ(listed.exit_code, 0) << listed.err;
  EXPECT_THAT(listed.out, HasSubstr("duplicate_model  UNUSABLE  " + dir +
                                    "/old_string_abi_plugin.so\n"
                                    "    built with another C++ standard library configuration"));
  const fs::path bank = write_file(test_directory() / "bank.yaml", R"(
name: stale
states: [x]
inputs: []
measurement: {observe: [x], R: {std: [1]}}
transition: {mean_dwell_time: 1.0}
initial: {covariance: {std: [1]}}
modes:
  - {name: only, model: duplicate_model, Q: {diagonal: [1]}}
)");
  const Result validated =
      run_skidimm("validate " + bank.string() + " --plugin-path " + kFixturePlugins + "/debug_stdlib");
  EXPECT_EQ(validated.exit_code, 1) << validated.out;
  EXPECT_THAT(validated.err, HasSubstr("_GLIBCXX_DEBUG=1"));
  EXPECT_THAT(validated.err, HasSubstr("debug_stdlib_plugin.so is unusable"));
}

TEST(Cli, NewPluginWritesAProjectAndRefusesBadNames) {
  const fs::path dir = test_directory();
  const Result bad = run_skidimm("new-plugin 9Lives --dir " + dir.string());
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_THAT(bad.err, HasSubstr("'9Lives' is not a plugin name: use lowercase letters, digits and '_'"));
  EXPECT_TRUE(fs::is_empty(dir));
  const Result ok = run_skidimm("new-plugin wet_grass --dir " + dir.string());
  ASSERT_EQ(ok.exit_code, 0) << ok.err;
  EXPECT_THAT(read_file(dir / "wet_grass" / "wet_grass_plugin.cc"),
              HasSubstr("SKIDIMM_EXPORT_FUNCTION_MODEL(WetGrass)"));
  EXPECT_THAT(read_file(dir / "wet_grass" / "wet_grass_test.cc"),
              HasSubstr("TEST(WetGrass, ConformsOverItsOperatingRegion"));
  const std::string cmake = read_file(dir / "wet_grass" / "CMakeLists.txt");
  EXPECT_THAT(cmake, HasSubstr("find_package(skidimm 0.1 REQUIRED COMPONENTS sdk)"));
  EXPECT_THAT(cmake, HasSubstr("skidimm_add_motion_model(wet_grass wet_grass_plugin.cc INSTALL)"));
  EXPECT_THAT(read_file(dir / "wet_grass" / "wet_grass_bank.yaml"), HasSubstr("model: wet_grass"));
  EXPECT_EQ(run_skidimm("new-plugin wet_grass --dir " + dir.string()).exit_code, 1);  // exists
}

TEST(Cli, UsageErrorsExitWithTwoAndHelpWithZero) {
  // `skidimm` alone is a newcomer asking what it does: the usage, not an error.
  const Result alone = run_skidimm("");
  EXPECT_EQ(alone.exit_code, 0);
  EXPECT_THAT(alone.out, HasSubstr("Usage: skidimm [OPTIONS] SUBCOMMAND"));
  EXPECT_THAT(alone.out, HasSubstr("Subcommands:"));
  EXPECT_EQ(run_skidimm("--frobnicate").exit_code, 2) << "an option, but no command";
  EXPECT_EQ(run_skidimm("run --bank").exit_code, 2);
  EXPECT_EQ(run_skidimm("frobnicate").exit_code, 2);
  const Result missing_path = run_skidimm("plugins --plugin-path /no/such/dir");
  EXPECT_EQ(missing_path.exit_code, 2);
  EXPECT_THAT(missing_path.err, HasSubstr("/no/such/dir"));
  const Result help = run_skidimm("run --help");
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_THAT(help.out, HasSubstr("--plugin-path"));
  // Every command's help ends with examples and where to read more.
  for (const char* command :
       {"run", "bag", "validate", "simulate", "fit", "tune", "eval", "plot", "plugins", "new-plugin"}) {
    const Result h = run_skidimm(std::string(command) + " --help");
    EXPECT_EQ(h.exit_code, 0) << command;
    EXPECT_THAT(h.out, ::testing::ContainsRegex("\nExamples:\n  skidimm " + std::string(command) + "[ \n]"))
        << command;
    EXPECT_THAT(h.out.substr(h.out.rfind("\n", h.out.size() - 2) + 1),
                ::testing::StartsWith("More: docs/cli.md#skidimm-" + std::string(command)))
        << command;
  }
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

TEST(Cli, FitReportsBadLogsAndUnknownModes) {
  const fs::path dir = test_directory();
  const fs::path log = write_file(dir / "log.csv", "t,phi_dot_L,phi_dot_R,V\n0,1,1,0\n");
  const std::string bank = kSource + "/configs/ltc_terrains.yaml";
  const Result missing = run_skidimm("fit --bank " + bank + " --mode asphalt --log " + log.string());
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_THAT(missing.err, HasSubstr("no column 'omega' (the bank's columns.measurements.omega)"));
  const Result unknown = run_skidimm("fit --bank " + bank + " --log mud=" + log.string());
  EXPECT_EQ(unknown.exit_code, 1);
  EXPECT_THAT(unknown.err, HasSubstr("the bank has no mode or class 'mud'"));
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

TEST(Cli, EvalReportsAccuracyLatencyAndConsistencyAsTextAndJson) {
  const std::string args = "eval --bank " + kSource + "/configs/ltc_terrains.yaml --input " + kSource +
                           "/configs/examples/ltc_switching.csv --plugin-path " + kPlugins;
  const Result text = run_skidimm(args);
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_THAT(text.out, HasSubstr("accuracy (time fraction)"));
  EXPECT_THAT(text.out, HasSubstr("10.01 s  crushed_concrete -> grass: first"));
  EXPECT_THAT(text.out, HasSubstr("state RMSE vs true_<state>: V"));
  EXPECT_THAT(text.out, HasSubstr("consistency of the true mode's filter"));
  const Result json = run_skidimm(args + " --json");
  ASSERT_EQ(json.exit_code, 0) << json.err;
  EXPECT_EQ(json.out.rfind("{\"overall\": {\"logs\": 1,", 0), 0u) << json.out.substr(0, 80);
  EXPECT_THAT(json.out, HasSubstr("\"switches\": [{\"time\": 10.0055, \"from\": \"crushed_concrete\""));
  // The same metrics from the `run` output alone (no NIS, no state truth).
  const fs::path out = test_directory() / "out.csv";
  ASSERT_EQ(run_skidimm("run -q --bank " + kSource + "/configs/ltc_terrains.yaml --input " + kSource +
                        "/configs/examples/ltc_switching.csv --output " + out.string() + " --plugin-path " + kPlugins)
                .exit_code,
            0);
  const Result from_output = run_skidimm("eval --estimates " + out.string());
  ASSERT_EQ(from_output.exit_code, 0) << from_output.err;
  const auto accuracy_line = [](const std::string& s) { return s.substr(s.find("accuracy"), 40); };
  EXPECT_EQ(accuracy_line(from_output.out), accuracy_line(text.out));
  const Result no_truth = run_skidimm("eval --bank " + kSource + "/configs/husky/ice_ltc.yaml --input x.csv");
  EXPECT_EQ(no_truth.exit_code, 1);
  EXPECT_THAT(no_truth.err, HasSubstr("names no columns.truth_mode"));
}

TEST(Cli, EvalTakesDecisionSettingsAndRemakesARunsDecisionFromItsProbabilities) {
  const fs::path dir = test_directory();
  const std::string bank = kSource + "/configs/ltc_terrains.yaml",
                    log = kSource + "/configs/examples/ltc_switching.csv";
  const std::string settings = " --decision-enter 0.6 --decision-hold 0.2";
  ASSERT_EQ(run_skidimm("run -q --bank " + bank + " --input " + log + " --output " + (dir / "given.csv").string() +
                        settings + " --plugin-path " + kPlugins)
                .exit_code,
            0);
  ASSERT_EQ(run_skidimm("run -q --bank " + bank + " --input " + log + " --output " + (dir / "default.csv").string() +
                        " --plugin-path " + kPlugins)
                .exit_code,
            0);
  // The decision's JSON scores, from "accuracy" to "lost".
  const auto decision_of = [](const Result& r) {
    EXPECT_EQ(r.exit_code, 0) << r.err;
    const std::size_t begin = r.out.find("\"decision\": {\"accuracy\"");
    const std::size_t end = r.out.find("\"lost\"", begin);
    return begin == std::string::npos || end == std::string::npos ? std::string() : r.out.substr(begin, end - begin);
  };
  const std::string written = decision_of(run_skidimm("eval --json --estimates " + (dir / "given.csv").string()));
  ASSERT_FALSE(written.empty());
  EXPECT_EQ(decision_of(run_skidimm("eval --json --bank " + bank + " --input " + log + settings + " --plugin-path " +
                                    kPlugins)),
            written)
      << "eval runs the bank with the settings run was given";
  EXPECT_EQ(decision_of(run_skidimm("eval --json --estimates " + (dir / "default.csv").string() + settings)), written)
      << "the decision made again from the probabilities of a run with the bank's own settings";
  EXPECT_NE(decision_of(run_skidimm("eval --json --estimates " + (dir / "default.csv").string())), written)
      << "the settings change the decision on this log";
  // The table says how the decision it scores was made.
  EXPECT_THAT(run_skidimm("eval --bank " + bank + " --input " + log + settings + " --plugin-path " + kPlugins).out,
              HasSubstr("decision (enter 0.6, leave 0.05, hold 0.2 s): accuracy"));
  EXPECT_THAT(run_skidimm("eval --estimates " + (dir / "default.csv").string() + settings).out,
              HasSubstr("decision (made again: enter 0.6, leave 0.05, hold 0.2 s): accuracy"));
  EXPECT_THAT(run_skidimm("eval --estimates " + (dir / "default.csv").string()).out,
              HasSubstr("decision (the files' decision column): accuracy"));
  const Result bad =
      run_skidimm("eval --estimates " + (dir / "default.csv").string() + " --decision-enter 0.05 --decision-leave 0.1");
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_THAT(bad.err, HasSubstr("need 0 <= leave < enter <= 1, got enter 0.05, leave 0.1"));
}

TEST(Cli, PlotDrawsPngAndSvgAndSaysWhenGnuplotIsMissing) {
  const fs::path dir = test_directory();
  const std::string log = kSource + "/configs/examples/stc_switching.csv";
  ASSERT_EQ(
      run_skidimm("run -q --bank " + kSource + "/configs/stc_slip4.yaml --input " + log + " --output " +
                  (dir / "out.csv").string() + " --plugin-path " + kPlugins + " --plot " + (dir / "run.png").string())
          .exit_code,
      0);
  const Result svg = run_skidimm("plot --estimates " + (dir / "out.csv").string() + " --log " + log +
                                 " --states --output " + (dir / "states.svg").string());
  ASSERT_EQ(svg.exit_code, 0) << svg.err;
  const std::string png = read_file(dir / "run.png");
  ASSERT_GT(png.size(), 10000u);
  EXPECT_EQ(png.substr(1, 3), "PNG");
  const std::string drawing = read_file(dir / "states.svg");
  EXPECT_THAT(drawing, HasSubstr("<svg"));
  EXPECT_THAT(drawing, HasSubstr("slip_FR_RR"));
  EXPECT_THAT(drawing, HasSubstr("theta"));
  // The decision track: a row per mode and one for `unknown`, under the probabilities.
  EXPECT_THAT(drawing, HasSubstr(">decision<"));
  EXPECT_THAT(drawing, HasSubstr(">unknown<"));
  EXPECT_FALSE(fs::exists(dir / "states.svg.gnuplot")) << "the script is removed after a successful plot";
  // Without gnuplot on PATH: a clear error, not a crash.
  const std::string command = "env PATH=/nonexistent " + std::string(SKIDIMM_EXECUTABLE) + " plot --estimates " +
                              (dir / "out.csv").string() + " --output " + (dir / "x.png").string() + " 2>" +
                              (dir / "err").string();
  const int status = std::system(command.c_str());
  EXPECT_EQ(WEXITSTATUS(status), 1);
  EXPECT_THAT(read_file(dir / "err"), HasSubstr("gnuplot is not installed or not on PATH"));
  EXPECT_EQ(run_skidimm("plot --estimates " + (dir / "out.csv").string() + " --output x.pdf").exit_code, 1);
}

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


namespace multi_rate {

// A log in two files at two rates: inputs and V at 10 Hz, omega at 50 Hz,
// split from the bundled example (V and omega come from its rows).
struct SplitLog {
  fs::path slow, fast;
  long fast_rows = 0;
};
SplitLog split_example(const fs::path& dir) {
  const auto rows = read_csv(kSource + "/configs/examples/ltc_switching.csv");
  const auto& h = rows[0];
  std::string slow = "t,phi_dot_L,phi_dot_R,V,mode\n", fast = "t,omega\n";
  SplitLog log;
  for (std::size_t i = 1; i < rows.size(); ++i) {
    const auto& r = rows[i];
    fast += r[column(h, "t")] + "," + r[column(h, "omega")] + "\n";
    ++log.fast_rows;
    if (i % 5 == 1) {
      slow += r[column(h, "t")] + "," + r[column(h, "phi_dot_L")] + "," + r[column(h, "phi_dot_R")] + "," +
              r[column(h, "V")] + "," + r[column(h, "mode")] + "\n";
    }
  }
  log.slow = write_file(dir / "slow.csv", slow);
  log.fast = write_file(dir / "fast.csv", fast);
  return log;
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
  EXPECT_THAT(bad.err, HasSubstr("'mud' is neither a mode nor a class of bank 'ltc_terrains'"));
  const Result none = run_skidimm("eval --bank " + kSource + "/configs/ltc_terrains.yaml --input '" +
                                  (dir / "runs" / "b_*.csv").string() + "'");
  EXPECT_EQ(none.exit_code, 1);
  EXPECT_THAT(none.err, HasSubstr("no file matches"));
}

// On real runs the plain IMM (likelihood weight 1) counts the same evidence
// many times: nine features averaged over overlapping windows, whose errors
// move together. `tune --tune likelihood-weight` leaves the weight at 1
// unless a smaller one scores the held-out runs better, so a weight below 1
// in the written bank is that finding, on runs the fit never saw.
TEST(Cli, TuneTempersTheEvidenceOfABankThatOvercountsItOnRealRuns) {
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

TEST(Cli, ClassesScoreSeveralModesAsOne) {
  const fs::path dir = test_directory();
  std::string bank = read_file(kSource + "/configs/ltc_terrains.yaml");
  bank += "classes:\n  soft: [grass, crushed_concrete]\n";
  write_file(dir / "classes.yaml", bank);
  const Result eval = run_skidimm("eval --bank " + (dir / "classes.yaml").string() + " --input " + kSource +
                                  "/configs/examples/ltc_switching.csv --plugin-path " + kPlugins);
  ASSERT_EQ(eval.exit_code, 0) << eval.err;
  EXPECT_THAT(eval.out, HasSubstr("soft asphalt"));  // the confusion's columns: classes
  // Grass taken for crushed concrete is now right: the class accuracy is at least the mode accuracy.
  const std::string key = "accuracy (time fraction)";
  ASSERT_NE(eval.out.find(key), std::string::npos);
  EXPECT_GE(std::stod(eval.out.substr(eval.out.find(key) + key.size())), 0.976);
}

TEST(Cli, AClassLabelTrainsItsModesByTheirFitWhen) {
  const fs::path dir = test_directory();
  std::string bank = read_file(kSource + "/configs/physical/ltc_terrains.yaml");
  // Two modes for crushed concrete, one per turning direction.
  const std::string from = "  - name: crushed_concrete\n";
  const auto at = bank.find(from);
  ASSERT_NE(at, std::string::npos);
  const std::string entry = bank.substr(at, bank.find("\n  - name:", at + 1) == std::string::npos
                                                ? std::string::npos
                                                : bank.find("\n  - name:", at + 1) - at + 1);
  std::string left = entry, right = entry;
  left.replace(0, from.size(), "  - name: concrete_left\n    fit_when: phi_dot_R > phi_dot_L\n");
  right.replace(0, from.size(), "  - name: concrete_right\n");
  bank.replace(at, entry.size(), left + right);
  bank += "\nclasses:\n  crushed_concrete: [concrete_left, concrete_right]\n";
  write_file(dir / "sided.yaml", bank);
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

}  // namespace multi_rate

namespace plugin_files {

// A plugin file cut short (a copy in progress, a full disk): today's loader
// mapped it and died of SIGBUS (exit 135) even when only listing plugins.
TEST(Cli, PluginsAndValidateRefuseATruncatedPluginFileWithoutCrashing) {
  const fs::path dir = test_directory();
  const std::string whole = read_file(kPlugins + "/skidimm_ltc_linear.so");
  write_file(dir / "ltc_linear.so", whole.substr(0, whole.size() / 2));
  const Result listed = run_skidimm("plugins --plugin-path " + dir.string());
  ASSERT_EQ(listed.exit_code, 0) << listed.err;
  EXPECT_THAT(listed.out, HasSubstr("?  UNUSABLE  " + (dir / "ltc_linear.so").string() + "\n    cannot load: " +
                                    (dir / "ltc_linear.so").string() + ": truncated: its ELF segment"));
  EXPECT_THAT(listed.out, HasSubstr("replace plugin files with mv or install, not cp"));

  // A bank whose plugin's only file is truncated: refused, the file named.
  const std::string slip = read_file(kFixturePlugins + "/slip_ratio/slip_ratio_plugin.so");
  fs::create_directories(dir / "slip");
  // The first 16 KiB: the ELF and program headers, not the segments. (Two
  // thirds of the file cut only debug information in a sanitizer build.)
  ASSERT_GT(slip.size(), 65536u);
  write_file(dir / "slip" / "slip_ratio.so", slip.substr(0, 16384));
  const fs::path bank = write_file(dir / "bank.yaml", R"(
name: truncated
states: [V, omega, s]
inputs: [phi_dot_L, phi_dot_R]
measurement: {observe: [V, omega], R: {std: [0.1, 0.1]}}
transition: {mean_dwell_time: 1.0}
initial: {covariance: {std: [1, 1, 1]}}
shared: {r: 0.165, b: 0.555}
modes:
  - {name: only, model: slip_ratio, params: {s_ss: 0.1, m: 0.8, tau: 0.05, tau_s: 0.5}, Q: {diagonal: [1, 1, 1]}}
)");
  const Result validated = run_skidimm("validate " + bank.string() + " --plugin-path " + (dir / "slip").string());
  EXPECT_EQ(validated.exit_code, 1) << validated.out << validated.err;
  EXPECT_THAT(validated.err, HasSubstr("no plugin named 'slip_ratio'"));
  EXPECT_THAT(validated.err, HasSubstr("skipped " + (dir / "slip" / "slip_ratio.so").string() + ": cannot load: "));
  EXPECT_THAT(validated.err, HasSubstr("truncated: its ELF segment"));
}

}  // namespace plugin_files

// ------------------------------------------------------------- reliability: pipes, writes, bad cells, fitter errors
namespace io_reliability {

const std::string kTerrains = kSource + "/configs/ltc_terrains.yaml";
const std::string kSwitching = kSource + "/configs/examples/ltc_switching.csv";

// A shell command line (bash: <(...), pipefail), its stdout and stderr captured.
Result run_shell(const std::string& script) {
  // Beside the test's directory (test_directory() would empty it).
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const fs::path dir = fs::path(::testing::TempDir()) / ("skidimm_cli_shell_" + std::string(info->name()));
  fs::create_directories(dir);
  write_file(dir / "script.sh", "set -o pipefail\n" + script + "\n");
  const std::string command = "bash " + (dir / "script.sh").string() + " > " + (dir / "out").string() + " 2> " +
                              (dir / "err").string() + " < /dev/null";
  const int status = std::system(command.c_str());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, read_file(dir / "out"), read_file(dir / "err")};
}

const std::string kSkidimm = SKIDIMM_EXECUTABLE;

std::string run_arguments(const std::string& input, const std::string& output) {
  return kSkidimm + " run -q --bank " + kTerrains + " --plugin-path " + kPlugins + " --input " + input +
         " --output " + output;
}

TEST(CliIo, RunReadsLogsFromStandardInputPipesAndFifos) {
  const fs::path dir = test_directory();
  const fs::path reference = dir / "reference.csv";
  ASSERT_EQ(run_shell(run_arguments(kSwitching, reference.string())).exit_code, 0);
  const std::string expected = read_file(reference);
  ASSERT_GT(expected.size(), 1000u);
  struct Case {
    std::string name, script;
  };
  const fs::path out = dir / "out.csv";
  const std::vector<Case> cases = {
      {"--input -", "cat " + kSwitching + " | " + run_arguments("-", out.string())},
      {"/dev/stdin", "cat " + kSwitching + " | " + run_arguments("/dev/stdin", out.string())},
      {"<(...)", run_arguments("<(cat " + kSwitching + ")", out.string())},
      {"FIFO", "mkfifo " + (dir / "fifo").string() + " && { cat " + kSwitching + " > " + (dir / "fifo").string() +
                   " & } && " + run_arguments((dir / "fifo").string(), out.string())},
      {"--output -", "cat " + kSwitching + " | " + run_arguments("-", "-") + " > " + out.string()},
  };
  for (const Case& c : cases) {
    fs::remove(out);
    const Result r = run_shell(c.script);
    EXPECT_EQ(r.exit_code, 0) << c.name << ": " << r.err;
    EXPECT_EQ(read_file(out), expected) << c.name;
    EXPECT_FALSE(fs::exists(out.string() + ".partial")) << c.name;
  }
  // Standard input twice in one log cannot be.
  const Result twice = run_shell("cat " + kSwitching + " | " + run_arguments("- --input -", out.string()));
  EXPECT_EQ(twice.exit_code, 1);
  EXPECT_THAT(twice.err, HasSubstr("standard input ('-') can be one file of a log, not several"));
}

TEST(CliIo, CommandsThatReadALogTwiceRefuseAPipeAndSaySo) {
  const fs::path dir = test_directory();
  const Result tune = run_shell("cat " + kSwitching + " | " + kSkidimm + " tune --bank " + kTerrains +
                                " --plugin-path " + kPlugins + " --log - --log " + kSwitching);
  EXPECT_EQ(tune.exit_code, 1);
  EXPECT_THAT(tune.err, HasSubstr("-: standard input can be read only once (standard input, a pipe or a FIFO), but tune "
                                  "reads each log more than once: save it to a file first"));
  const Result plot = run_shell("cat " + kSwitching + " | " + run_arguments("-", (dir / "out.csv").string()) +
                                " --plot " + (dir / "figure.png").string());
  EXPECT_EQ(plot.exit_code, 2);
  EXPECT_THAT(plot.err, HasSubstr("--plot reads the estimates and the log again after the run, which --input -"));
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

TEST(CliIo, WritesOntoAFullDiskFailWithTheReasonAndLeaveNoFile) {
  const fs::path dir = test_directory();
  // A file-size limit of 0 (with SIGXFSZ ignored) makes every write to a
  // regular file fail, as a full disk does; stderr goes through a pipe.
  const std::string limited = "trap '' XFSZ; ulimit -f 0; ";
  const fs::path entry = dir / "entry.yaml";
  const Result fit = run_shell("(" + limited + kSkidimm + " fit --bank " + kTerrains + " --plugin-path " + kPlugins +
                               " --objective window --log " + kSwitching + " --output-entry " + entry.string() +
                               ") 2>&1 | cat >&2");
  EXPECT_EQ(fit.exit_code, 1) << fit.err;
  EXPECT_THAT(fit.err, HasSubstr(entry.string() + ".partial: cannot write: File too large"));
  EXPECT_FALSE(fs::exists(entry));
  EXPECT_FALSE(fs::exists(entry.string() + ".partial"));
  const fs::path out = dir / "out.csv";
  const Result run = run_shell("(" + limited + run_arguments(kSwitching, out.string()) + ") 2>&1 | cat >&2");
  EXPECT_EQ(run.exit_code, 1) << run.err;
  EXPECT_THAT(run.err, HasSubstr(out.string() + ".partial: cannot write: File too large"));
  EXPECT_FALSE(fs::exists(out));
  EXPECT_FALSE(fs::exists(out.string() + ".partial"));
  // A device is written in place, never replaced by a renamed file.
  const Result full = run_shell(kSkidimm + " fit --bank " + kTerrains + " --plugin-path " + kPlugins +
                                " --objective window --log " + kSwitching + " --output-entry /dev/full");
  EXPECT_EQ(full.exit_code, 1);
  EXPECT_THAT(full.err, HasSubstr("/dev/full: cannot write: No space left on device"));
  const Result run_full = run_shell(run_arguments(kSwitching, "/dev/full"));
  EXPECT_EQ(run_full.exit_code, 1);
  EXPECT_THAT(run_full.err, HasSubstr("/dev/full: cannot write: No space left on device"));
  const Result run_null = run_shell(run_arguments(kSwitching, "/dev/null"));
  EXPECT_EQ(run_null.exit_code, 0) << run_null.err;
  EXPECT_TRUE(fs::is_character_file("/dev/null"));
  EXPECT_TRUE(fs::is_character_file("/dev/full"));
  EXPECT_FALSE(fs::exists("/dev/null.partial"));
  const Result to_pipe = run_shell(run_arguments(kSwitching, "/dev/stdout") + " | cat > /dev/null");
  EXPECT_EQ(to_pipe.exit_code, 0) << "CSV to a pipe: " << to_pipe.err;
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
    const Result fit = run_shell(kSkidimm + " fit --bank " + bank.string() + " --plugin-path " + kPlugins +
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
    const Result fit = run_shell(kSkidimm + " fit --bank " + bank.string() + " --plugin-path " + kPlugins +
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
  const Result likelihood = run_shell(kSkidimm + " fit --bank " + bank.string() + " --plugin-path " + kPlugins +
                                      " --mode asphalt --name ice --log " + log.string() + " --append-to " +
                                      bank.string());
  EXPECT_EQ(likelihood.exit_code, 1) << likelihood.err;
  EXPECT_THAT(likelihood.err, HasSubstr("an absurd input or measurement there"));
  EXPECT_EQ(read_file(bank), before);
  // The same log without the corrupt cell fits: the check does not fire on a clean log.
  const Result clean = run_shell(kSkidimm + " fit --bank " + bank.string() + " --plugin-path " + kPlugins +
                                 " --objective window --mode asphalt --log " + corrupt_log(dir, "0.1").string() +
                                 " --output-bank " + (dir / "clean.yaml").string());
  EXPECT_EQ(clean.exit_code, 0) << clean.err;
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
  const Result fit = run_shell(kSkidimm + " fit --bank " + bank.string() + " --plugin-path " + kPlugins +
                               " --mode asphalt --log " + log.string() + " --output-bank " + (dir / "out.yaml").string());
  EXPECT_EQ(fit.exit_code, 1) << fit.err;
  EXPECT_THAT(fit.err, HasSubstr(log.string() + ": row 100 (t = 2.009 s) has a term of")) << fit.err;
  EXPECT_THAT(fit.err, HasSubstr("an absurd input or measurement there"));
  EXPECT_FALSE(fs::exists(dir / "out.yaml"));
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
  ASSERT_EQ(run_shell(run_arguments(kSwitching, (dir / "plain.csv").string())).exit_code, 0);
  ASSERT_EQ(run_shell(run_arguments(kSwitching, (dir / "one.csv").string()) + " --likelihood-weight 1").exit_code, 0);
  EXPECT_EQ(read_file(dir / "one.csv"), read_file(dir / "plain.csv"));
  const Result tempered =
      run_shell(run_arguments(kSwitching, (dir / "tempered.csv").string()) + " --likelihood-weight 0.05");
  ASSERT_EQ(tempered.exit_code, 0) << tempered.err;
  EXPECT_LT(mean_largest_probability(dir / "tempered.csv"), mean_largest_probability(dir / "plain.csv") - 0.05);
  for (const std::string bad : {"0", "1.5", "-0.2", "nan", "abc"}) {
    const Result refused =
        run_shell(run_arguments(kSwitching, (dir / "bad.csv").string()) + " --likelihood-weight " + bad);
    EXPECT_EQ(refused.exit_code, 2) << bad;
    EXPECT_THAT(refused.err, HasSubstr("--likelihood-weight")) << bad;
    EXPECT_FALSE(fs::exists(dir / "bad.csv")) << bad;
  }
}

// gnuplot's line colours repeat after 8: in a bank of more modes, each mode
// still gets a colour (or, past 20, a dash pattern) of its own.
TEST(CliIo, PlotGivesEachOfManyModesItsOwnLine) {
  const fs::path dir = test_directory();
  std::string text = "t";
  for (int j = 0; j < 22; ++j) text += ",mu_m" + std::to_string(j);
  text += "\n";
  for (int k = 0; k < 5; ++k) {
    text += std::to_string(0.5 * k);
    for (int j = 0; j < 22; ++j) text += "," + std::to_string((j + k) % 22 == 0 ? 0.79 : 0.01);
    text += "\n";
  }
  const fs::path estimates = write_file(dir / "many.csv", text);
  const fs::path figure = dir / "many.svg";
  const Result plot = run_skidimm("plot --estimates " + estimates.string() + " --output " + figure.string());
  ASSERT_EQ(plot.exit_code, 0) << plot.err;
  const std::string svg = read_file(figure);
  // Modes 9 and 10 in the 12 colours after gnuplot's 8 (#8c564b, #e377c2),
  // not in the 1st and 2nd modes' dark violet and green again.
  EXPECT_THAT(svg, HasSubstr("rgb(140,  86,  75)"));
  EXPECT_THAT(svg, HasSubstr("rgb(227, 119, 194)"));
  EXPECT_THAT(svg, HasSubstr("rgb(158, 218, 229)"));  // the 20th, #9edae5
  // The 21st mode: the 1st mode's colour, dashed (the 1st is solid).
  EXPECT_THAT(svg, HasSubstr("stroke='rgb(148,   0, 211)' stroke-dasharray"));
}

// plot reads the estimates twice (here, then gnuplot): from a pipe they are
// copied first. Text from the file reaches gnuplot printable, and names
// reach it without a shell.
TEST(CliIo, PlotReadsAPipeAndGivesGnuplotNoRawTextFromTheFiles) {
  const fs::path dir = test_directory();
  const fs::path piped = dir / "piped.png";
  const Result pipe = run_shell(run_arguments(kSwitching, "-") + " | " + kSkidimm + " plot --estimates - --output " +
                                piped.string());
  ASSERT_EQ(pipe.exit_code, 0) << pipe.err;
  EXPECT_EQ(read_file(piped).substr(1, 3), "PNG");
  for (const auto& entry : fs::directory_iterator(dir)) {
    EXPECT_EQ(entry.path(), piped) << "left behind: " << entry.path();
  }

  const fs::path estimates = dir / "estimates.csv";
  ASSERT_EQ(run_shell(run_arguments(kSwitching, estimates.string())).exit_code, 0);
  auto rows = read_csv(estimates);
  // A mode name with a line break (a quoted CSV header cell) used to end
  // gnuplot's string mid-script; an apostrophe in the figure's name broke the
  // shell command line.
  rows[0][1] = "mu_asphalt\nset output 'elsewhere.png'";
  std::string text;
  for (const auto& row : rows) {
    for (std::size_t c = 0; c < row.size(); ++c) {
      const bool quote = row[c].find_first_of(",\n'") != std::string::npos;
      text += (c ? "," : "") + (quote ? "\"" + row[c] + "\"" : row[c]);
    }
    text += "\n";
  }
  const fs::path odd = write_file(dir / "odd.csv", text);
  const fs::path figure = dir / "it's a figure.png";
  const Result plot = run_skidimm("plot --estimates " + odd.string() + " --output \"" + figure.string() + "\"");
  EXPECT_EQ(plot.exit_code, 0) << plot.err;
  EXPECT_EQ(read_file(figure).substr(1, 3), "PNG");
  EXPECT_FALSE(fs::exists(dir / "elsewhere.png"));

  // A time cell that is not a number: the file, line, column and the cell.
  rows = read_csv(estimates);
  rows[3][0] = "2.5s";
  text.clear();
  for (const auto& row : rows) {
    for (std::size_t c = 0; c < row.size(); ++c) text += (c ? "," : "") + row[c];
    text += "\n";
  }
  const fs::path bad = write_file(dir / "bad.csv", text);
  const Result located = run_skidimm("plot --estimates " + bad.string() + " --output " + (dir / "bad.png").string());
  EXPECT_EQ(located.exit_code, 1);
  EXPECT_THAT(located.err, HasSubstr(bad.string() + ":4: column 1 ('t'): expected the time, a finite number, got '2.5s'"));
  EXPECT_FALSE(fs::exists(dir / "bad.png"));
  EXPECT_FALSE(fs::exists(dir / "bad.png.gnuplot"));
}

TEST(CliIo, BadCellsNameTheFileLineColumnAndWhatWasExpected) {
  const fs::path dir = test_directory();
  // A true_<state> cell that is not a number, in the log eval runs over.
  std::ifstream in(kSwitching);
  std::string text, line;
  for (int row = 0; std::getline(in, line) && row < 50; ++row) {
    if (row == 20) {  // column 12, true_V
      std::size_t at = 0;
      for (int comma = 0; comma < 11; ++comma) at = line.find(',', at) + 1;
      line = line.substr(0, at) + "fast" + line.substr(line.find(',', at));
    }
    text += line + "\n";
  }
  const fs::path bad_truth = write_file(dir / "bad_truth.csv", text);
  const Result truth = run_shell(kSkidimm + " eval --bank " + kTerrains + " --plugin-path " + kPlugins + " --input " +
                                 bad_truth.string());
  EXPECT_EQ(truth.exit_code, 1);
  EXPECT_THAT(truth.err, HasSubstr(bad_truth.string() + ":21: column 12 ('true_V'): expected a finite number"));
  EXPECT_THAT(truth.err, HasSubstr("got 'fast'"));
  // A subnormal cell is a number: the nearest double, as strtod reads it.
  text.replace(text.find("fast"), 4, "1e-320");
  write_file(bad_truth, text);
  const Result subnormal = run_shell(kSkidimm + " eval --bank " + kTerrains + " --plugin-path " + kPlugins +
                                     " --input " + bad_truth.string());
  EXPECT_EQ(subnormal.exit_code, 0) << subnormal.err;

  // eval --estimates: the output of run, then broken in each way.
  const fs::path estimates = dir / "estimates.csv";
  ASSERT_EQ(run_shell(run_arguments(kSwitching, estimates.string())).exit_code, 0);
  std::vector<std::string> lines;
  {
    std::ifstream e(estimates);
    while (std::getline(e, line)) lines.push_back(line);
  }
  auto with_row = [&](std::size_t index, const std::string& replacement) {
    std::string out;
    for (std::size_t i = 0; i < lines.size() && i < 40; ++i) out += (i == index ? replacement : lines[i]) + "\n";
    return write_file(dir / "broken.csv", out);
  };
  auto cells = [&](std::size_t index) {
    std::vector<std::string> c;
    std::stringstream row(lines[index]);
    std::string cell;
    while (std::getline(row, cell, ',')) c.push_back(cell);
    if (!lines[index].empty() && lines[index].back() == ',') c.push_back("");  // an empty last cell (reason)
    return c;
  };
  auto join = [](const std::vector<std::string>& c) {
    std::string out;
    for (const std::string& x : c) out += (out.empty() ? "" : ",") + x;
    return out;
  };
  struct Case {
    std::string name;
    std::vector<std::string> row;
    std::string expected;
  };
  std::vector<Case> cases;
  std::vector<std::string> c = cells(10);
  c[0] = "soon";
  cases.push_back({"bad t", c, ":11: column 1 ('t'): expected a finite time in seconds, got 'soon'"});
  c = cells(10);
  c[1] = "x";
  cases.push_back({"bad mu", c, ":11: column 2 ('mu_asphalt'): expected a probability in [0, 1], got 'x'"});
  c = cells(10);
  c[1] = "7";
  cases.push_back({"mu = 7", c, ":11: column 2 ('mu_asphalt'): expected a probability in [0, 1], got 7"});
  c = cells(10);
  c[1] = "0.5";
  c[2] = "0.5";
  c[3] = "0.5";
  cases.push_back({"sum 1.5", c, ":11: the mode probabilities (mu_ columns) sum to 1.5"});
  c = cells(10);
  c[0] = cells(5)[0];
  cases.push_back({"time backwards", c, ":11: column 1 ('t'): time must increase strictly, but "});
  for (const Case& k : cases) {
    const fs::path broken = with_row(10, join(k.row));
    const Result r = run_shell(kSkidimm + " eval --estimates " + broken.string());
    EXPECT_EQ(r.exit_code, 1) << k.name;
    EXPECT_THAT(r.err, HasSubstr(broken.string() + k.expected)) << k.name;
    EXPECT_THAT(r.err, ::testing::Not(HasSubstr("unexpected error"))) << k.name;
  }
  const fs::path header_only = write_file(dir / "header_only.csv", lines[0] + "\n");
  const Result empty = run_shell(kSkidimm + " eval --estimates " + header_only.string());
  EXPECT_EQ(empty.exit_code, 1);
  EXPECT_THAT(empty.err, HasSubstr(header_only.string() + ":1: the file has a header but no rows"));
}

TEST(CliIo, FitterErrorsNameTheLogAndTheOptionAndCeresStaysQuiet) {
  const fs::path dir = test_directory();
  // Too short for the window objective: two rows.
  std::ifstream in(kSwitching);
  std::string text, line;
  for (int row = 0; std::getline(in, line) && row < 3; ++row) text += line + "\n";
  const fs::path short_log = write_file(dir / "short.csv", text);
  const Result fit = run_shell(kSkidimm + " fit --bank " + kTerrains + " --plugin-path " + kPlugins +
                               " --objective window --mode asphalt --log " + short_log.string());
  EXPECT_EQ(fit.exit_code, 1);
  EXPECT_THAT(fit.err, HasSubstr(short_log.string()));
  // A bad held-out log is blamed on --held-out, not --log.
  const fs::path bad = write_file(dir / "bad.csv", "t,phi_dot_L,phi_dot_R,V\n0,1,1,0\n");
  const Result held = run_shell(kSkidimm + " fit --bank " + kTerrains + " --plugin-path " + kPlugins +
                                " --objective window --log " + kSwitching + " --held-out asphalt=" + bad.string());
  EXPECT_EQ(held.exit_code, 1);
  EXPECT_THAT(held.err, HasSubstr("no column 'omega'"));
  EXPECT_THAT(held.err, ::testing::Not(HasSubstr("--log '")));
  const Result held_label = run_shell(kSkidimm + " fit --bank " + kTerrains + " --plugin-path " + kPlugins +
                                      " --objective window --log " + kSwitching + " --held-out mud=" +
                                      kSwitching);
  EXPECT_EQ(held_label.exit_code, 1);
  EXPECT_THAT(held_label.err, HasSubstr("--held-out 'mud=" + kSwitching + "': the bank has no mode or class 'mud'"));
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
  const Result quiet = run_shell(kSkidimm + " fit --bank " + omega_bank.string() + " --plugin-path " + kPlugins +
                                 " --hold-unexcited --mode asphalt --log " + absurd.string());
  EXPECT_EQ(quiet.exit_code, 1);
  EXPECT_THAT(quiet.err, HasSubstr("(logs: " + absurd.string() + "): the logs do not identify every parameter"));
  EXPECT_THAT(quiet.err, ::testing::ContainsRegex("skidimm fit: Ceres reported [0-9]+ warning\\(s\\) or error\\(s\\):\n  "
                                                  "[a-z_]+\\.cc:[0-9]+: "));
  EXPECT_THAT(quiet.err, ::testing::Not(::testing::ContainsRegex("(^|\n)[IWEF][0-9]{4} ")));
}

}  // namespace io_reliability

}  // namespace

namespace {

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

}  // namespace

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

TEST(Cli, ValidateRefusesAQOf1e300) {
  const fs::path dir = test_directory();
  std::string bank = read_file(kSource + "/configs/ltc_terrains.yaml");
  const std::size_t q = bank.find("Q:");
  ASSERT_NE(q, std::string::npos);
  bank.replace(q, bank.find('\n', q) - q, "Q: [[1e300, 0], [0, 1e300]]");
  const fs::path file = write_file(dir / "huge_q.yaml", bank);
  const Result r = run_skidimm("validate " + file.string() + " --plugin-path " + kPlugins);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("huge_q.yaml:"));
  EXPECT_THAT(r.err, HasSubstr(".Q (mode '"));
  EXPECT_THAT(r.err, HasSubstr("entry (0, 0) = 1e+300 is larger in magnitude than 1e+15"));
}
