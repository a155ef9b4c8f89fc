#include "skidimm/config/bank.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>

#include "core/temp_files.h"
#include "skidimm/errors.h"

namespace skidimm {
namespace {

using skidimm_test::test_directory;
using skidimm_test::write_file;
using ::testing::HasSubstr;

const std::string kSourceDir = SKIDIMM_SOURCE_DIR;
const std::string kPluginDir = SKIDIMM_PLUGIN_DIR;

// A valid two-mode LTC bank; tests break one line at a time.
const std::string kValidBank = R"(name: two_terrains
states: [V, omega]
inputs: [phi_dot_L, phi_dot_R]
columns:
  time: time
  inputs: {phi_dot_L: left, phi_dot_R: right}
measurement:
  observe: [V, omega]
  R: {std: [0.05, 0.03]}
transition:
  stay: 0.98
initial:
  covariance: {diagonal: [1, 1]}
modes:
  - name: grip
    model: ltc_linear
    params: {A: [[-5, 0], [0, -4]], B: [[0.4, 0.4], [-0.8, 0.8]]}
    Q: {diagonal: [0.01, 0.01]}
  - name: ice
    model: ltc_linear
    params: {A: [[-2, 0], [0, -1]], B: [[0.1, 0.1], [-0.2, 0.2]]}
    Q: [[0.02, 0], [0, 0.02]]
)";

std::string replace(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << "test setup: '" << from << "' not in the bank";
  return text.replace(at, from.size(), to);
}

// Expects load_bank_config (or Bank::load when `with_plugins`) to fail with a
// message containing each of `parts`, and returns the error.
ConfigError expect_config_error(const std::string& yaml, std::initializer_list<std::string> parts,
                                bool with_plugins = false) {
  const auto file = write_file(test_directory() / "bank.yaml", yaml);
  try {
    if (with_plugins) {
      Bank::load(file, {kPluginDir});
    } else {
      load_bank_config(file);
    }
  } catch (const ConfigError& e) {
    for (const std::string& part : parts) EXPECT_THAT(e.what(), HasSubstr(part));
    EXPECT_THAT(e.what(), HasSubstr(file.string()));
    return e;
  }
  ADD_FAILURE() << "expected a ConfigError";
  return ConfigError("", 0, "", "");
}

TEST(BankConfig, ParsesTheValidBank) {
  const BankConfig c = load_bank_config(write_file(test_directory() / "bank.yaml", kValidBank));
  EXPECT_EQ(c.name, "two_terrains");
  EXPECT_EQ(c.num_modes(), 2);
  EXPECT_EQ(c.columns.time, "time");
  EXPECT_EQ(c.columns.inputs, (std::vector<std::string>{"left", "right"}));
  EXPECT_EQ(c.columns.measurements, (std::vector<std::string>{"V", "omega"}));  // defaults to the names
  EXPECT_DOUBLE_EQ(c.measurement.r(0, 0), 0.0025);
  EXPECT_DOUBLE_EQ(c.modes[1].q_intensity(1, 1), 0.02);
  EXPECT_EQ(c.initial_mode_probabilities, Eigen::Vector2d(0.5, 0.5));
  EXPECT_EQ(c.transition.kind, TransitionConfig::Kind::kStay);
  EXPECT_EQ(c.modes[1].line, 19);
}

TEST(BankConfig, EveryBundledBankLoadsWithItsPlugins) {
  for (const char* name : {"ltc_terrains", "ltc_shared", "stc_slip4", "stc_slip16", "physical/ltc_terrains",
                           "physical/ltc_shared", "physical/stc_slip4", "physical/stc_slip16", "husky/ice_ltc"}) {
    const Bank bank = Bank::load(kSourceDir + "/configs/" + name + ".yaml", {kPluginDir});
    EXPECT_EQ(bank.models.size(), bank.config.modes.size()) << name;
  }
  EXPECT_EQ(Bank::load(kSourceDir + "/configs/stc_slip16.yaml", {kPluginDir}).config.num_modes(), 16);
}

TEST(BankConfig, ColumnsDefaultToTheNamesWhenTheSectionIsAbsent) {
  std::string yaml = kValidBank;
  yaml.erase(yaml.find("columns:"), yaml.find("measurement:") - yaml.find("columns:"));
  const BankConfig c = load_bank_config(write_file(test_directory() / "bank.yaml", yaml));
  EXPECT_EQ(c.columns.time, "t");
  EXPECT_EQ(c.columns.inputs, (std::vector<std::string>{"phi_dot_L", "phi_dot_R"}));
  EXPECT_EQ(c.columns.measurements, (std::vector<std::string>{"V", "omega"}));
}

TEST(BankConfig, MalformedYamlNamesTheLine) {
  const ConfigError e = expect_config_error(replace(kValidBank, "  stay: 0.98", "  stay: [0.98"), {"malformed YAML"});
  EXPECT_GE(e.line(), 11);
}

TEST(BankConfig, MissingSectionIsNamed) {
  expect_config_error(replace(kValidBank, "transition:\n  stay: 0.98\n", ""), {"transition: missing (required)"});
}

TEST(BankConfig, WrongSizedQNamesModeFieldAndLine) {
  expect_config_error(replace(kValidBank, "Q: [[0.02, 0], [0, 0.02]]", "Q: [[0.02, 0, 0], [0, 0.02, 0]]"),
                      {"bank.yaml:22: modes[1].Q: expected a 2x2 matrix, got 2x3"});
}

TEST(BankConfig, IndefiniteQIsRejectedWithTheModeName) {
  expect_config_error(replace(kValidBank, "Q: [[0.02, 0], [0, 0.02]]", "Q: [[0.02, 0.1], [0.1, 0.02]]"),
                      {"modes[1].Q (mode 'ice')", "not positive semidefinite"});
}

TEST(BankConfig, MeasurementNoiseMustBePositiveDefinite) {
  expect_config_error(replace(kValidBank, "R: {std: [0.05, 0.03]}", "R: {std: [0.05, 0]}"),
                      {"measurement.R", "not positive definite"});
}

// A mode's own R: every measurement row, a covariance; without one a mode
// uses the bank's.
TEST(BankConfig, AModesOwnMeasurementNoiseIsReadAndChecked) {
  const std::string own =
      replace(kValidBank, "Q: [[0.02, 0], [0, 0.02]]", "Q: [[0.02, 0], [0, 0.02]]\n    R: {std: [0.1, 0.2]}");
  const BankConfig c = load_bank_config(write_file(test_directory() / "own_r.yaml", own));
  EXPECT_EQ(c.modes[0].r.size(), 0);
  EXPECT_EQ(c.measurement_noise(0), c.measurement.r);
  EXPECT_TRUE(c.measurement_noise(1).isApprox(Eigen::Vector2d(0.01, 0.04).asDiagonal().toDenseMatrix()));
  EXPECT_TRUE(c.any_mode_measurement_noise());
  expect_config_error(replace(own, "R: {std: [0.1, 0.2]}", "R: {std: [0.1]}"),
                      {"bank.yaml:23: modes[1].R.std: expected 2 values, got 1"});
  expect_config_error(replace(own, "R: {std: [0.1, 0.2]}", "R: [[0.01, 0.05], [0.05, 0.01]]"),
                      {"modes[1].R (mode 'ice')", "not positive definite"});
}

TEST(BankConfig, TransitionRowsMustSumToOne) {
  expect_config_error(replace(kValidBank, "  stay: 0.98", "  matrix: [[0.9, 0.1], [0.3, 0.6]]"),
                      {"transition.matrix[1]", "sums to 0.9", "rows are 'from', columns 'to'"});
  expect_config_error(replace(kValidBank, "  stay: 0.98", "  matrix: [[0.5, 0.5000001], [0.3, 0.7]]"),
                      {"transition.matrix[0]", "sums to 1.0000001 (within 1e-9 of 1 is taken as 1)"});
}

TEST(BankConfig, UnknownKeyIsATypoNotIgnored) {
  expect_config_error(replace(kValidBank, "  stay: 0.98", "  stay: 0.98\n  sty: 0.5"),
                      {"transition.sty: unknown key (expected one of: stay, matrix, mean_dwell_time)"});
}

TEST(BankConfig, ObservedNameMustBeAState) {
  expect_config_error(replace(kValidBank, "observe: [V, omega]", "observe: [V, yaw]"),
                      {"measurement.observe", "'yaw' is not a state (states: V, omega)"});
}

TEST(BankConfig, DwellTimesPerModeMustCoverEveryMode) {
  expect_config_error(replace(kValidBank, "  stay: 0.98", "  mean_dwell_time: {grip: 5}"),
                      {"no dwell time for mode 'ice'"});
  const BankConfig c = load_bank_config(write_file(
      test_directory() / "ok.yaml", replace(kValidBank, "  stay: 0.98", "  mean_dwell_time: {grip: 5, ice: 2}")));
  EXPECT_EQ(c.transition.kind, TransitionConfig::Kind::kDwellTimes);
  EXPECT_EQ(c.transition.dwell_seconds, Eigen::Vector2d(5, 2));
}

TEST(BankConfig, InitialProbabilitiesMustSumToOne) {
  expect_config_error(replace(kValidBank, "  covariance: {diagonal: [1, 1]}",
                              "  covariance: {diagonal: [1, 1]}\n  mode_probabilities: {grip: 0.5}"),
                      {"initial.mode_probabilities", "must sum to 1"});
}

TEST(BankConfig, DuplicateModeNames) {
  expect_config_error(replace(kValidBank, "name: ice", "name: grip"), {"modes[1].name", "'grip' appears twice"});
}

TEST(BankConfig, NonNumericMatrixEntry) {
  expect_config_error(replace(kValidBank, "[[-2, 0], [0, -1]]", "[[-2, 0], [0, fast]]"),
                      {"modes[1].params.A[1][1]: expected a number, got 'fast'"});
}

// Rows of unequal length: either may be the wrong one, so both lengths are said.
TEST(BankConfig, RaggedMatrixRows) {
  expect_config_error(replace(kValidBank, "[[-2, 0], [0, -1]]", "[[-2, 0, 0.5], [0, -1]]"),
                      {"modes[1].params.A[1]: this row has 2 numbers and row 0 has 3: every row of a matrix needs "
                       "as many"});
}

TEST(BankConfig, TextParametersAreStringsOrListsOfStrings) {
  const BankConfig c = load_bank_config(write_file(
      test_directory() / "bank.yaml",
      replace(kValidBank, "params: {A: [[-2, 0], [0, -1]]",
              "params: {note: fast ice, features: [v, \"abs(dv)\", \"1\"], gains: [1, 2], A: [[-2, 0], [0, -1]]")));
  const sdk::ParameterSet& p = c.modes[1].params;
  ASSERT_NE(p.find_text("note"), nullptr);
  EXPECT_EQ(*p.find_text("note"), std::vector<std::string>{"fast ice"});
  ASSERT_NE(p.find_text("features"), nullptr);
  EXPECT_EQ(*p.find_text("features"), (std::vector<std::string>{"v", "abs(dv)", "1"}));  // a quoted "1" is text
  ASSERT_NE(p.find("gains"), nullptr);                                                    // numbers stay a matrix
  EXPECT_EQ(p.find("gains")->rows(), 2);
  EXPECT_EQ(p.find_text("gains"), nullptr);
  EXPECT_EQ(p.keys(), (std::vector<std::string>{"A", "B", "features", "gains", "note"}));
}

TEST(Bank, ModelsReceiveTheBanksNamesAndUnknownTextIsRejected) {
  // ltc_linear takes A and B only: a text parameter is an unknown key, named.
  expect_config_error(replace(kValidBank, "params: {A: [[-2, 0], [0, -1]]", "params: {note: x, A: [[-2, 0], [0, -1]]"),
                      {"modes[1].params", "unknown parameter 'note'"}, /*with_plugins=*/true);
}

TEST(BankConfig, ClassesAndFitWhenAreChecked) {
  const std::string with_classes = kValidBank + "classes:\n  slippery: [grip, ice]\n";
  const BankConfig c = load_bank_config(write_file(
      test_directory() / "bank.yaml",
      replace(with_classes, "    Q: [[0.02, 0], [0, 0.02]]", "    Q: [[0.02, 0], [0, 0.02]]\n    fit_when: phi_dot_R > phi_dot_L")));
  EXPECT_EQ(c.modes[1].fit_when, "phi_dot_R > phi_dot_L");
  EXPECT_EQ(c.class_names(), std::vector<std::string>{"slippery"});
  EXPECT_EQ(c.class_index("ice"), 0);
  EXPECT_EQ(c.class_index("slippery"), 0);
  EXPECT_EQ(c.class_index("mud"), -1);
  expect_config_error(replace(with_classes, "    Q: [[0.02, 0], [0, 0.02]]", "    Q: [[0.02, 0], [0, 0.02]]\n    fit_when: v > 0"),
                      {"modes[1].fit_when", "'v' is not an input (inputs: phi_dot_L, phi_dot_R)"});
  expect_config_error(replace(kValidBank, "    Q: [[0.02, 0], [0, 0.02]]", "    Q: [[0.02, 0], [0, 0.02]]\n    fit_when: phi_dot_L >"),
                      {"modes[1].fit_when", "cannot parse"});
  // Positions as in a column text's errors: the character, counted from 1.
  expect_config_error(
      replace(kValidBank, "    Q: [[0.02, 0], [0, 0.02]]",
              "    Q: [[0.02, 0], [0, 0.02]]\n    fit_when: phi_dot_L > > 0"),
      {"modes[1].fit_when: cannot parse \"phi_dot_L > > 0\": Unexpected operator \">\" found at character 13"});
  expect_config_error(replace(kValidBank, "    Q: [[0.02, 0], [0, 0.02]]",
                              "    Q: [[0.02, 0], [0, 0.02]]\n    fit_when: phi_dot_L > 0)"),
                      {"modes[1].fit_when: cannot parse \"phi_dot_L > 0)\": a ')' without its '(' at character 14"});
  expect_config_error(replace(kValidBank, "    Q: [[0.02, 0], [0, 0.02]]", "    Q: [[0.02, 0], [0, 0.02]]\n    fit_when: phi_dot_L > 0"),
                      {"modes[1].fit_when", "mode 'ice' is in none"});
  expect_config_error(kValidBank + "classes:\n  slippery: [grip, snow]\n", {"classes.slippery", "'snow' is not a mode"});
  expect_config_error(kValidBank + "classes:\n  a: [grip]\n  b: [grip, ice]\n", {"classes.b", "mode 'grip' is in two classes"});
  expect_config_error(kValidBank + "classes:\n  ice: [grip]\n", {"classes.ice", "also a mode's name"});
}

TEST(BankConfig, ARepeatedKeyIsAnErrorAnywhereAndAliasesCostNothing) {
  expect_config_error(replace(kValidBank, "    Q: [[0.02, 0], [0, 0.02]]", "    Q: [[0.02, 0], [0, 0.02]]\n    Q: [[1, 0], [0, 1]]"),
                      {"modes[1].Q: appears twice in one mapping (first on line"});
  expect_config_error(replace(kValidBank, "name: two_terrains\n", "name: two_terrains\nname: other\n"),
                      {":2: name: appears twice"});
  expect_config_error(replace(kValidBank, "  time: time\n", "  time: time\n  time: t\n"), {"columns.time: appears twice"});
  // A billion laughs: ten levels of ten aliases. Rejected for its unknown key, at once.
  std::string bomb = "name: bomb\nl0: &l0 [x, x, x, x, x, x, x, x, x, x]\n";
  for (int level = 1; level < 10; ++level) {
    const std::string previous = "*l" + std::to_string(level - 1);
    bomb += "l" + std::to_string(level) + ": &l" + std::to_string(level) + " [";
    for (int k = 0; k < 10; ++k) bomb += (k ? ", " : "") + previous;
    bomb += "]\n";
  }
  expect_config_error(bomb, {"l0: unknown key"});
}

TEST(BankConfig, NamesArePrintableAndNotTheDecisionsUnknown) {
  expect_config_error(replace(kValidBank, "name: ice", "name: \"ice\\e[2J\""), {"modes[1].name", "control characters"});
  expect_config_error(replace(kValidBank, "name: ice", "name: unknown"), {"modes[1].name", "'unknown' is the decision's answer"});
  const ConfigError e = expect_config_error(replace(kValidBank, "name: ice", "name: \"i\\x1b]0;pwned\\x07ce\""),
                                            {"modes[1].name"});
  for (unsigned char c : std::string(e.what())) EXPECT_TRUE(c >= 0x20 || c == '\n' || c == '\t') << int(c);
}

TEST(BankConfig, SamplingIsChecked) {
  const BankConfig c = load_bank_config(
      write_file(test_directory() / "bank.yaml", kValidBank + "sampling: {join: rows, rate: 12.5}\n"));
  EXPECT_EQ(c.sampling.join, SamplingConfig::Join::kRows);
  EXPECT_EQ(c.sampling.rate, 12.5);
  expect_config_error(kValidBank + "sampling: {join: side_by_side}\n", {"sampling.join", "expected 'time'"});
  expect_config_error(kValidBank + "sampling: {rate: 0}\n", {"sampling.rate", "must be a rate in Hz"});
  EXPECT_FALSE(c.sampling.skip_gaps);
  EXPECT_FALSE(c.sampling.skip_out_of_order);
  const BankConfig lenient = load_bank_config(write_file(
      test_directory() / "bank.yaml", kValidBank + "sampling: {skip_gaps: true, skip_out_of_order: true}\n"));
  EXPECT_TRUE(lenient.sampling.skip_gaps);
  EXPECT_TRUE(lenient.sampling.skip_out_of_order);
  expect_config_error(kValidBank + "sampling: {skip_out_of_order: yes please}\n",
                      {"sampling.skip_out_of_order", "expected true or false, got 'yes please'"});
  expect_config_error(kValidBank + "sampling: {skip_gaps: 1}\n", {"sampling.skip_gaps", "expected true or false"});
}

TEST(Bank, UnknownPluginListsWhatWasFound) {
  expect_config_error(
      replace(kValidBank, "model: ltc_linear\n    params: {A: [[-2", "model: ltc_lineer\n    params: {A: [[-2"),
      {"modes[1].model", "no plugin named 'ltc_lineer'", "found: ", "ltc_linear"}, true);
}

TEST(Bank, PluginRejectionIsReportedAtTheMode) {
  expect_config_error(replace(kValidBank, ", B: [[0.1, 0.1], [-0.2, 0.2]]}", "}"),
                      {"bank.yaml:19: modes[1].params", "mode 'ice' (model ltc_linear)", "missing parameter 'B'"},
                      true);
}

TEST(Bank, StateNamesMustMatchThePlugin) {
  expect_config_error(replace(kValidBank, "states: [V, omega]\n", "states: [omega, V]\n"),
                      {"has states [V, omega] but the bank declares [omega, V]"}, true);
}

// measurement.outputs: rows after the states' with zero H, named and read
// like the outputs; every mode's model must have each.
TEST(Bank, MeasuredOutputsFollowTheStatesAndEveryModelMustHaveThem) {
  std::string yaml = skidimm_test::read_file(std::filesystem::path(kSourceDir) / "configs/stc_sided4.yaml");
  yaml = replace(yaml, "R: {std: [0.03, 0.03, 0.03]}", "outputs: [omega]\n  R: {std: [0.03, 0.03, 0.03, 0.02]}");
  const Bank bank = Bank::load(write_file(test_directory() / "outputs.yaml", yaml), {kPluginDir});
  const MeasurementConfig& m = bank.config.measurement;
  EXPECT_EQ(m.names, (std::vector<std::string>{"X", "Y", "theta", "omega"}));
  EXPECT_EQ(m.outputs, (std::vector<std::string>{"omega"}));
  EXPECT_EQ(m.first_output_row(), 3);
  EXPECT_EQ(m.h.rows(), 4);
  EXPECT_TRUE(m.h.row(3).isZero());
  EXPECT_FALSE(m.is_angle[3]);
  EXPECT_EQ(bank.config.columns.measurements[3], "omega");

  expect_config_error(
      replace(yaml, "outputs: [omega]", "outputs: [i_L]"),
      {"modes[0].model", "mode 'no_slip' (model stc_sided) has no output 'i_L'", "its outputs are [omega]"}, true);
  expect_config_error(replace(yaml, "outputs: [omega]", "outputs: [theta]"), {"measurement.outputs", "theta"});
  expect_config_error(replace(yaml, "outputs: [omega]", "outputs: []"), {"measurement.outputs", "lists no output"});
  expect_config_error(replace(yaml, "0.03, 0.02]", "0.03]"), {"measurement.R"});
}

TEST(Bank, BankScopedParametersMustBeShared) {
  std::string yaml =
      replace(kValidBank, "model: ltc_linear\n    params: {A: [[-5", "model: ltc_shared\n    params: {A: [[-5");
  expect_config_error(yaml, {"modes[0].params.A", "give it once under 'shared:'"}, true);
}

// The converse: a bank-level parameter the bank gives nowhere is said to
// belong under `shared:`, for a class-form plugin (whose own "missing
// parameter" cannot say where it belongs) as for a function model.
TEST(Bank, BankScopedParameterGivenNowhereIsSaidToBelongUnderShared) {
  std::string yaml = replace(kValidBank, "modes:\n", "shared: {r: 0.165}\nmodes:\n");
  yaml = replace(yaml, "model: ltc_linear\n    params: {A: [[-5, 0], [0, -4]], B: [[0.4, 0.4], [-0.8, 0.8]]}",
                 "model: wrong_jacobian\n    params: {k: 5, c: 0.1}");
  yaml = replace(yaml, "model: ltc_linear\n    params: {A: [[-2, 0], [0, -1]], B: [[0.1, 0.1], [-0.2, 0.2]]}",
                 "model: wrong_jacobian\n    params: {k: 2, c: 0.3}");
  const std::vector<std::filesystem::path> paths{kPluginDir, std::string(SKIDIMM_TEST_PLUGIN_ROOT) + "/wrong_jacobian"};
  const auto file = write_file(test_directory() / "no_b.yaml", yaml);
  try {
    Bank::load(file, paths);
    ADD_FAILURE() << "expected a ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(),
                HasSubstr(file.string() + ":16: modes[0].params: mode 'grip' (model wrong_jacobian): "
                                          "the bank gives no 'b', which model wrong_jacobian declares bank-level "
                                          "(one value for every mode): give it once under 'shared:'"));
    EXPECT_THAT(e.what(), HasSubstr("missing parameter 'b'"));  // the model's own words follow
  }
  const Bank bank = Bank::load(
      write_file(test_directory() / "with_b.yaml", replace(yaml, "shared: {r: 0.165}", "shared: {r: 0.165, b: 0.555}")),
      paths);
  EXPECT_EQ(bank.models.size(), 2u);

