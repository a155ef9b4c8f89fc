#include "skidimm/fitting/bank_writer.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "core/temp_files.h"
#include "skidimm/errors.h"

namespace skidimm {
namespace fitting {
namespace {

using skidimm_test::read_file;
using skidimm_test::test_directory;
using skidimm_test::write_file;
using ::testing::HasSubstr;

const std::string kBank = R"(# A hand-written bank: this comment must survive appends.
name: writer_test
states: [V, omega]
inputs: [phi_dot_L, phi_dot_R]
measurement: {observe: [V, omega], R: {std: [0.02, 0.02]}}   # sensor noise
transition: {stay: 0.99}
initial: {covariance: {std: [1, 1]}}
modes:
  # the asphalt mode
  - name: asphalt
    model: ltc_linear
    params: {A: [[-5, 0], [0, -4]], B: [[0.4, 0.4], [-0.8, 0.8]]}
    Q: {diagonal: [0.01, 0.01]}

)";

// A mode entry as a fit leaves it: ltc_linear with Q = q I.
ModeConfig mode_named(const std::string& name, double q = 0.02) {
  ModeConfig mode;
  mode.name = name;
  mode.model = "ltc_linear";
  mode.q_intensity = Eigen::Matrix2d::Identity() * q;
  return mode;
}

TEST(BankWriter, FormatsParametersByKeyAndShape) {
  const Bank bank = Bank::load(write_file(test_directory() / "b.yaml", kBank), {SKIDIMM_PLUGIN_DIR});
  EXPECT_EQ(format_parameters(*bank.models[0], sdk::ParameterScope::kMode),
            "{A: [[-5, 0], [0, -4]], B: [[0.4, 0.4], [-0.8, 0.8]]}");
  EXPECT_EQ(format_parameters(*bank.models[0], sdk::ParameterScope::kBank), "{}");
  EXPECT_EQ(format_matrix(Eigen::MatrixXd::Constant(1, 1, 0.123456789)), "0.1234568");
}

// A fit at another rate writes the bank's sampling block anew: what it said
// of gaps and rows out of order stays said.
TEST(BankWriter, TheSamplingBlockKeepsEveryKey) {
  SamplingConfig sampling;
  EXPECT_EQ(format_sampling_block(sampling), "");
  sampling.rate = 2.0;
  sampling.max_gap = 30.0;
  sampling.skip_gaps = true;
  sampling.skip_out_of_order = true;
  EXPECT_EQ(format_sampling_block(sampling),
            "sampling:\n  rate: 2\n  max_gap: 30\n  skip_gaps: true\n  skip_out_of_order: true\n");
}

TEST(BankWriter, KeepsWhatTheBankGaveThatWasNotFitted) {
  const Bank bank = Bank::load(write_file(test_directory() / "b.yaml", kBank), {SKIDIMM_PLUGIN_DIR});
  sdk::ParameterSet original;
  original.set_text("features", {"abs(v)", "say \"hi\""});
  original.set("offset", Eigen::Vector2d(1.5, -2));
  EXPECT_EQ(format_parameters(*bank.models[0], sdk::ParameterScope::kMode, original),
            "{A: [[-5, 0], [0, -4]], B: [[0.4, 0.4], [-0.8, 0.8]], features: [\"abs(v)\", \"say \\\"hi\\\"\"], "
            "offset: [1.5, -2]}")
      << "the model's parameters in its table's order, then the rest by name";
}

TEST(BankWriter, NamesThatYamlWouldReadOtherwiseAreQuoted) {
  const auto file = write_file(test_directory() / "b.yaml", kBank);
  Bank bank = Bank::load(file, {SKIDIMM_PLUGIN_DIR});
  append_mode_to_bank(file, format_mode_entry(mode_named("ice: slick #1"), *bank.models[0]));
  EXPECT_THAT(read_file(file), HasSubstr("  - name: \"ice: slick #1\"\n"));
  EXPECT_EQ(load_bank_config(file).modes[1].name, "ice: slick #1");
  // A name with a line break cannot add keys to the bank: the result does not validate, nothing is written.
  const std::string before = read_file(file);
  EXPECT_THROW(append_mode_to_bank(file, format_mode_entry(mode_named("ice\n    model: x"), *bank.models[0])),
               ConfigError);
  EXPECT_EQ(read_file(file), before);
}

TEST(BankWriter, AppendKeepsCommentsAndTheResultLoads) {
  const auto file = write_file(test_directory() / "b.yaml", kBank);
  Bank bank = Bank::load(file, {SKIDIMM_PLUGIN_DIR});
  append_mode_to_bank(file, format_mode_entry(mode_named("ice"), *bank.models[0], {"fitted on ice"}));
  const std::string text = read_file(file);
  EXPECT_THAT(text, HasSubstr("# A hand-written bank: this comment must survive appends."));
  EXPECT_THAT(text, HasSubstr("# sensor noise"));
  EXPECT_THAT(text, HasSubstr("  # fitted on ice\n  - name: ice\n    model: ltc_linear\n"));
  const BankConfig config = load_bank_config(file);
  ASSERT_EQ(config.num_modes(), 2);
  EXPECT_EQ(config.modes[1].name, "ice");
  EXPECT_DOUBLE_EQ(config.modes[1].q_intensity(1, 1), 0.02);
}

// A mode's own R is written after its Q and loads back; a mode without one
// writes none.
TEST(BankWriter, AModesOwnMeasurementNoiseLoadsBack) {
  const auto file = write_file(test_directory() / "b.yaml", kBank);
  Bank bank = Bank::load(file, {SKIDIMM_PLUGIN_DIR});
  Eigen::Matrix2d r;
  r << 0.0009, 0.0002, 0.0002, 0.0016;
  ModeConfig own_r = mode_named("ice");
  own_r.r = r;
  const std::string entry = format_mode_entry(own_r, *bank.models[0]);
  EXPECT_THAT(entry, HasSubstr("    R: [[0.0009, 0.0002], [0.0002, 0.0016]]\n"));
  own_r.r = Eigen::Vector2d(0.01, 0.04).asDiagonal().toDenseMatrix();
  EXPECT_THAT(format_mode_entry(own_r, *bank.models[0]), HasSubstr("    R: {diagonal: [0.01, 0.04]}\n"));
  EXPECT_THAT(format_mode_entry(mode_named("ice"), *bank.models[0]), ::testing::Not(HasSubstr("R:")));
  append_mode_to_bank(file, entry);
  const BankConfig config = load_bank_config(file);
  EXPECT_EQ(config.modes[0].r.size(), 0);
  EXPECT_TRUE(config.modes[1].r.isApprox(r));
}

TEST(BankWriter, AModesFitConditionIsKept) {
  Bank bank = Bank::load(write_file(test_directory() / "b.yaml", kBank), {SKIDIMM_PLUGIN_DIR});
  ModeConfig turning_mode = mode_named("ice_turning");
  turning_mode.fit_when = "abs(phi_dot_R - phi_dot_L) > 0.5";
  const std::string turning = format_mode_entry(turning_mode, *bank.models[0]);
  EXPECT_THAT(turning, HasSubstr("    fit_when: \"abs(phi_dot_R - phi_dot_L) > 0.5\"\n"));
  const std::string straight = format_mode_entry(mode_named("ice_straight"), *bank.models[0]);
  const std::string head = kBank.substr(0, kBank.find("modes:"));
  const auto file =
      write_file(test_directory() / "classes.yaml",
                 head + "classes: {ice: [ice_turning, ice_straight]}\nmodes:\n" + turning + straight);
  EXPECT_EQ(load_bank_config(file).modes[0].fit_when, "abs(phi_dot_R - phi_dot_L) > 0.5");
}

// The inputs' ranges over the fitted steps are written in the bank's input
// order, rounded outward to the bank's 7 digits so that they still hold every
// fitted step, and load back; a mode without them writes none.
TEST(BankWriter, FittedInputRangesLoadBack) {
  const auto file = write_file(test_directory() / "b.yaml", kBank);
  Bank bank = Bank::load(file, {SKIDIMM_PLUGIN_DIR});
  ModeConfig ice = mode_named("ice");
  ice.fitted_inputs["phi_dot_R"] = {-0.25, 3.5};
  ice.fitted_inputs["phi_dot_L"] = {0.12345678, 4.0000000001};
  const std::string entry = format_mode_entry(ice, *bank.models[0], {}, {}, bank.config.input_names);
  EXPECT_THAT(entry, HasSubstr("    fitted_inputs: {phi_dot_L: [0.1234567, 4.000001], phi_dot_R: [-0.25, 3.5]}\n"));
  EXPECT_THAT(format_mode_entry(mode_named("ice"), *bank.models[0]), ::testing::Not(HasSubstr("fitted_inputs")));
  append_mode_to_bank(file, entry);
  const BankConfig config = load_bank_config(file);
  EXPECT_TRUE(config.modes[0].fitted_inputs.empty());
  ASSERT_EQ(config.modes[1].fitted_inputs.size(), 2u);
  EXPECT_EQ(config.modes[1].fitted_inputs.at("phi_dot_L").lowest, 0.1234567);
  EXPECT_EQ(config.modes[1].fitted_inputs.at("phi_dot_R").highest, 3.5);
}

TEST(BankWriter, AnAppendThatWouldBreakTheBankChangesNothing) {
  const auto file = write_file(test_directory() / "b.yaml", kBank);
  Bank bank = Bank::load(file, {SKIDIMM_PLUGIN_DIR});
  try {
    append_mode_to_bank(file, format_mode_entry(mode_named("asphalt", 1.0), *bank.models[0]));
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr("the result would not be a valid bank, nothing was written"));
    EXPECT_THAT(e.what(), HasSubstr("'asphalt' appears twice"));
  }
  EXPECT_EQ(read_file(file), kBank);
  EXPECT_FALSE(std::filesystem::exists(file.string() + ".tmp"));
}

TEST(BankWriter, WritesABankFromATemplateWithANewHeaderAndModes) {
  const auto dir = test_directory();
  const auto file = write_file(dir / "template.yaml", kBank);
  write_bank_from_template(
      file, dir / "out.yaml", {"Written by a test"},
      {{"modes", "modes:\n  - name: grass\n    model: ltc_linear\n"
                 "    params: {A: [[-3, 0], [0, -3]], B: [[0.3, 0.3], [-0.5, 0.5]]}\n    Q: [[0.02, 0], [0, 0.02]]\n"}});
  const std::string text = read_file(dir / "out.yaml");
  EXPECT_EQ(text.rfind("# Written by a test\nname: writer_test\n", 0), 0u) << text;
  EXPECT_THAT(text, HasSubstr("# sensor noise"));
  EXPECT_THAT(text, ::testing::Not(HasSubstr("asphalt")));
  EXPECT_EQ(load_bank_config(dir / "out.yaml").modes[0].name, "grass");
}

TEST(BankWriter, MeasurementTransitionFloorAndWeightBlocksLoadBackToTheSameValues) {
  const auto dir = test_directory();
  const auto file = write_file(dir / "template.yaml", kBank);
  BankConfig config = load_bank_config(file);
  config.measurement.r << 0.0004, 0.0001, 0.0001, 0.0009;  // correlated
  config.transition.kind = TransitionConfig::Kind::kDwellTimes;
  config.transition.dwell_seconds = Eigen::VectorXd::Constant(1, 42.5);
  config.mode_probability_floor = 1e-4;
  EXPECT_EQ(format_likelihood_weight_block(config), "");  // 1, the default: no key
  config.likelihood_weight = 0.125;
  EXPECT_EQ(format_measurement_block(config), "measurement:\n  observe: [V, omega]\n  R: [[0.0004, 0.0001], [0.0001, 0.0009]]\n");
  write_bank_from_template(file, dir / "out.yaml", {"tuned"},
                           {{"measurement", format_measurement_block(config)},
                            {"transition", format_transition_block(config)},
                            {"mode_probability_floor", format_floor_block(config)},
                            {"likelihood_weight", format_likelihood_weight_block(config)}});
  const BankConfig back = load_bank_config(dir / "out.yaml");
  EXPECT_EQ(back.likelihood_weight, 0.125);
  EXPECT_EQ(back.measurement.r, config.measurement.r);
  EXPECT_EQ(back.measurement.h, config.measurement.h);
  EXPECT_EQ(back.transition.kind, TransitionConfig::Kind::kDwellTimes);
  EXPECT_EQ(back.transition.dwell_seconds[0], 42.5);
  EXPECT_EQ(back.mode_probability_floor, 1e-4);
  EXPECT_THAT(read_file(dir / "out.yaml"), HasSubstr("  # the asphalt mode"));  // the rest is kept
  // A general H is written as H with names.
  config.measurement.h << 1, 0.5, 0, 1;
  config.measurement.names = {"mixed", "omega"};
  config.measurement.r = Eigen::Matrix2d::Identity() * 0.01;
  EXPECT_EQ(format_measurement_block(config),
            "measurement:\n  H: [[1, 0.5], [0, 1]]\n  names: [mixed, omega]\n  R: {diagonal: [0.01, 0.01]}\n");

  // Measured outputs are written as `outputs:` after the state rows, and a
  // tuned bank reads back with the same rows (tune rewrites this block).
  std::string with_outputs = kBank;
  with_outputs.replace(with_outputs.find("observe: [V, omega]"), 19, "observe: [V], outputs: [omega]");
  const auto outputs_file = write_file(dir / "outputs.yaml", with_outputs);
  const BankConfig outputs = load_bank_config(outputs_file);
  ASSERT_EQ(outputs.measurement.outputs, std::vector<std::string>{"omega"});
  EXPECT_EQ(format_measurement_block(outputs),
            "measurement:\n  observe: [V]\n  outputs: [omega]\n  R: {diagonal: [0.0004, 0.0004]}\n");
  write_bank_from_template(outputs_file, dir / "outputs_out.yaml", {"tuned"},
                           {{"measurement", format_measurement_block(outputs)}});
  const BankConfig outputs_back = load_bank_config(dir / "outputs_out.yaml");
  EXPECT_EQ(outputs_back.measurement.outputs, outputs.measurement.outputs);
  EXPECT_EQ(outputs_back.measurement.h, outputs.measurement.h);
  EXPECT_EQ(outputs_back.measurement.names, outputs.measurement.names);
}

}  // namespace
}  // namespace fitting
}  // namespace skidimm
