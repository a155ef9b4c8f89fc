// The range another set of logs' accuracy falls in (accuracy_range.h):
// its mean, standard error and ends against values computed by hand with
// Student's t quantiles from tables, how the other set's counts move it,
// what a class of one log takes, and when it refuses to say.
#include "skidimm/evaluation/accuracy_range.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

namespace skidimm {
namespace evaluation {
namespace {

using ::testing::HasSubstr;

// Student's t quantiles at 0.95, from tables.
constexpr double kT95With3 = 2.353363435;
constexpr double kT95With4 = 2.131846786;
constexpr double kT95With39 = 1.684875122;

std::vector<LogScore> scores_of(const std::vector<std::pair<std::string, double>>& logs) {
  std::vector<LogScore> out;
  for (const auto& [truth, accuracy] : logs) {
    LogScore s;
    s.log = truth + "_" + std::to_string(out.size());
    s.truth = truth;
    s.accuracy = accuracy;
    out.push_back(s);
  }
  return out;
}

TEST(AccuracyRange, IsThePooledStudentTPredictionIntervalOfTheMeanOverClasses) {
  // A: 1.0, 0.5; B: 0.8, 0.6, 0.7; C: 0.6, 0.6. Squares about the classes'
  // means 0.125 + 0.02 + 0 over 1 + 2 + 1 degrees of freedom: s2 = 0.03625.
  const std::vector<LogScore> scores =
      scores_of({{"A", 1.0}, {"A", 0.5}, {"B", 0.8}, {"B", 0.6}, {"B", 0.7}, {"C", 0.6}, {"C", 0.6}});
  const double s2 = 0.145 / 4.0;
  const double mean = (0.75 + 0.7 + 0.6) / 3.0;
  const AccuracyRange r = accuracy_range(scores, {{"A", 1}, {"B", 4}, {"C", 9}});
  EXPECT_EQ(r.degrees_of_freedom, 4);
  EXPECT_NEAR(r.mean, mean, 1e-15);
  EXPECT_NEAR(r.standard_error, std::sqrt(s2 * (1.0 / 2 + 1.0 / 3 + 1.0 / 2)) / 3.0, 1e-15);
  // The other set's mean minus this one's: s2 sum_c (1 / n_c + 1 / m_c) / C^2.
  const double spread = std::sqrt(s2 * (1.0 / 2 + 1.0 + 1.0 / 3 + 1.0 / 4 + 1.0 / 2 + 1.0 / 9)) / 3.0;
  EXPECT_NEAR(r.half_width, kT95With4 * spread, 1e-8);
  EXPECT_NEAR(r.low, mean - kT95With4 * spread, 1e-8);
  EXPECT_NEAR(r.high, mean + kT95With4 * spread, 1e-8);
  EXPECT_EQ(r.level, 0.9);
  EXPECT_TRUE(r.known());
  EXPECT_EQ(r.logs_per_class.at("B"), 4);
  // As many of each as were scored, by default.
  EXPECT_EQ(accuracy_range(scores).logs_per_class, (std::map<std::string, int>{{"A", 2}, {"B", 3}, {"C", 2}}));
}

TEST(AccuracyRange, NarrowsAsTheOtherSetHoldsMoreLogsButNotBelowThisEstimatesOwnUncertainty) {
  // One class of 40 logs at i / 39: sample variance 40 * 41 / 12 / 39^2.
  std::vector<std::pair<std::string, double>> logs;
  for (int i = 0; i < 40; ++i) logs.emplace_back("A", i / 39.0);
  const double s2 = 40.0 * 41.0 / 12.0 / (39.0 * 39.0);
  for (const int m : {4, 400, 1000000}) {
    const AccuracyRange r = accuracy_range(scores_of(logs), {{"A", m}});
    const double half = kT95With39 * std::sqrt(s2 * (1.0 / 40.0 + 1.0 / m));
    EXPECT_NEAR(r.low, 0.5 - half, 1e-8) << m;
    EXPECT_NEAR(r.high, 0.5 + half, 1e-8) << m;
  }
  // A wider level asks for a wider range; the ends stay within [0, 1].
  const AccuracyRange one = accuracy_range(scores_of(logs), {{"A", 1}}, 0.99);
  EXPECT_EQ(one.low, 0.0);
  EXPECT_EQ(one.high, 1.0);
  EXPECT_GT(one.half_width, 0.5);  // as computed, before the ends were clamped
}

// Where its assumption holds (each class's logs normal about the class's
// mean, one spread for all), the interval holds the mean over classes of
// nine in ten other sets: drawn here, with a fixed seed, for the BorealTC
// development runs' counts and for a lockbox's few, each against another
// set counted as the held-back split.
TEST(AccuracyRange, HoldsNineInTenOtherSetsWhereLogsAreNormalAboutTheirClasssMean) {
  const std::vector<std::string> classes{"A", "B", "C", "D", "E"};
  const std::vector<double> means{0.4, 0.45, 0.5, 0.55, 0.6};  // 5.7 spreads from 0 and from 1
  const std::map<std::string, int> another{{"A", 2}, {"B", 2}, {"C", 4}, {"D", 4}, {"E", 9}};
  for (const std::vector<int>& counts : {std::vector<int>{4, 5, 6, 8, 14}, std::vector<int>{1, 1, 2, 3, 3}}) {
    std::mt19937_64 random(2024);
    std::normal_distribution<double> spread(0.0, 0.07);
    const int trials = 4000;
    int held = 0;
    for (int trial = 0; trial < trials; ++trial) {
      std::vector<std::pair<std::string, double>> logs;
      double other = 0.0;
      for (std::size_t c = 0; c < classes.size(); ++c) {
        for (int i = 0; i < counts[c]; ++i) logs.emplace_back(classes[c], means[c] + spread(random));
        double sum = 0.0;
        for (int i = 0; i < another.at(classes[c]); ++i) sum += means[c] + spread(random);
        other += sum / another.at(classes[c]) / static_cast<double>(classes.size());
      }
      const AccuracyRange r = accuracy_range(scores_of(logs), another);
      ASSERT_TRUE(r.known());
      held += other >= r.low && other <= r.high;
    }
    // Binomial: 0.9 +- 0.0047 over 4000 trials; four standard deviations either way.
    EXPECT_NEAR(static_cast<double>(held) / trials, 0.9, 0.019) << counts[0] << " logs of the first class";
  }
}

TEST(AccuracyRange, LogsAlikeInEachClassGiveNoSpread) {
  const AccuracyRange r = accuracy_range(
      scores_of({{"A", 0.7}, {"A", 0.7}, {"A", 0.7}, {"A", 0.7}, {"B", 0.2}, {"B", 0.2}}), {{"A", 3}, {"B", 9}});
  EXPECT_EQ(r.low, r.high);
  EXPECT_NEAR(r.low, 0.45, 1e-15);
  EXPECT_EQ(r.standard_error, 0.0);
}

TEST(AccuracyRange, AClassOfOneLogHasTheSpreadPooledOverTheOthers) {
  // B's squares 4 * 0.09 over 3 degrees of freedom: s2 = 0.12, which A's
  // one log at 0.9 takes too; the mean is (0.9 + 0.5) / 2. Only the high end
  // is clamped to 1.
  const std::vector<LogScore> scores = scores_of({{"A", 0.9}, {"B", 0.2}, {"B", 0.8}, {"B", 0.2}, {"B", 0.8}});
  const AccuracyRange r = accuracy_range(scores, {{"A", 100}, {"B", 100}});
  EXPECT_EQ(r.degrees_of_freedom, 3);
  EXPECT_NEAR(r.standard_error, std::sqrt(0.12 * (1.0 + 0.25)) / 2.0, 1e-15);
  EXPECT_NEAR(r.low, 0.7 - kT95With3 * std::sqrt(0.12 * (1.0 + 0.01 + 0.25 + 0.01)) / 2.0, 1e-8);
  EXPECT_EQ(r.high, 1.0);
}

TEST(AccuracyRange, IsTheSameWhateverTheLogsOrder) {
  std::vector<LogScore> scores =
      scores_of({{"A", 0.1}, {"A", 0.95}, {"A", 0.7}, {"B", 0.99}, {"B", 0.4}, {"C", 0.8}, {"C", 0.85}});
  const AccuracyRange first = accuracy_range(scores, {{"A", 2}, {"B", 2}, {"C", 4}});
  std::mt19937 shuffle(7);
  for (int k = 0; k < 5; ++k) {
    std::shuffle(scores.begin(), scores.end(), shuffle);
    const AccuracyRange again = accuracy_range(scores, {{"A", 2}, {"B", 2}, {"C", 4}});
    EXPECT_EQ(again.low, first.low);
    EXPECT_EQ(again.high, first.high);
    EXPECT_EQ(again.standard_error, first.standard_error);
  }
}

TEST(AccuracyRange, TooFewLogsBeyondEachClassesFirstSayNothing) {
  // One log beyond each class's first (A's second): two logs alike by chance
  // would give every class no spread at all.
  const AccuracyRange r = accuracy_range(scores_of({{"A", 0.5}, {"A", 0.6}, {"B", 0.9}, {"C", 0.1}}));
  EXPECT_FALSE(r.known());
  EXPECT_EQ(r.degrees_of_freedom, 1);
  EXPECT_NEAR(r.mean, (0.55 + 0.9 + 0.1) / 3.0, 1e-15);
  EXPECT_TRUE(std::isnan(r.standard_error));
  EXPECT_THAT(r.describe(), HasSubstr("too few logs"));
  EXPECT_THAT(r.describe(), HasSubstr("counted over all classes; these have 1"));
  // Every class of one log: no spread to go on at all.
  EXPECT_EQ(accuracy_range(scores_of({{"A", 0.5}, {"B", 0.9}})).degrees_of_freedom, 0);
}

TEST(AccuracyRange, AnotherSetMustCountEachScoredClassAndNoOther) {
  const std::vector<LogScore> scores = scores_of({{"A", 0.5}, {"A", 0.6}, {"B", 0.9}, {"B", 0.8}});
  EXPECT_NO_THROW(check_logs_per_class(scores, {{"A", 1}, {"B", 7}}));
  try {
    accuracy_range(scores, {{"A", 2}});
    FAIL() << "a class left out";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("leaves out class 'B'"));
    EXPECT_THAT(e.what(), HasSubstr("(scored: A, B)"));
  }
  try {
    accuracy_range(scores, {{"A", 2}, {"B", 2}, {"SNOW", 3}});
    FAIL() << "a class not scored";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("class 'SNOW' of the other set has no scored log here"));
  }
  EXPECT_THROW(accuracy_range(scores, {{"A", 0}, {"B", 2}}), std::invalid_argument);
  EXPECT_THROW(accuracy_range(scores, {{"A", kMostLogsPerClass + 1}, {"B", 2}}), std::invalid_argument);
  EXPECT_THROW(accuracy_range(scores, {}, 1.0), std::invalid_argument);
  // An accuracy that is not a share is refused, not summed.
  for (const double bad : {std::numeric_limits<double>::quiet_NaN(), 1.5, -0.1}) {
    EXPECT_THROW(accuracy_range(scores_of({{"A", 0.5}, {"A", bad}})), std::invalid_argument) << bad;
  }
}

TEST(AccuracyRange, LogsPerClassAreReadFromClassEqualsCount) {
  EXPECT_EQ(parse_logs_per_class("ASPHALT=2,SANDY_LOAM=4"),
            (std::map<std::string, int>{{"ASPHALT", 2}, {"SANDY_LOAM", 4}}));
  for (const std::string bad :
       {"", ",", "ASPHALT", "ASPHALT=", "=2", "ASPHALT=0", "ASPHALT=2.5", "ASPHALT=-1", "ASPHALT=+4", "ASPHALT= 4",
        "ICE=4, SNOW=9", "ICE=4,", "ICE=4,,SNOW=9", "A=1,A=2", "ICE=1000001", "ICE=99999999999"}) {
    EXPECT_THROW(parse_logs_per_class(bad), std::invalid_argument) << "'" << bad << "'";
  }
  EXPECT_EQ(parse_logs_per_class("ICE=1000000").at("ICE"), kMostLogsPerClass);
  try {
    parse_logs_per_class("ICE=4,SNOW=nine");
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("'SNOW=nine' is not CLASS=COUNT"));
  }
}

}  // namespace
}  // namespace evaluation
}  // namespace skidimm