  const std::string sided = skidimm_test::read_file(std::filesystem::path(kSourceDir) / "configs/stc_sided4.yaml");
  expect_config_error(replace(sided, "  r: 0.165", "  r_typo: 0.165"),
                      {"modes[0].params: mode 'no_slip' (model stc_sided): the bank gives no 'r', which model "
                       "stc_sided declares bank-level (one value for every mode): give it once under 'shared:'"},
                      true);
}

// A model's complaint about a parameter it names points at the line that
// gave that parameter: a mode's own params, or the bank's shared: (given to
// every mode, but not written at any mode's line), not at the first mode.
TEST(Bank, AModelsComplaintAboutAParameterPointsAtTheLineThatGaveIt) {
  const std::string slip = skidimm_test::read_file(std::filesystem::path(kSourceDir) / "configs/stc_slip4.yaml");
  const auto line_of = [](const std::string& yaml, const std::string& text) {
    const std::size_t at = yaml.find(text);
    return at == std::string::npos ? -1 : 1 + static_cast<int>(std::count(yaml.begin(), yaml.begin() + at, '\n'));
  };
  const std::string shared = replace(slip, "  r: 0.165", "  r: -1");
  expect_config_error(shared,
                      {"bank.yaml:" + std::to_string(line_of(shared, "  r: -1")) +
                           ": shared.r: mode 'no_slip' (model stc_kinematic, its value from 'shared:'): ",
                       "parameter 'r' = -1.000000 is outside"},
                      true);
  const std::string own = replace(slip, "params: {k: 0.9990679,", "params: {k: -3,");
  ASSERT_NE(own, slip) << "the second mode's params in configs/stc_slip4.yaml";
  expect_config_error(own,
                      {"bank.yaml:" + std::to_string(line_of(own, "params: {k: -3,")) +
                           ": modes[1].params.k: mode 'slip_FL_FR' (model stc_kinematic): ",
                       "parameter 'k' = -3.000000 is outside"},
                      true);
}

