#include "skidimm/evaluation/mode_metrics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "skidimm/errors.h"
#include "skidimm/evaluation/consistency.h"
#include "skidimm/evaluation/log_evaluation.h"

namespace skidimm {
namespace evaluation {
namespace {

// One row per second unless given: (t, truth, estimate, p(truth)).
std::vector<LabelledStep> steps(std::initializer_list<LabelledStep> list) { return list; }

TEST(ModeMetrics, AccuracyConfusionAndProbabilityByTime) {
  // Rows at t = 0, 1, 3, 4: weights 1, 2, 1 and (last row) 1 s.
  const ModeMetrics m = compute_mode_metrics(
      steps({{0, "a", "a", 0.9}, {1, "a", "b", 0.4}, {3, "b", "b", 0.8}, {4, "b", "b", 0.6}}), {"a", "b"});
  EXPECT_DOUBLE_EQ(m.duration, 5.0);
  EXPECT_DOUBLE_EQ(m.correct, 1.0 + 1.0 + 1.0);
  EXPECT_DOUBLE_EQ(m.accuracy(), 0.6);
  EXPECT_DOUBLE_EQ(m.confusion.at("a").at("a"), 1.0);
  EXPECT_DOUBLE_EQ(m.confusion.at("a").at("b"), 2.0);
  EXPECT_DOUBLE_EQ(m.confusion.at("b").at("b"), 2.0);
  EXPECT_DOUBLE_EQ(m.mean_truth_probability(), (0.9 * 1 + 0.4 * 2 + 0.8 * 1 + 0.6 * 1) / 5.0);
}

// Time stamps near the largest double: each of two steps stands for 1e308 s,
// which sum past it. Every figure would be NaN; the error says why.
TEST(ModeMetrics, IntervalsThatDoNotSumToAFiniteTimeAreAnError) {
  try {
    compute_mode_metrics(steps({{0, "a", "a", 0.9}, {1e308, "a", "a", 0.9}}), {"a"});
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("do not sum to a finite time (time stamps from 0 to 1e+308 s)"),
              std::string::npos)
        << e.what();
  }
  // Near it but summing within it: figures as usual.
  const ModeMetrics m = compute_mode_metrics(steps({{0, "a", "a", 0.9}, {5e307, "a", "a", 0.9}}), {"a"});
  EXPECT_DOUBLE_EQ(m.duration, 1e308);
  EXPECT_DOUBLE_EQ(m.accuracy(), 1.0);
}

// Calibration by hand: rows at t = 0, 1, 3, 4, 5 (weights 1, 2, 1, 1, 1 s),
// estimate probabilities 0.95 (right), 0.92 (wrong), 0.55 (right), 0.58
// (wrong), and an "unknown" row, which is in no bin.
TEST(ModeMetrics, CalibrationBinsExpectedErrorAndBrierScore) {
  std::vector<LabelledStep> s = steps({{0, "a", "a", 0.95}, {1, "a", "b", 0.05}, {3, "b", "b", 0.55},
                                       {4, "b", "a", 0.42}, {5, "b", "unknown", 0.5}});
  const double p[] = {0.95, 0.92, 0.55, 0.58, 0.5};
  const double brier[] = {0.005, 1.7, 0.4, 0.5, 0.5};
  for (std::size_t k = 0; k < s.size(); ++k) {
    s[k].estimate_probability = s[k].estimate == "unknown" ? 0.0 : p[k];
    s[k].brier = brier[k];
  }
  const ModeMetrics m = compute_mode_metrics(s, {"a", "b"});
  const CalibrationBin& top = m.calibration[9];
  EXPECT_DOUBLE_EQ(top.seconds, 3.0);
  EXPECT_DOUBLE_EQ(top.correct, 1.0);
  EXPECT_DOUBLE_EQ(top.confidence, 0.95 + 2 * 0.92);
  const CalibrationBin& middle = m.calibration[5];
  EXPECT_DOUBLE_EQ(middle.seconds, 2.0);
  EXPECT_DOUBLE_EQ(middle.correct, 1.0);
  EXPECT_DOUBLE_EQ(middle.mean_confidence(), (0.55 + 0.58) / 2);
  for (int b : {0, 1, 2, 3, 4, 6, 7, 8}) EXPECT_EQ(m.calibration[static_cast<std::size_t>(b)].seconds, 0.0);
  // ECE over the 5 binned seconds: 3 |1/3 - 0.93| + 2 |1/2 - 0.565|.
  EXPECT_NEAR(m.expected_calibration_error(), (std::abs(1.0 - 2.79) + std::abs(1.0 - 1.13)) / 5.0, 1e-12);
  EXPECT_DOUBLE_EQ(m.confident_fraction(), 3.0 / 5.0);
  EXPECT_DOUBLE_EQ(m.confident_accuracy(), 1.0 / 3.0);
  EXPECT_NEAR(m.mean_brier(), (0.005 + 2 * 1.7 + 0.4 + 0.5 + 0.5) / 6.0, 1e-12);
  ModeMetrics twice = m;
  twice.merge(m);
  EXPECT_DOUBLE_EQ(twice.calibration[9].correct, 2.0);
  EXPECT_DOUBLE_EQ(twice.expected_calibration_error(), m.expected_calibration_error());
  EXPECT_TRUE(std::isnan(compute_mode_metrics(steps({{0, "a", "a", 0.5}, {1, "a", "a", 0.5}}), {"a"})
                             .confident_accuracy()));
}

// Modes a1, a2 and b, a1 and a2 making class A.
BankConfig modes_a1_a2_b() {
  BankConfig config;
  for (const char* name : {"a1", "a2", "b"}) {
    ModeConfig mode;
    mode.name = name;
    config.modes.push_back(mode);
  }
  config.classes.push_back(ClassConfig{"A", {0, 1}});
  return config;
}

// Modes a1 and a2 make class A, b its own: probabilities 0.5, 0.2, 0.3 are
// A 0.7, b 0.3. Brier for truth A: (0.7 - 1)^2 + 0.3^2; for a truth the bank
// cannot answer: 0.7^2 + 0.3^2 + 1.
TEST(ClassScorer, GivesTheEstimatesProbabilityAndTheBrierScoreOfAStep) {
  const BankConfig config = modes_a1_a2_b();
  const ClassScorer scorer(config);
  Eigen::VectorXd mu(3);
  mu << 0.5, 0.2, 0.3;
  const LabelledStep step = scorer.score(1.0, "A", mu);
  EXPECT_EQ(step.estimate, "A");
  EXPECT_DOUBLE_EQ(step.estimate_probability, 0.7);
  EXPECT_NEAR(step.brier, 0.09 + 0.09, 1e-15);
  EXPECT_NEAR(scorer.score(1.0, "a2", mu).brier, 0.18, 1e-15) << "a mode's label scores its class";
  EXPECT_NEAR(scorer.score(1.0, "gravel", mu).brier, 0.49 + 0.09 + 1.0, 1e-15);
  EXPECT_DOUBLE_EQ(scorer.decided(step, "b").estimate_probability, 0.3);
  EXPECT_EQ(scorer.decided(step, "unknown").estimate_probability, 0.0);
  EXPECT_EQ(scorer.decided(step, "unknown").truth_probability, 0.7);
}

// "None of these" scores the truth as a uniform guess over the classes would:
// its probability is spread evenly over them (hand-computed below).
TEST(ClassScorer, UnknownHypothesisScoresAsAUniformGuess) {
  BankConfig config = modes_a1_a2_b();
  config.classes.push_back(ClassConfig{"B", {2}});
  const ClassScorer scorer(config);
  Eigen::VectorXd mu(3);
  mu << 0.4, 0.1, 0.2;  // A 0.5, B 0.2, unknown 0.3: each class gets 0.15 more
  const LabelledStep known = scorer.score(1.0, "A", mu, 0.3);
  EXPECT_EQ(known.estimate, "A");
  EXPECT_DOUBLE_EQ(known.estimate_probability, 0.5) << "the estimate's own probability is not widened";
  EXPECT_NEAR(known.truth_probability, 0.65, 1e-15);
  EXPECT_NEAR(known.brier, 0.35 * 0.35 + 0.35 * 0.35, 1e-15);  // (0.65 - 1)^2 + 0.35^2

  mu << 0.1, 0.1, 0.1;  // A 0.2, B 0.1, unknown 0.7 outweighs both
  const LabelledStep unsure = scorer.score(1.0, "B", mu, 0.7);
  EXPECT_EQ(unsure.estimate, "unknown");
  EXPECT_EQ(unsure.estimate_probability, 0.0);
  EXPECT_NEAR(unsure.truth_probability, 0.45, 1e-15);
  EXPECT_NEAR(unsure.brier, 0.55 * 0.55 + 0.55 * 0.55, 1e-15);  // A 0.55, B 0.45 against B
  EXPECT_EQ(scorer.score(1.0, "gravel", mu, 0.7).truth_probability, 0.0) << "a truth outside the bank stays at 0";
}

TEST(ModeMetrics, SwitchLatencyFirstAndSettled) {
  // Switch a -> b at t = 2; the estimate reaches b at 3, flickers back at 4,
  // settles at 5. Switch b -> c at 7 is never followed.
  const ModeMetrics m = compute_mode_metrics(steps({{0, "a", "a", 1},
                                                    {1, "a", "a", 1},
                                                    {2, "b", "a", 0},
                                                    {3, "b", "b", 1},
                                                    {4, "b", "a", 0},
                                                    {5, "b", "b", 1},
                                                    {6, "b", "b", 1},
                                                    {7, "c", "b", 0},
                                                    {8, "c", "b", 0}}),
                                             {"a", "b", "c"});
  ASSERT_EQ(m.switches.size(), 2u);
  EXPECT_EQ(m.switches[0].from, "a");
  EXPECT_EQ(m.switches[0].to, "b");
  EXPECT_DOUBLE_EQ(m.switches[0].time, 2.0);
  EXPECT_DOUBLE_EQ(m.switches[0].first_latency, 1.0);
  EXPECT_DOUBLE_EQ(m.switches[0].latency, 3.0);
  EXPECT_TRUE(m.switches[0].detected());
  EXPECT_FALSE(m.switches[1].detected());
  EXPECT_TRUE(std::isnan(m.switches[1].first_latency));
}

// The decision over the same steps: it reaches b late and never reaches c,
// which the most likely mode reached once; a switch neither detected is not
// lost.
TEST(ModeMetrics, SwitchesLostAgainstTheMostLikelyMode) {
  const ModeMetrics most_likely = compute_mode_metrics(steps({{0, "a", "a", 1},
                                                              {1, "b", "a", 0},
                                                              {2, "b", "b", 1},
                                                              {3, "c", "c", 1},
                                                              {4, "c", "b", 0},
                                                              {5, "d", "b", 0},
                                                              {6, "d", "b", 0}}),
                                                       {"a", "b", "c", "d"});
  const ModeMetrics decision = compute_mode_metrics(steps({{0, "a", "a", 1},
                                                           {1, "b", "a", 0},
                                                           {2, "b", "a", 0},
                                                           {3, "c", "b", 0},
                                                           {4, "c", "b", 0},
                                                           {5, "d", "unknown", 0},
                                                           {6, "d", "unknown", 0}}),
                                                    {"a", "b", "c", "d"});
  ASSERT_EQ(most_likely.switches.size(), 3u);
  EXPECT_EQ(switches_lost(most_likely, decision), 2);  // b (never decided) and c; d by neither
  EXPECT_EQ(switches_lost(decision, most_likely), 0);
  const ModeMetrics other_run = compute_mode_metrics(steps({{0, "a", "a", 1}, {1, "b", "b", 1}}), {"a", "b"});
  EXPECT_THROW(switches_lost(most_likely, other_run), std::invalid_argument);
}

TEST(ModeMetrics, ImmediateDetectionHasZeroLatency) {
  const ModeMetrics m = compute_mode_metrics(steps({{0, "a", "a", 1}, {1, "b", "b", 1}, {2, "b", "b", 1}}), {"a", "b"});
  ASSERT_EQ(m.switches.size(), 1u);
  EXPECT_DOUBLE_EQ(m.switches[0].latency, 0.0);
}

TEST(ModeMetrics, TruthModeAbsentFromTheBankIsAlwaysWrong) {
  const ModeMetrics m = compute_mode_metrics(
      steps({{0, "ice", "asphalt", 0}, {1, "ice", "grass", 0}, {2, "asphalt", "asphalt", 1}}), {"asphalt", "grass"});
  EXPECT_DOUBLE_EQ(m.truth_absent.at("ice"), 2.0);
  EXPECT_DOUBLE_EQ(m.accuracy(), 1.0 / 3.0);
  EXPECT_DOUBLE_EQ(m.mean_truth_probability(), 1.0 / 3.0);
}

TEST(ModeMetrics, UnlabelledRowsAreIgnoredAndRunsMerge) {
  ModeMetrics m = compute_mode_metrics(steps({{0, "", "a", 0}, {1, "a", "a", 1}, {2, "a", "a", 1}}), {"a"});
  EXPECT_DOUBLE_EQ(m.duration, 2.0);
  const ModeMetrics other = compute_mode_metrics(steps({{0, "a", "b", 0}, {1, "a", "b", 0}}), {"a", "b"});
  m.merge(other);
  EXPECT_DOUBLE_EQ(m.duration, 4.0);
  EXPECT_DOUBLE_EQ(m.accuracy(), 0.5);
}

TEST(Consistency, ChiSquareQuantilesMatchTables) {
  // Reference values from standard chi-square tables.
  EXPECT_NEAR(chi_square_quantile(0.975, 10), 20.483, 0.1);
  EXPECT_NEAR(chi_square_quantile(0.025, 10), 3.247, 0.05);
  EXPECT_NEAR(chi_square_quantile(0.975, 100), 129.561, 0.1);
  EXPECT_NEAR(chi_square_quantile(0.025, 100), 74.222, 0.1);
  EXPECT_NEAR(chi_square_quantile(0.5, 2000), 1999.33, 0.5);
}

TEST(Consistency, VerdictFollowsTheBounds) {
  NisAccumulator consistent, overconfident, underconfident;
  for (int k = 0; k < 1000; ++k) {
    consistent.add(2.0, 2);
    overconfident.add(3.0, 2);
    underconfident.add(1.0, 2);
  }
  EXPECT_STREQ(consistent.verdict(), "consistent");
  EXPECT_STREQ(overconfident.verdict(), "overconfident");
  EXPECT_STREQ(underconfident.verdict(), "underconfident");
  EXPECT_NEAR(consistent.upper_bound(), 1.0 + 1.96 * std::sqrt(2.0 / 2000.0), 0.005);
}

TEST(ModeMetrics, CountsChangesUnknownTimeAndLogProbability) {
  // Truth a (0-2 s), b (2-4 s); the estimate starts unknown, decides a, flickers, and follows b.
  const std::vector<LabelledStep> steps{
      {0.0, "a", "unknown", 0.4}, {1.0, "a", "a", 0.9}, {2.0, "b", "a", 0.5},
      {3.0, "b", "unknown", 0.5}, {4.0, "b", "b", 0.99}};
  const ModeMetrics m = compute_mode_metrics(steps, {"a", "b"});
  EXPECT_EQ(m.estimate_changes, 2) << "a -> unknown -> b; the first decision out of unknown is not a change";
  EXPECT_EQ(m.truth_changes, 1);
  EXPECT_DOUBLE_EQ(m.unknown_seconds, 2.0);
  EXPECT_DOUBLE_EQ(m.duration, 5.0);
  EXPECT_NEAR(m.estimate_changes_per_minute(), 24.0, 1e-12);
  EXPECT_NEAR(m.mean_truth_log_probability(),
              (std::log(0.4) + std::log(0.9) + std::log(0.5) + std::log(0.5) + std::log(0.99)) / 5.0, 1e-12);
  // A probability of 0 is floored, not -infinity.
  const ModeMetrics z = compute_mode_metrics({{0.0, "a", "b", 0.0}, {1.0, "a", "b", 0.0}}, {"a", "b"});
  EXPECT_NEAR(z.mean_truth_log_probability(), std::log(kMinScoredProbability), 1e-12);
  EXPECT_EQ(main_truth(m), "b");
}

}  // namespace
}  // namespace evaluation
}  // namespace skidimm
