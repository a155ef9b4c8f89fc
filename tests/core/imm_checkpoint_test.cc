// Imm::checkpoint / restore and checkpoint files: a filter stopped after any
// step and restored (through the file's text) in a new Imm runs on exactly
// as the one that never stopped, for every part of the engine that carries
// memory from step to step.
#include "skidimm/engine/imm_checkpoint.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "core/temp_files.h"
#include "skidimm/config/bank.h"
#include "skidimm/engine/decision.h"
#include "skidimm/engine/imm.h"
#include "skidimm/errors.h"
#include "skidimm/io/checkpoint_file.h"
#include "skidimm/io/log_reader.h"

namespace skidimm {
namespace {
namespace imm_checkpoint_test {

using skidimm_test::test_directory;
using skidimm_test::write_file;
using ::testing::HasSubstr;

const std::filesystem::path kSource = SKIDIMM_SOURCE_DIR;
const std::filesystem::path kBoreal = std::filesystem::path(SKIDIMM_SHARED_DATA_DIR) / "borealtc";

std::string read_text(const std::filesystem::path& file) {
  std::ifstream in(file);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

// ltc_terrains with every part of the engine that remembers something
// between steps: per-mode dwell times (the chain's anchors), correlated
// innovations, the unknown hypothesis, a Student-t likelihood and the
// extrapolation discount (the bank records its modes' fitted inputs).
std::filesystem::path bank_with_every_memory(const std::filesystem::path& dir) {
  std::string text = read_text(kSource / "configs" / "ltc_terrains.yaml");
  text = replaced(text, "  mean_dwell_time: 10.0",
                  "  mean_dwell_time: {asphalt: 20, grass: 10, crushed_concrete: 5}\n"
                  "likelihood_dof: 6\n"
                  "extrapolation_scale: 0.5\n"
                  "unknown: {inflation: 30, enter: 0.02, leave: 0.2}");
  for (const char* mode : {"asphalt", "grass", "crushed_concrete"}) {
    const std::string line = std::string("  - name: ") + mode + "\n";
    text = replaced(text, line, line + "    residual_correlation: 0.6\n");
  }
  const std::filesystem::path file = dir / "every_memory.yaml";
  write_file(file, text);
  return file;
}

struct Sample {
  double t;
  Eigen::VectorXd u, z;
};

std::vector<Sample> read_log(const BankConfig& config, const std::vector<LogFile>& files) {
  LogReader reader(config, files);
  std::vector<Sample> out;
  for (LogSample s; reader.next(&s);) out.push_back({s.t, s.u, s.z});
  return out;
}

// Bit for bit, NaN equal to NaN.
bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0 || (std::isnan(a) && std::isnan(b)); }

template <typename Matrix>
bool same_bits(const Matrix& a, const Matrix& b) {
  if (a.rows() != b.rows() || a.cols() != b.cols()) return false;
  for (Eigen::Index i = 0; i < a.size(); ++i) {
    if (!same_bits(a.data()[i], b.data()[i])) return false;
  }
  return true;
}

void expect_same_estimate(const ImmEstimate& a, const ImmEstimate& b, std::size_t step) {
  ASSERT_TRUE(same_bits(a.t, b.t)) << "step " << step;
  ASSERT_EQ(a.status, b.status) << "step " << step;
  ASSERT_EQ(a.num_measured, b.num_measured) << "step " << step;
  ASSERT_EQ(a.num_rejected_modes, b.num_rejected_modes) << "step " << step;
  ASSERT_EQ(a.num_gated_modes, b.num_gated_modes) << "step " << step;
  ASSERT_TRUE(same_bits(a.mode_probabilities, b.mode_probabilities)) << "step " << step;
  ASSERT_TRUE(same_bits(a.unknown_probability, b.unknown_probability)) << "step " << step;
  ASSERT_TRUE(same_bits(a.log_likelihoods, b.log_likelihoods)) << "step " << step;
  ASSERT_TRUE(same_bits(a.nis, b.nis)) << "step " << step;
  ASSERT_EQ(a.mode_failures, b.mode_failures) << "step " << step;
  ASSERT_EQ(a.failure_reasons, b.failure_reasons) << "step " << step;
  ASSERT_EQ(a.mode_states.size(), b.mode_states.size());
  for (std::size_t j = 0; j < a.mode_states.size(); ++j) {
    ASSERT_TRUE(same_bits(a.mode_states[j], b.mode_states[j])) << "step " << step << " mode " << j;
    ASSERT_TRUE(same_bits(a.mode_covariances[j], b.mode_covariances[j])) << "step " << step << " mode " << j;
  }
  ASSERT_TRUE(same_bits(a.state, b.state)) << "step " << step;
  ASSERT_TRUE(same_bits(a.covariance, b.covariance)) << "step " << step;
  ASSERT_EQ(a.most_likely_mode, b.most_likely_mode) << "step " << step;
}

// Runs `samples` through one Imm and decision, and again stopping after
// each step in `stops`: a checkpoint through its file's text, restored in a
// new Imm and decision of a freshly loaded bank. Every step after a stop
// must be the uninterrupted run's, bit for bit, and so must each decision.
// Returns the checkpoints.
std::vector<ImmCheckpoint> expect_restored_runs_on(const std::filesystem::path& bank_file,
                                                   const std::vector<LogFile>& files,
                                                   const std::vector<std::size_t>& stops,
                                                   ImmKernelChoice kernel = ImmKernelChoice::kFastest) {
  const Bank bank = Bank::load(bank_file);
  const std::vector<Sample> samples = read_log(bank.config, files);
  std::vector<ImmCheckpoint> checkpoints;
  EXPECT_GT(samples.size(), stops.back());
  Imm whole(Bank::load(bank_file), kernel);
  ModeDecision whole_decision(bank.config);
  std::vector<ImmEstimate> expected;
  std::vector<int> expected_decisions;
  for (const Sample& s : samples) {
    expected.push_back(whole.step(s.t, s.u, s.z));
    expected_decisions.push_back(
        whole_decision.update(s.t, expected.back().mode_probabilities, expected.back().measured()));
  }
  auto imm = std::make_unique<Imm>(Bank::load(bank_file), kernel);
  auto decision = std::make_unique<ModeDecision>(bank.config);
  std::size_t next_stop = 0;
  for (std::size_t k = 0; k < samples.size(); ++k) {
    const ImmEstimate& e = imm->step(samples[k].t, samples[k].u, samples[k].z);
    const int decided = decision->update(samples[k].t, e.mode_probabilities, e.measured());
    expect_same_estimate(e, expected[k], k);
    EXPECT_EQ(decided, expected_decisions[k]) << "step " << k;
    if (::testing::Test::HasFatalFailure()) return checkpoints;
    if (next_stop < stops.size() && k == stops[next_stop]) {
      ++next_stop;
      ImmCheckpoint checkpoint = imm->checkpoint();
      checkpoint.decision = decision->memory();
      const std::string text = checkpoint_text(checkpoint);
      const ImmCheckpoint read = parse_checkpoint(text, "checkpoint.yaml");
      EXPECT_EQ(checkpoint_text(read), text) << "the text reads back to itself";
      imm = std::make_unique<Imm>(Bank::load(bank_file), kernel);
      imm->restore(read);
      expect_same_estimate(imm->estimate(), expected[k], k);
      decision = std::make_unique<ModeDecision>(bank.config);
      decision->restore(*read.decision);
      EXPECT_EQ(decision->decision(), expected_decisions[k]);
      checkpoints.push_back(read);
    }
  }
  EXPECT_EQ(next_stop, stops.size());
  return checkpoints;
}

TEST(ImmCheckpoint, RestoredLtcBankRunsOnBitForBit) {
  expect_restored_runs_on(kSource / "configs" / "ltc_terrains.yaml",
                          {kSource / "configs" / "examples" / "ltc_switching.csv"}, {0, 1, 2, 500, 777});
}

TEST(ImmCheckpoint, RestoredBankWithEveryMemoryRunsOnBitForBit) {
  const std::filesystem::path bank = bank_with_every_memory(test_directory());
  const ImmCheckpoint fresh = Imm::from_yaml(bank).checkpoint();
  EXPECT_EQ(fresh.innovations.size(), 3u);  // the memories are there to be kept
  EXPECT_EQ(fresh.transition_anchors.dt.size(), 4u);
  const std::vector<LogFile> log = {kSource / "configs" / "examples" / "ltc_switching.csv"};
  const std::vector<ImmCheckpoint> stops = expect_restored_runs_on(bank, log, {3, 250, 600, 1100});
  expect_restored_runs_on(bank, log, {5, 700}, ImmKernelChoice::kDynamic);
  // What was restored held memory: anchors made, innovations remembered,
  // some probability on the unknown hypothesis.
  ASSERT_EQ(stops.size(), 4u);
  const ImmCheckpoint& later = stops[2];
  EXPECT_GT(later.transition_anchors.uses, 0);
  bool remembered = false;
  for (const InnovationMemory& memory : later.innovations) remembered = remembered || memory.remembers;
  EXPECT_TRUE(remembered);
  EXPECT_GT(later.estimate.unknown_probability, 0.0);
}

TEST(ImmCheckpoint, RestoredStcBankWithPartialRowsRunsOnBitForBit) {
  // GPS in one row of five: stops after rows with and without it.
  expect_restored_runs_on(kSource / "configs" / "stc_slip16.yaml",
                          {kSource / "configs" / "examples" / "stc_switching.csv"}, {10, 11, 12, 13, 14, 400});
}

TEST(RealBorealTcData, ARestoredBundledBankRunsOnBitForBit) {
  // 9 features, parameter uncertainty, a fixed-state kernel, measurements
  // aggregated over multi-rate rows.
  const std::filesystem::path run = kBoreal / "SNOW";
  expect_restored_runs_on(kSource / "configs" / "borealtc" / "terrains.yaml", {run / "pro_01.csv", run / "imu_01.csv"},
                          {0, 20, 21, 50});
}

TEST(ImmCheckpoint, ABankOfOtherModesOrStatesIsRefusedAndLeavesTheImmAsItWas) {
  const std::filesystem::path ltc = kSource / "configs" / "ltc_terrains.yaml";
  Imm imm = Imm::from_yaml(ltc);
  imm.step(0.0, Eigen::Vector2d(1.0, 1.0), Eigen::Vector2d(0.1, 0.0));
  imm.step(0.02, Eigen::Vector2d(1.0, 1.0), Eigen::Vector2d(0.2, 0.0));
  const ImmCheckpoint good = imm.checkpoint();
  const std::string before = checkpoint_text(good);
  const auto refused = [&](ImmCheckpoint bad, const std::string& why) {
    try {
      imm.restore(bad);
      ADD_FAILURE() << "restored: " << why;
    } catch (const Error& e) {
      EXPECT_THAT(e.what(), HasSubstr(why));
    }
    EXPECT_EQ(checkpoint_text(imm.checkpoint()), before) << "changed by a refused restore: " << why;
  };
  ImmCheckpoint other = good;
  other.mode_names[2] = "gravel";
  refused(other,
          "it was made by a bank of modes [asphalt, grass, gravel], this bank's are "
          "[asphalt, grass, crushed_concrete]");
  other = good;
  other.state_names = {"V", "omega", "psi"};
  refused(other, "bank of states [V, omega, psi]");
  other = good;
  other.measurement_rows = 3;
  refused(other, "measuring 3 rows, this bank measures 2");
  other = good;
  other.estimate.mode_states[1][0] = std::nan("");
  refused(other, "a mode's state is not finite");
  other = good;
  other.estimate.mode_covariances[0].resize(3, 3);
  refused(other, "a mode's covariance is not 2 x 2");
  other = good;
  other.estimate.mode_probabilities[0] = -0.5;
  refused(other, "its mode probabilities are not probabilities");
  other = good;
  other.held_input.resize(3);
  refused(other, "the held input has 3 entries, expected 2");
  other = good;
  other.innovations.resize(2);
  refused(other, "the innovation memory has 2 entries, expected 3");

  // The same shape from another fit restores: a retuned bank keeps what
  // the filter knew.
  std::string text = read_text(ltc);
  text = replaced(text, "Q: [[0.00556329, 0], [0, 0.003817253]]", "Q: [[0.01, 0], [0, 0.01]]");
  const std::filesystem::path retuned = test_directory() / "retuned.yaml";
  write_file(retuned, text);
  Imm other_fit = Imm::from_yaml(retuned);
  other_fit.restore(good);
  EXPECT_EQ(other_fit.estimate().t, 0.02);
  EXPECT_EQ(other_fit.step(0.04, Eigen::Vector2d(1.0, 1.0), Eigen::Vector2d(0.2, 0.0)).status, StepStatus::kUpdated);
  // Before its first step an Imm's checkpoint restores to a first step.
  Imm fresh = Imm::from_yaml(ltc);
  fresh.restore(Imm::from_yaml(ltc).checkpoint());
  EXPECT_EQ(fresh.step(5.0, Eigen::Vector2d(1.0, 1.0), Eigen::Vector2d(0.1, 0.0)).status, StepStatus::kUpdated);
}

// What a hand-edited file could hold that the engine never makes, and that
// would otherwise poison later steps: refused, the Imm unchanged.
TEST(ImmCheckpoint, MemoryTheEngineNeverMakesIsRefused) {
  const std::filesystem::path dir = test_directory();
  const std::filesystem::path bank = bank_with_every_memory(dir);
  Imm imm = Imm::from_yaml(bank);
  const std::vector<Sample> samples = read_log(imm.config(), {kSource / "configs" / "examples" / "ltc_switching.csv"});
  for (std::size_t k = 0; k < 300; ++k) imm.step(samples[k].t, samples[k].u, samples[k].z);
  const ImmCheckpoint good = imm.checkpoint();
  const std::string before = checkpoint_text(good);
  const auto refused = [&](const ImmCheckpoint& bad, const std::string& why) {
    try {
      imm.restore(bad);
      ADD_FAILURE() << "restored: " << why;
    } catch (const Error& e) {
      EXPECT_THAT(e.what(), HasSubstr(why));
    }
    EXPECT_EQ(checkpoint_text(imm.checkpoint()), before) << why;
  };
  ImmCheckpoint bad = good;
  bad.innovations[0].remembers = true;
  bad.innovations[0].steps_since = 2147483647;  // would overflow as it counts on
  refused(bad, "a mode's innovation memory is malformed");
  bad = good;
  ASSERT_GE(bad.transition_anchors.dt[0], 0.0);
  bad.transition_anchors.dt[0] = 1.05e10;  // a uniformisation of billions of terms
  refused(bad, "a transition anchor is not one this chain makes");
  bad = good;
  bad.transition_anchors.dt.pop_back();
  bad.transition_anchors.used.pop_back();
  refused(bad, "it keeps 3 transition anchors, this chain 4");

  ModeDecision decision(imm.config());
  ModeDecision::Memory memory = decision.memory();
  memory.last_measured_t = std::nan("");  // would never go stale
  EXPECT_THROW(decision.restore(memory), Error);
  memory = decision.memory();
  memory.class_probabilities[1] = 1.5;
  EXPECT_THROW(decision.restore(memory), Error);
  memory = decision.memory();
  memory.decision = "gravel";
  try {
    decision.restore(memory);
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("the decision 'gravel' is none of the bank's classes"));
  }
}

// A checkpoint of a bank with a "none of these" hypothesis, restored into
// the same bank without one: the modes share what the hypothesis held, in
// proportion, and it is gone.
TEST(ImmCheckpoint, TheUnknownsShareGoesToTheModesOfABankWithoutIt) {
  const std::filesystem::path dir = test_directory();
  Imm with_unknown = Imm::from_yaml(bank_with_every_memory(dir));
  const std::vector<Sample> samples =
      read_log(with_unknown.config(), {kSource / "configs" / "examples" / "ltc_switching.csv"});
  for (std::size_t k = 0; k < 400; ++k) with_unknown.step(samples[k].t, samples[k].u, samples[k].z);
  const ImmCheckpoint checkpoint = with_unknown.checkpoint();
  ASSERT_GT(checkpoint.estimate.unknown_probability, 0.0);
  std::string text = read_text(dir / "every_memory.yaml");
  text = replaced(text, "unknown: {inflation: 30, enter: 0.02, leave: 0.2}", "");
  write_file(dir / "without_unknown.yaml", text);
  Imm without = Imm::from_yaml(dir / "without_unknown.yaml");
  without.restore(checkpoint);
  EXPECT_EQ(without.estimate().unknown_probability, 0.0);
  EXPECT_NEAR(without.estimate().mode_probabilities.sum(), 1.0, 1e-15);
  const Eigen::VectorXd expected =
      checkpoint.estimate.mode_probabilities / checkpoint.estimate.mode_probabilities.sum();
  EXPECT_TRUE(without.estimate().mode_probabilities.isApprox(expected, 1e-15));
  const ImmEstimate& next = without.step(samples[400].t, samples[400].u, samples[400].z);
  EXPECT_EQ(next.unknown_probability, 0.0);
  EXPECT_NEAR(next.mode_probabilities.sum(), 1.0, 1e-12);
}

TEST(CheckpointFile, IsWrittenWholeAndReadBackExactly) {
  const std::filesystem::path dir = test_directory();
  Imm imm = Imm::from_yaml(bank_with_every_memory(dir));
  imm.step(0.0, Eigen::Vector2d(1.0, 1.0), Eigen::Vector2d(0.1, 0.0));
  imm.step(0.02, Eigen::Vector2d(1.0, 1.5), Eigen::Vector2d(std::nan(""), 0.01));
  ImmCheckpoint checkpoint = imm.checkpoint();
  checkpoint.estimate.failure_reasons[1] = "a reason: with \"quotes\", a colon\nand a new line";
  checkpoint.estimate.log_likelihoods[0] = std::nan("");
  checkpoint.estimate.log_likelihoods[2] = -std::numeric_limits<double>::infinity();
  checkpoint.estimate.nis[0] = 4.9406564584124654e-324;  // the smallest subnormal
  const std::filesystem::path file = dir / "state.yaml";
  save_checkpoint(file, checkpoint);
  EXPECT_FALSE(std::filesystem::exists(file.string() + ".partial"));
  const ImmCheckpoint read = load_checkpoint(file);
  EXPECT_EQ(read.estimate.failure_reasons[1], checkpoint.estimate.failure_reasons[1]);
  EXPECT_TRUE(std::isnan(read.estimate.log_likelihoods[0]));
  EXPECT_EQ(read.estimate.log_likelihoods[2], -std::numeric_limits<double>::infinity());
  EXPECT_EQ(read.estimate.nis[0], 4.9406564584124654e-324);
  EXPECT_EQ(checkpoint_text(read), checkpoint_text(checkpoint));
  EXPECT_FALSE(read.decision.has_value());
}

TEST(CheckpointFile, AFileNotAsWrittenIsAnErrorNamingItsLineAndField) {
  Imm imm = Imm::from_yaml(kSource / "configs" / "ltc_terrains.yaml");
  imm.step(0.0, Eigen::Vector2d(1.0, 1.0), Eigen::Vector2d(0.1, 0.0));
  const std::string text = checkpoint_text(imm.checkpoint());
  const auto error_of = [](const std::string& broken) -> std::string {
    try {
      parse_checkpoint(broken, "state.yaml");
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "no error";
  };
  EXPECT_THAT(error_of("a: [1, 2"), HasSubstr("state.yaml:"));
  EXPECT_THAT(error_of("name: ltc_terrains\n"), HasSubstr("not a checkpoint written by skidimm"));
  EXPECT_THAT(error_of(replaced(text, "skidimm_checkpoint: 1", "skidimm_checkpoint: 7")),
              HasSubstr("version 7 is not one this skidimm reads"));
  std::string bad = replaced(text, "status: updated", "status: fine");
  EXPECT_THAT(error_of(bad), HasSubstr("estimate.status: not a step status: 'fine'"));
  const std::size_t line =
      static_cast<std::size_t>(std::count(text.begin(), text.begin() + text.find("status:"), '\n') + 1);
  EXPECT_THAT(error_of(bad), HasSubstr("state.yaml:" + std::to_string(line) + ":"));
  bad = replaced(text, "started: true", "started: yes please");
  EXPECT_THAT(error_of(bad), HasSubstr("started: expected true or false"));
  bad = replaced(text, "measurement_rows: 2", "measurement_rows: 2\n  colour: blue");
  EXPECT_THAT(error_of(bad), HasSubstr("bank.colour: unknown key"));
  const std::size_t held = text.find("held_input: [");
  bad = text.substr(0, held) + "held_input: [1, x]" + text.substr(text.find('\n', held));
  EXPECT_THAT(error_of(bad), HasSubstr("held_input[1]: expected a number, got 'x'"));
  bad = text.substr(0, held) + "held_input: [1]" + text.substr(text.find('\n', held));
  EXPECT_THAT(error_of(bad), HasSubstr("held_input: expected 2 entries, got 1"));
  // A count beyond an int does not wrap round to a small one.
  bad = replaced(text, "measurement_rows: 2", "measurement_rows: 4294967298");
  EXPECT_THAT(error_of(bad), HasSubstr("bank.measurement_rows: expected a whole number from"));
  try {
    load_checkpoint(test_directory() / "none.yaml");
    ADD_FAILURE();
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr("no such checkpoint file"));
  }
}

}  // namespace imm_checkpoint_test
}  // namespace
}  // namespace skidimm