TEST(Bank, SharedParametersReachEveryModeAndUnusedOnesAreErrors) {
  std::string yaml = kValidBank;
  yaml = replace(yaml, "modes:\n", "shared:\n  A: [[-3, 0], [0, -3]]\n  B: [[0.2, 0.2], [-0.4, 0.4]]\nmodes:\n");
  yaml = replace(yaml, "    model: ltc_linear\n    params: {A: [[-5, 0], [0, -4]], B: [[0.4, 0.4], [-0.8, 0.8]]}\n",
                 "    model: ltc_shared\n");
  yaml = replace(yaml, "    model: ltc_linear\n    params: {A: [[-2, 0], [0, -1]], B: [[0.1, 0.1], [-0.2, 0.2]]}\n",
                 "    model: ltc_shared\n");
  const Bank bank = Bank::load(write_file(test_directory() / "shared.yaml", yaml), {kPluginDir});
  Eigen::VectorXd values(8);
  bank.models[1]->get_parameters(values);
  EXPECT_EQ(values[0], -3.0);
  EXPECT_EQ(values[4], 0.2);
  expect_config_error(replace(yaml, "shared:\n", "shared:\n  C: 1\n"),
                      {"shared.C", "not a parameter of any mode's model"}, true);
}

TEST(BankConfig, MissingPluginPathIsNamed) {
  expect_config_error(replace(kValidBank, "modes:\n", "plugin_paths: [../no_such_dir]\nmodes:\n"),
                      {"plugin_paths: '../no_such_dir' does not exist", "relative to the bank file"});
}

