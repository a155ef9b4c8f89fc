#include "skidimm/fitting/tuning.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <set>

#include "core/temp_files.h"

namespace skidimm {
namespace fitting {
namespace {

using skidimm_test::test_directory;
using skidimm_test::write_file;

TEST(GroupedFolds, LeaveOneOutAndStratifiedGroupsPartitionTheLogs) {
  const std::vector<std::string> classes{"ice", "ice", "ice", "snow", "snow", "sand", "sand", "sand", "sand"};
  std::vector<int> all(classes.size());
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
  const auto loo = grouped_folds(all, classes, 0);
  ASSERT_EQ(loo.size(), all.size());
  for (std::size_t i = 0; i < loo.size(); ++i) EXPECT_EQ(loo[i], std::vector<int>{static_cast<int>(i)});

  const auto three = grouped_folds(all, classes, 3);
  ASSERT_EQ(three.size(), 3u);
  std::multiset<int> seen;
  for (const auto& fold : three) {
    seen.insert(fold.begin(), fold.end());
    std::set<std::string> fold_classes;
    for (int i : fold) fold_classes.insert(classes[static_cast<std::size_t>(i)]);
    EXPECT_GE(fold_classes.size(), 2u) << "classes are dealt out, not left in one fold";
  }
  EXPECT_EQ(seen, std::multiset<int>(all.begin(), all.end())) << "every log in exactly one fold";
  // Inner folds of a subset stay inside it.
  const std::vector<int> subset{0, 2, 3, 5, 8};
  for (const auto& fold : grouped_folds(subset, classes, 2)) {
    for (int i : fold) EXPECT_NE(std::find(subset.begin(), subset.end(), i), subset.end());
  }
  EXPECT_EQ(grouped_folds(subset, classes, 10).size(), subset.size()) << "more folds than logs: one log each";
}

TEST(TuningSummary, AveragesLogsWithinAClassThenClasses) {
  std::vector<LogScore> scores(4);
  scores[0] = {"a", "ice", 1.0, -0.1, 10, ""};
  scores[1] = {"b", "ice", 0.5, -0.5, 100, ""};
  scores[2] = {"c", "ice", 0.0, -3.0, 10, ""};
  scores[3] = {"d", "snow", 0.2, -1.0, 10, ""};
  const Summary s = summarize(scores);
  EXPECT_DOUBLE_EQ(s.class_accuracy.at("ice"), 0.5);
  EXPECT_DOUBLE_EQ(s.class_log_probability.at("ice"), -3.6 / 3.0);
  EXPECT_DOUBLE_EQ(s.accuracy, 0.35);
  EXPECT_DOUBLE_EQ(s.mean_log_probability, (-1.2 - 1.0) / 2.0);
}

const std::string kBank = R"(name: tune_test
states: [V, omega]
inputs: [phi_dot_L, phi_dot_R]
measurement: {observe: [V, omega], R: {std: [0.02, 0.03]}}
transition: {stay: 0.99}
initial: {covariance: {std: [1, 1]}}
modes:
  - {name: a, model: ltc_linear, params: {A: [[-1, 0], [0, -1]], B: [[0.1, 0.1], [-0.1, 0.1]]}, Q: {diagonal: [0.01, 0.02]}}
  - {name: b, model: ltc_linear, params: {A: [[-2, 0], [0, -2]], B: [[0.2, 0.2], [-0.2, 0.2]]}, Q: {diagonal: [0.03, 0.04]}}
)";

TEST(TunedSettings, ApplyScalesFittedValuesAndSetsTheTransitionAndFloor) {
  Bank bank = Bank::load(write_file(test_directory() / "b.yaml", kBank), {SKIDIMM_PLUGIN_DIR});
  bank.config.modes[1].r = Eigen::Vector2d(0.01, 0.0025).asDiagonal();  // mode b's own R: scaled alike
  FittedValues fitted = values_of(bank);
  fitted.parameters[1][0] = -3.0;
  TunedSettings s;
  s.r_scale = 4.0;
  s.r_component = Eigen::Vector2d(1.0, 2.0);
  s.q_scale = 10.0;
  s.q_mode = Eigen::Vector2d(1.0, 0.5);
  s.dwell_seconds = 20.0;
  s.probability_floor = 1e-4;
  s.likelihood_weight = 0.25;
  apply(fitted, s, &bank);
  Eigen::VectorXd p(8);
  bank.models[1]->get_parameters(p);
  EXPECT_EQ(p[0], -3.0);
  EXPECT_NEAR(bank.config.measurement.r(0, 0), 4.0 * 0.0004, 1e-15);
  EXPECT_NEAR(bank.config.measurement.r(1, 1), 4.0 * 4.0 * 0.0009, 1e-15);
  EXPECT_EQ(bank.config.modes[0].r.size(), 0);
  EXPECT_NEAR(bank.config.modes[1].r(0, 0), 4.0 * 0.01, 1e-15);
  EXPECT_NEAR(bank.config.modes[1].r(1, 1), 4.0 * 4.0 * 0.0025, 1e-15);
  EXPECT_NEAR(bank.config.modes[0].q_intensity(1, 1), 10.0 * 0.02, 1e-15);
  EXPECT_NEAR(bank.config.modes[1].q_intensity(0, 0), 5.0 * 0.03, 1e-15);
  EXPECT_EQ(bank.config.transition.kind, TransitionConfig::Kind::kDwellTimes);
  EXPECT_EQ(bank.config.transition.dwell_seconds, Eigen::Vector2d(20.0, 20.0));
  EXPECT_EQ(bank.config.mode_probability_floor, 1e-4);
  EXPECT_EQ(bank.config.likelihood_weight, 0.25);
  EXPECT_EQ(
      s.describe(bank.config),
      "objective , R x 4, R[omega] std x 2, Q x 10, Q[b] x 0.5, dwell 20 s, floor 0.0001, likelihood weight 0.25");
  EXPECT_THROW(knob_from_string("r_scale"), Error);
  EXPECT_EQ(knob_from_string("q-modes"), Knob::kQModes);
  EXPECT_EQ(knob_from_string("likelihood-weight"), Knob::kLikelihoodWeight);
}

}  // namespace
}  // namespace fitting
}  // namespace skidimm
