// `skidimm validate`: a bank's modes, their plugins and versions, the
// conformance checks at a real log's operating points (--check), and noise
// matrices out of range.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>

#include "cli/cli_test_support.h"

namespace skidimm_test {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
namespace fs = std::filesystem;

TEST(Cli, ValidateReportsTheBankAndItsModes) {
  const Result ok = run_skidimm("validate " + kSource + "/configs/stc_slip4.yaml --plugin-path " + kPlugins);
  EXPECT_EQ(ok.exit_code, 0) << ok.err;
  EXPECT_THAT(ok.out, HasSubstr("stc_slip4.yaml: OK"));
  EXPECT_THAT(ok.out, HasSubstr("angles [theta]"));
  EXPECT_THAT(ok.out, HasSubstr("slip_FR_RR"));
  // A bank that does not exist is a bad command line, as for every command's --bank.
  const Result missing = run_skidimm("validate /nonexistent.yaml");
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_THAT(missing.err, HasSubstr("File does not exist: /nonexistent.yaml"));
}

TEST(Cli, ValidateNamesEachModesPluginFileAndVersion) {
  const Result r = run_skidimm("validate " + kSource + "/configs/stc_slip4.yaml --plugin-path " + kPlugins);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("  plugins:\n    no_slip: plugin stc_kinematic 1.0.0 (" + kPlugins +
                               "/skidimm_stc_kinematic.so)"));
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

// A parameter of absurd size makes the prediction too large for central
// differences to check the plugin's (right) derivatives: validate says the
// entry cannot be checked and names the bank's parameter behind it, instead
// of calling the plugin's Jacobian wrong.
TEST(Cli, ValidateCheckNamesAParameterOfAbsurdSizeInsteadOfBlamingThePlugin) {
  const fs::path dir = test_directory();
  std::string bank = read_file(kSource + "/configs/ltc_terrains.yaml");
  const std::size_t a = bank.find("params: {A: [[");
  ASSERT_NE(a, std::string::npos);
  const std::size_t first = a + std::string("params: {A: [[").size();
  bank.replace(first, bank.find(',', first) - first, "1e300");
  const fs::path file = write_file(dir / "absurd_a.yaml", bank);
  const Result r = run_skidimm("validate " + file.string() + " --plugin-path " + kPlugins + " --check " + kSource +
                               "/configs/examples/ltc_switching.csv");
  EXPECT_EQ(r.exit_code, 1) << r.err;
  EXPECT_THAT(r.out, HasSubstr("    asphalt: FAILED at 20 of 20 points"));
  EXPECT_THAT(r.out, HasSubstr("parameter_jacobian() cannot be checked at x = ["));
  EXPECT_THAT(r.out, HasSubstr("the largest term of 'V' is parameter 'A[0,0]' = 1e+300"));
  EXPECT_THAT(r.out,
              HasSubstr("entry (row 0 'V', column 1 'A[0,1]'): analytic 0.000565582, numeric 0, rounding up to "));
  EXPECT_THAT(r.out, Not(HasSubstr("differs from central differences")));
  EXPECT_THAT(r.out, HasSubstr("    grass: ok\n    crushed_concrete: ok\n"));
  EXPECT_THAT(r.err, HasSubstr("one that cannot be checked comes of a value too large to difference, often a "
                               "parameter of " +
                               file.string() + " out of scale"));
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

// A model's complaint names the bank as the user gave it (a path relative to
// the working directory), as the parser's errors do, not as an absolute path.
TEST(Cli, AModelsComplaintNamesTheBankAsItWasGiven) {
  const fs::path dir = test_directory();
  std::string bank = read_file(kSource + "/configs/stc_slip4.yaml");
  const std::size_t r = bank.find("  r: 0.165");
  ASSERT_NE(r, std::string::npos);
  bank.replace(r, 10, "  r: -1");
  write_file(dir / "negative_radius.yaml", bank);
  const Result given =
      run_shell("cd " + dir.string() + " && " + kSkidimm + " validate negative_radius.yaml --plugin-path " + kPlugins);
  EXPECT_EQ(given.exit_code, 1);
  EXPECT_THAT(given.err, ::testing::StartsWith("skidimm validate: error: negative_radius.yaml:"));
  EXPECT_THAT(given.err, HasSubstr(": shared.r: mode 'no_slip' (model stc_kinematic, its value from 'shared:'): "));
  EXPECT_THAT(given.err, Not(HasSubstr(dir.string())));
  // Beside the working directory, given as '..': so named, as the parser names it.
  fs::create_directories(dir / "elsewhere");
  const Result beside = run_shell("cd " + (dir / "elsewhere").string() + " && " + kSkidimm +
                                  " validate ../negative_radius.yaml --plugin-path " + kPlugins);
  EXPECT_EQ(beside.exit_code, 1);
  EXPECT_THAT(beside.err, ::testing::StartsWith("skidimm validate: error: ../negative_radius.yaml:"));
  // From anywhere else (/): a path that names it from there.
  const Result far = run_shell("cd / && " + kSkidimm + " validate " + (dir / "negative_radius.yaml").string() +
                               " --plugin-path " + kPlugins);
  EXPECT_EQ(far.exit_code, 1);
  EXPECT_THAT(far.err, ::testing::StartsWith("skidimm validate: error: "));
  EXPECT_THAT(far.err, HasSubstr("negative_radius.yaml:"));
}

// A measurement that aggregates a step's rows needs a fixed step: validate
// said OK of a bank without one, which run refused. A warning (run --rate
// can give the step), and --rate gives it to validate as to run.
TEST(Cli, ValidateWarnsOfAnAggregatedMeasurementWithoutAFixedStep) {
  const fs::path dir = test_directory();
  std::string text = read_file(kSource + "/configs/ltc_terrains.yaml");
  const std::string columns = "  truth_mode: mode";
  ASSERT_NE(text.find(columns), std::string::npos);
  text.replace(text.find(columns), columns.size(), columns + "\n  measurements: {V: \"mean(V)\"}");
  const fs::path bank = write_file(dir / "mean.yaml", text);
  // The line of the inserted text, which the warning names.
  const auto line = 2 + std::count(text.begin(), text.begin() + static_cast<long>(text.find(columns)), '\n');
  const std::string validate = "validate " + bank.string() + " --plugin-path " + kPlugins;
  const Result plain = run_skidimm(validate);
  EXPECT_EQ(plain.exit_code, 0) << plain.err;
  EXPECT_THAT(plain.err, HasSubstr("skidimm validate: warning: " + bank.string() + ":" + std::to_string(line) +
                                   ": columns.measurements.V aggregates the rows of a filter step, which needs a "
                                   "fixed step"));
  EXPECT_THAT(plain.out,
              HasSubstr(bank.string() + ": OK as a bank, but 1 aggregated measurement(s) that need a fixed step "
                                        "(warnings on stderr)\n"));
  const std::string log = kSource + "/configs/examples/ltc_switching.csv";
  const Result run = run_skidimm("run -q --bank " + bank.string() + " --plugin-path " + kPlugins + " --input " + log +
                                 " --output " + (dir / "out.csv").string());
  EXPECT_EQ(run.exit_code, 1) << "what the warning foretells";
  EXPECT_THAT(run.err, HasSubstr("aggregates the rows of a filter step"));
  const Result stepped = run_skidimm(validate + " --rate 10 --check " + log);
  EXPECT_EQ(stepped.exit_code, 0) << stepped.err;
  EXPECT_THAT(stepped.err, Not(HasSubstr("aggregates")));
  EXPECT_EQ(run_skidimm(validate + " --check " + log).exit_code, 1) << "the log read without a fixed step";
}

// With --check the logs are read after the bank's summary: the verdict
// comes last, after what the logs gave reason to warn of, and counts it.
TEST(Cli, ValidateCheckGivesItsVerdictAfterTheLogsWarnings) {
  const fs::path dir = test_directory();
  auto rows = read_csv(kSwitching);
  const std::size_t omega = static_cast<std::size_t>(column(rows[0], "omega"));
  for (std::size_t i = 1; i < rows.size(); ++i) rows[i][omega].clear();
  const fs::path log = write_file(dir / "no_omega.csv", csv_text(rows));
  const std::string validate = "validate " + kTerrains + " --plugin-path " + kPlugins + " --check ";
  const Result warned = run_skidimm(validate + log.string());
  EXPECT_EQ(warned.exit_code, 0) << warned.err;
  EXPECT_THAT(warned.err, HasSubstr("skidimm validate: warning: " + log.string() +
                                    ": measurement 'omega' (\"omega\") had no value at any step\n"));
  EXPECT_THAT(warned.out, ::testing::StartsWith(kTerrains + ":\n  bank:"));
  EXPECT_THAT(warned.out, ::testing::EndsWith("    crushed_concrete: ok\n" + kTerrains +
                                              ": OK as a bank, but 1 warning(s) about the log(s) of --check "
                                              "(warnings on stderr)\n"));
  const Result clean = run_skidimm(validate + kSwitching);
  EXPECT_EQ(clean.exit_code, 0) << clean.err;
  EXPECT_EQ(clean.err, "");
  EXPECT_THAT(clean.out, ::testing::EndsWith("    crushed_concrete: ok\n" + kTerrains + ": OK\n"));
  // A truth label the bank does not know (here a capital letter): fit and tune refuse it later; said now.
  auto relabelled = read_csv(kSwitching);
  const std::size_t mode = static_cast<std::size_t>(column(relabelled[0], "mode"));
  for (std::size_t i = 1; i < relabelled.size(); ++i) {
    if (relabelled[i][mode] == "asphalt") relabelled[i][mode] = "Asphalt";
  }
  const fs::path typo = write_file(dir / "typo.csv", csv_text(relabelled));
  const Result labelled = run_skidimm(validate + typo.string());
  EXPECT_EQ(labelled.exit_code, 0) << labelled.err;
  EXPECT_THAT(labelled.err, HasSubstr("skidimm validate: warning: " + typo.string() +
                                      ": its truth column 'mode' holds a label the bank does not know: 'Asphalt' is "
                                      "neither a mode nor a class of bank 'ltc_terrains'"));
  EXPECT_THAT(labelled.err, HasSubstr("names are case-sensitive: 'asphalt'?"));
  EXPECT_THAT(labelled.out, HasSubstr(": OK as a bank, but 1 warning(s) about the log(s) of --check"));
  const Result label_given = run_skidimm(validate + "grass=" + typo.string());
  EXPECT_EQ(label_given.err, "") << "the label given overrides the truth column";
  // A log the bank cannot read is an error, with no verdict said before it.
  const Result unreadable = run_skidimm(validate + (dir / "missing.csv").string());
  EXPECT_EQ(unreadable.exit_code, 1);
  EXPECT_THAT(unreadable.out, Not(HasSubstr("OK")));
}

// An empty parameter covariance would read as none at all.
TEST(Cli, ValidateRefusesAnEmptyParameterCovariance) {
  const fs::path dir = test_directory();
  std::string bank = read_file(kSource + "/configs/ltc_terrains.yaml");
  const std::size_t q = bank.find("    Q:");
  ASSERT_NE(q, std::string::npos);
  bank.insert(q, "    parameter_covariance: {diagonal: []}\n");
  const fs::path file = write_file(dir / "empty_covariance.yaml", bank);
  const Result r = run_skidimm("validate " + file.string() + " --plugin-path " + kPlugins);
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("empty_covariance.yaml:"));
  EXPECT_THAT(r.err, HasSubstr(".parameter_covariance"));
  EXPECT_THAT(r.err, HasSubstr("is empty: expected one value per parameter of the model"));
}

// A column text that is neither a plain name nor an expression the log
// reader evaluates is found without a log: a warning naming the field and
// why, on a bank still OK (exit 0), as a log with a column of exactly that
// text would be read. Every bundled bank's columns pass (Install.* validates
// them all), the bag-reading one's topic paths included.
TEST(Cli, ValidateWarnsOfColumnsOnlyAColumnOfThatExactTextCouldGive) {
  const fs::path dir = test_directory();
  const std::string source = read_file(kSource + "/configs/borealtc/terrains.yaml");
  const auto edited = [&](const std::string& name, const std::string& from, const std::string& to) {
    std::string bank = source;
    const std::size_t at = bank.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) bank.replace(at, from.size(), to);
    return write_file(dir / name, bank);
  };
  const Result good =
      run_skidimm("validate " + (kSource + "/configs/borealtc/terrains.yaml") + " --plugin-path " + kPlugins);
  EXPECT_EQ(good.exit_code, 0) << good.err;
  EXPECT_THAT(good.out, HasSubstr("terrains.yaml: OK"));
  EXPECT_THAT(good.err, Not(HasSubstr("warning")));
  const fs::path unbalanced = edited("unbalanced.yaml", "abs(velL + velR) / 2", "abs(velL + velR)) / 2");
  const Result r = run_skidimm("validate " + unbalanced.string() + " --plugin-path " + kPlugins);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("unbalanced.yaml: OK as a bank, but 1 column text(s) a log can give only as a column "
                               "of exactly that text (warnings on stderr)"));
  // Located as the loader's errors are: the file, the line of the text, the field.
  EXPECT_THAT(r.err,
              HasSubstr("warning: " + unbalanced.string() +
                        ":11: columns.inputs.speed: cannot parse \"abs(velL + velR)) / 2\": a ')' without its '('"));
  EXPECT_THAT(r.err, HasSubstr("(a log can give it only as a column of exactly this text; --check LOG reads one)"));
  const Result unknown = run_skidimm("validate " + edited("unknown.yaml", "log(std(ax))", "log(stdev(ax))").string() +
                                     " --plugin-path " + kPlugins);
  EXPECT_EQ(unknown.exit_code, 0);
  EXPECT_THAT(unknown.err,
              HasSubstr(":18: columns.measurements.vib_ax: cannot parse \"log(stdev(ax))\": unknown function "
                        "'stdev' (the functions are abs, sign, sqrt, exp, log, log10, sin, cos, min, max; "
                        "over a step's rows, mean, std, rms, diff_std)"));
  const Result outside = run_skidimm("validate " + edited("outside.yaml", "mean(wz)", "mean(wz) + wx").string() +
                                     " --plugin-path " + kPlugins);
  EXPECT_EQ(outside.exit_code, 0);
  EXPECT_THAT(outside.err, HasSubstr("columns.measurements.omega: \"mean(wz) + wx\" uses column 'wx' outside mean(), "
                                     "std(), rms() or diff_std()"));
  // A dotted column name, as ROS CSV exports write them, is a column of a
  // log that has it: the warning without one, nothing with --check of it.
  std::string ltc = read_file(kTerrains);
  const std::size_t columns = ltc.find("columns:\n");
  ASSERT_NE(columns, std::string::npos);
  ltc.insert(columns + 9, "  inputs: {phi_dot_L: field.phi_dot_L, phi_dot_R: phi_dot_R}\n");
  const fs::path dotted = write_file(dir / "dotted.yaml", ltc);
  std::string log = read_file(kSwitching);
  log.replace(log.find("phi_dot_L"), 9, "field.phi_dot_L");
  const fs::path dotted_log = write_file(dir / "dotted.csv", log);
  const Result without_log = run_skidimm("validate " + dotted.string() + " --plugin-path " + kPlugins);
  EXPECT_EQ(without_log.exit_code, 0) << without_log.err;
  EXPECT_THAT(without_log.err, HasSubstr("columns.inputs.phi_dot_L: cannot parse \"field.phi_dot_L\""));
  const Result with_log =
      run_skidimm("validate " + dotted.string() + " --check " + dotted_log.string() + " --plugin-path " + kPlugins);
  EXPECT_EQ(with_log.exit_code, 0) << with_log.err;
  EXPECT_THAT(with_log.err, Not(HasSubstr("warning")));
  EXPECT_EQ(run_skidimm("run -q --bank " + dotted.string() + " --input " + dotted_log.string() + " --output " +
                        (dir / "out.csv").string() + " --plugin-path " + kPlugins)
                .exit_code,
            0);
}

}  // namespace
// A class whose every mode has a fit_when leaves the steps none of them
// holds for unfitted, without a word:
// validate and fit say so.
TEST(Cli, AClassWhoseEveryModeHasAFitWhenIsSaidToLeaveStepsUnfitted) {
  const fs::path dir = test_directory();
  std::string bank = read_file(kSource + "/configs/borealtc/wheels_start.yaml");
  const std::string straight = "  - name: ASPHALT_straight\n";
  ASSERT_NE(bank.find(straight), std::string::npos);
  bank.replace(bank.find(straight), straight.size(), straight + "    fit_when: \"turn < 0.02\"\n");
  const fs::path file = write_file(dir / "both.yaml", bank);
  const std::string warning = file.string() +
                              ": class 'ASPHALT': every mode of it has a fit_when, so a step of the class none of "
                              "them holds for is fitted by no mode; leave one mode without fit_when to take the rest";
  const Result validated = run_skidimm("validate " + file.string() + " --plugin-path " + kPlugins);
  EXPECT_EQ(validated.exit_code, 0) << validated.err;
  EXPECT_THAT(validated.err, HasSubstr("skidimm validate: warning: " + warning));
  EXPECT_THAT(validated.out,
              HasSubstr(file.string() + ": OK as a bank, but 1 class(es) with steps that no mode is fitted on "
                                        "(warnings on stderr)\n"));
  const Result bundled =
      run_skidimm("validate " + kSource + "/configs/borealtc/wheels_start.yaml --plugin-path " + kPlugins);
  EXPECT_THAT(bundled.err, Not(HasSubstr("fitted by no mode")));
  const std::string boreal = std::string(SKIDIMM_SHARED_DATA_DIR) + "/borealtc";
  if (!fs::exists(boreal)) GTEST_SKIP() << "no shared data at " << boreal;
  const Result fitted =
      run_skidimm("fit --bank " + file.string() + " --objective window --hold-unexcited --log 'ASPHALT=" + boreal +
                  "/ASPHALT/pro_00.csv'");
  EXPECT_EQ(fitted.exit_code, 0) << fitted.err;
  EXPECT_THAT(fitted.err, HasSubstr("skidimm fit: warning: " + warning));
}

}  // namespace skidimm_test