TEST(Bank, MissingFileIsAConfigError) { EXPECT_THROW(load_bank_config("/nonexistent/bank.yaml"), ConfigError); }

// Entries a filter step cannot carry are refused.
TEST(BankConfig, MatrixEntriesAbove1e15AreRefusedNamingModeFieldAndEntry) {
  expect_config_error(
      replace(kValidBank, "Q: [[0.02, 0], [0, 0.02]]", "Q: [[1e300, 0], [0, 1e300]]"),
      {"bank.yaml:22: modes[1].Q (mode 'ice'): entry (0, 0) = 1e+300 is larger in magnitude than 1e+15"});
  expect_config_error(replace(kValidBank, "R: {std: [0.05, 0.03]}", "R: {diagonal: [2e15, 1]}"),
                      {"measurement.R: entry (0, 0) = 2e+15"});
  expect_config_error(replace(kValidBank, "covariance: {diagonal: [1, 1]}", "covariance: {diagonal: [1, 1e16]}"),
                      {"initial.covariance: entry (1, 1) = 1e+16"});
  expect_config_error(
      replace(kValidBank, "covariance: {diagonal: [1, 1]}", "covariance: {diagonal: [1, 1]}\n  state: [0, -1e200]"),
      {"initial.state: entry (1, 0) = -1e+200"});
  // 1e15 itself is accepted.
  EXPECT_NO_THROW(load_bank_config(write_file(
      test_directory() / "ok.yaml", replace(kValidBank, "Q: [[0.02, 0], [0, 0.02]]", "Q: [[1e15, 0], [0, 1e15]]"))));
}

TEST(BankConfig, LikelihoodDofIsAPositiveNumberOrAbsent) {
  EXPECT_EQ(load_bank_config(write_file(test_directory() / "dof.yaml", "likelihood_dof: 4\n" + kValidBank)).likelihood_dof,
            4.0);
  EXPECT_EQ(load_bank_config(write_file(test_directory() / "gauss.yaml", kValidBank)).likelihood_dof, 0.0);
  expect_config_error("likelihood_dof: 0\n" + kValidBank, {"bank.yaml:1: likelihood_dof", "finite number > 0"});
  expect_config_error("likelihood_dof: -2\n" + kValidBank, {"likelihood_dof", "Gaussian"});
  expect_config_error("likelihood_dof: .inf\n" + kValidBank, {"likelihood_dof"});
}

TEST(BankConfig, DecisionStaleAfterIsSecondsOrAbsent) {
  const auto bank = [](const std::string& decision) {
    return load_bank_config(write_file(test_directory() / "stale.yaml", decision + kValidBank)).decision.stale_after;
  };
  EXPECT_EQ(bank("decision: {stale_after: 3}\n"), 3.0);
  EXPECT_EQ(bank("decision: {stale_after: 0}\n"), 0.0);
  EXPECT_LT(bank(""), 0.0) << "unset: the decision takes the bank's shortest mean dwell time";
  expect_config_error("decision: {stale_after: -1}\n" + kValidBank, {"decision.stale_after", "(0: never)"});
}

// columns.time_unit: the unit of a CSV time column, as units per second
// (seconds when absent); anything else names the file's line.
TEST(BankConfig, TheTimeColumnsUnitIsSecondsOrOneOfThreeOthers) {
  const auto with_unit = [](const std::string& unit) {
    std::string text = kValidBank;
    text.replace(text.find("  time: time\n"), 13, "  time: time\n  time_unit: " + unit + "\n");
    return text;
  };
  const auto per_second = [&](const std::string& unit) {
    return load_bank_config(write_file(test_directory() / "unit.yaml", with_unit(unit))).columns.time_units_per_second;
  };
  EXPECT_EQ(load_bank_config(write_file(test_directory() / "s.yaml", kValidBank)).columns.time_units_per_second, 1.0);
  EXPECT_EQ(per_second("s"), 1.0);
  EXPECT_EQ(per_second("ms"), 1e3);
  EXPECT_EQ(per_second("us"), 1e6);
  EXPECT_EQ(per_second("ns"), 1e9);
  expect_config_error(with_unit("minutes"),
                      {"bank.yaml:6: columns.time_unit", "must be s, ms, us or ns", "got 'minutes'"});
}

TEST(BankConfig, ExtrapolationScaleIsAPositiveNumberOrAbsent) {
  EXPECT_EQ(load_bank_config(write_file(test_directory() / "scale.yaml", "extrapolation_scale: 0.5\n" + kValidBank))
                .extrapolation_scale,
            0.5);
  EXPECT_EQ(load_bank_config(write_file(test_directory() / "no_scale.yaml", kValidBank)).extrapolation_scale, 0.0);
  expect_config_error("extrapolation_scale: 0\n" + kValidBank,
                      {"bank.yaml:1: extrapolation_scale", "finite number > 0", "range"});
  expect_config_error("extrapolation_scale: -1\n" + kValidBank, {"extrapolation_scale"});
  expect_config_error("extrapolation_scale: .nan\n" + kValidBank, {"extrapolation_scale"});
}

TEST(BankConfig, UnknownHypothesisIsOptInAndChecked) {
  EXPECT_FALSE(load_bank_config(write_file(test_directory() / "plain.yaml", kValidBank)).unknown.enabled());
  const BankConfig c = load_bank_config(write_file(
      test_directory() / "unknown.yaml", "unknown: {inflation: 50, enter: 0.01, leave: 0.3}\n" + kValidBank));
  EXPECT_TRUE(c.unknown.enabled());
  EXPECT_EQ(c.unknown.inflation, 50.0);
  EXPECT_EQ(c.unknown.enter, 0.01);
  EXPECT_EQ(c.unknown.leave, 0.3);
  expect_config_error("unknown:\n  inflation: 1\n  enter: 0.01\n  leave: 0.3\n" + kValidBank,
                      {"bank.yaml:2: unknown.inflation", "> 1"});
  expect_config_error("unknown:\n  inflation: 10\n  enter: 1\n  leave: 0.3\n" + kValidBank,
                      {"bank.yaml:3: unknown.enter", "[0, 1)"});
  expect_config_error("unknown:\n  inflation: 10\n  enter: 0\n  leave: 0\n" + kValidBank,
                      {"bank.yaml:4: unknown.leave", "(0, 1]"});
  expect_config_error("unknown:\n  inflation: 10\n  enter: 0.1\n" + kValidBank, {"unknown.leave", "missing"});
  expect_config_error("unknown:\n  inflation: 10\n  enter: 0.1\n  leave: 0.1\n  leav: 2\n" + kValidBank,
                      {"bank.yaml:5: unknown.leav", "unknown key"});
  expect_config_error("unknown: 3\n" + kValidBank, {"bank.yaml:1: unknown", "mapping"});
}

TEST(BankConfig, ResidualCorrelationIsInMinusOneToOne) {
  const std::string ice_q = "    Q: [[0.02, 0], [0, 0.02]]\n";
  const auto ok = write_file(test_directory() / "rho.yaml",
                             replace(kValidBank, ice_q, ice_q + "    residual_correlation: -0.25\n"));
  const BankConfig c = load_bank_config(ok);
  EXPECT_EQ(c.modes[0].residual_correlation, 0.0);
  EXPECT_EQ(c.modes[1].residual_correlation, -0.25);
  EXPECT_TRUE(c.any_residual_correlation());
  EXPECT_FALSE(load_bank_config(write_file(test_directory() / "none.yaml", kValidBank)).any_residual_correlation());
  for (const std::string bad : {"1", "-1", "1.5", ".nan", "high"}) {
    expect_config_error(
        replace(kValidBank, ice_q, ice_q + "    residual_correlation: " + bad + "\n"),
        {"bank.yaml:23: modes[1].residual_correlation", bad == "high" ? "expected a number" : "(-1, 1)"});
  }
}

// Each input's range over the steps a mode's fit used: input names of the
// bank, [lowest, highest] finite and in order.
TEST(BankConfig, FittedInputRangesNameInputsAndHoldTheirLowestFirst) {
  const std::string ice_q = "    Q: [[0.02, 0], [0, 0.02]]\n";
  const auto with = [&](const std::string& ranges) {
    return replace(kValidBank, ice_q, ice_q + "    fitted_inputs: " + ranges + "\n");
  };
  const BankConfig c =
      load_bank_config(write_file(test_directory() / "ranges.yaml", with("{phi_dot_L: [-1.5, 2], phi_dot_R: [0, 0]}")));
  EXPECT_TRUE(c.modes[0].fitted_inputs.empty());
  ASSERT_EQ(c.modes[1].fitted_inputs.size(), 2u);
  EXPECT_EQ(c.modes[1].fitted_inputs.at("phi_dot_L").lowest, -1.5);
  EXPECT_EQ(c.modes[1].fitted_inputs.at("phi_dot_L").highest, 2.0);
  EXPECT_EQ(c.modes[1].fitted_inputs.at("phi_dot_R").highest, 0.0);
  EXPECT_EQ(c.modes[1].fitted_inputs_line, 23);
  // An input left out has no range.
  EXPECT_EQ(load_bank_config(write_file(test_directory() / "one.yaml", with("{phi_dot_R: [0, 1]}")))
                .modes[1]
                .fitted_inputs.count("phi_dot_L"),
            0u);
  expect_config_error(with("{v: [0, 1]}"),
                      {"bank.yaml:23: modes[1].fitted_inputs.v", "'v' is not an input (inputs: phi_dot_L, phi_dot_R)"});
  expect_config_error(with("{phi_dot_L: [2, 1]}"),
                      {"bank.yaml:23: modes[1].fitted_inputs.phi_dot_L", "the lowest first, got [2, 1]"});
  expect_config_error(with("{phi_dot_L: [0, .inf]}"), {"modes[1].fitted_inputs.phi_dot_L", "finite"});
  expect_config_error(with("{phi_dot_L: [0, 1, 2]}"), {"modes[1].fitted_inputs.phi_dot_L", "[lowest, highest]"});
  expect_config_error(with("{phi_dot_L: 1}"), {"modes[1].fitted_inputs.phi_dot_L", "[lowest, highest]"});
  expect_config_error(with("{phi_dot_L: [0, fast]}"), {"modes[1].fitted_inputs.phi_dot_L[1]", "expected a number"});
  expect_config_error(with("[0, 1]"), {"bank.yaml:23: modes[1].fitted_inputs", "mapping from input name"});
}

TEST(BankConfig, LikelihoodWeightIsInZeroToOne) {
  const auto ok = write_file(test_directory() / "ok.yaml", "likelihood_weight: 0.25\n" + kValidBank);
  EXPECT_EQ(load_bank_config(ok).likelihood_weight, 0.25);
  EXPECT_EQ(load_bank_config(write_file(test_directory() / "none.yaml", kValidBank)).likelihood_weight, 1.0);
  expect_config_error("likelihood_weight: 0\n" + kValidBank, {"bank.yaml:1: likelihood_weight", "in (0, 1]"});
  expect_config_error("likelihood_weight: 1.5\n" + kValidBank, {"bank.yaml:1: likelihood_weight", "in (0, 1]"});
  expect_config_error("likelihood_weight: .nan\n" + kValidBank, {"likelihood_weight"});
}

TEST(BankConfig, InnovationGateIsAProbability) {
  const auto ok = write_file(test_directory() / "ok.yaml", "innovation_gate: 0.9999\n" + kValidBank);
  EXPECT_EQ(load_bank_config(ok).innovation_gate, 0.9999);
  EXPECT_EQ(load_bank_config(write_file(test_directory() / "none.yaml", kValidBank)).innovation_gate, 0.0);
  expect_config_error("innovation_gate: 1\n" + kValidBank, {"bank.yaml:1: innovation_gate", "in (0, 1)"});
  expect_config_error("innovation_gate: -0.5\n" + kValidBank, {"innovation_gate"});
}

}  // namespace
}  // namespace skidimm
