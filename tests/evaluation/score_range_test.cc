// The range another set of logs' accuracy falls in (score_range.h): its
// standard error against hand-computed values, its ends against the normal
// approximation of the two-level bootstrap's exact variance, what it
// borrows for a class of one log, and when it refuses to say.
#include "skidimm/evaluation/score_range.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

namespace skidimm {
namespace evaluation {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

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

TEST(AccuracyRange, StandardErrorIsEachClassesSpreadOverItsLogs) {
  // A: 1.0, 0.5 (variance 0.125); B: 0.8, 0.6, 0.7 (0.01); C: 0.9, 0.9 (0).
  // sqrt(0.125 / 2 + 0.01 / 3 + 0 / 2) / 3, by hand.
  const AccuracyRange r =
      accuracy_range(scores_of({{"A", 1.0}, {"A", 0.5}, {"B", 0.8}, {"B", 0.6}, {"B", 0.7}, {"C", 0.9}, {"C", 0.9}}));
  EXPECT_NEAR(r.mean, (0.75 + 0.7 + 0.9) / 3.0, 1e-15);
  EXPECT_NEAR(r.standard_error, std::sqrt(0.0625 + 0.01 / 3.0) / 3.0, 1e-15);
  EXPECT_EQ(r.level, 0.9);
  EXPECT_TRUE(r.known());
  EXPECT_LT(r.low, r.mean);
  EXPECT_GT(r.high, r.mean);
  EXPECT_EQ(r.logs_per_class.at("A"), 2);
  EXPECT_EQ(r.logs_per_class.at("B"), 3);
  EXPECT_TRUE(r.borrowed_spread.empty());
}

TEST(AccuracyRange, EndsAreTheTwoLevelBootstrapsNormalQuantilesForManyLogs) {
  // One class of 40 logs at i / 39. Resampling them (this estimate's
  // uncertainty), then drawing m = 40 from the resample, gives the other
  // set's mean a variance of s2 / n + s2 (n - 1) / (n m), s2 the logs'
  // population variance ((40^2 - 1) / 12 / 39^2 for these). With 80 draws
  // behind each mean it is close to normal: the ends are the mean +- 1.6449
  // standard deviations, to the bootstrap's noise and the little skew left.
  std::vector<std::pair<std::string, double>> logs;
  for (int i = 0; i < 40; ++i) logs.emplace_back("A", i / 39.0);
  const AccuracyRange r = accuracy_range(scores_of(logs));
  const double s2 = (40.0 * 40.0 - 1.0) / 12.0 / (39.0 * 39.0);
  const double sd = std::sqrt(s2 / 40.0 + s2 * 39.0 / 40.0 / 40.0);
  EXPECT_NEAR(r.low, 0.5 - 1.6449 * sd, 0.005);
  EXPECT_NEAR(r.high, 0.5 + 1.6449 * sd, 0.005);
  // Asking for a range in which fewer of the other sets fall narrows it.
  const AccuracyRange half = accuracy_range(scores_of(logs), {}, 0.5);
  EXPECT_NEAR(half.low, 0.5 - 0.67449 * sd, 0.005);
  EXPECT_NEAR(half.high, 0.5 + 0.67449 * sd, 0.005);
}

TEST(AccuracyRange, LogsAlikeInEachClassGiveNoSpread) {
  const AccuracyRange r = accuracy_range(
      scores_of({{"A", 0.7}, {"A", 0.7}, {"A", 0.7}, {"A", 0.7}, {"B", 0.2}, {"B", 0.2}}), {{"A", 3}, {"B", 9}});
  EXPECT_EQ(r.low, r.high);
  EXPECT_NEAR(r.low, 0.45, 1e-15);
  EXPECT_EQ(r.standard_error, 0.0);
}

TEST(AccuracyRange, AClassOfOneLogBorrowsTheOtherClassesSpread) {
  // B's deviations from its mean, scaled by sqrt(4 / 3): +-0.3464 (pooled
  // variance 0.12). A's one log at 0.9: its mean is 0.9 -+ 0.3464, and
  // another log of A that mean +- 0.3464 kept within [0, 1]: 0.2072, 0.9 or 1.
  const std::vector<LogScore> scores = scores_of({{"A", 0.9}, {"B", 0.2}, {"B", 0.8}, {"B", 0.2}, {"B", 0.8}});
  const AccuracyRange r = accuracy_range(scores);
  EXPECT_THAT(r.borrowed_spread, ElementsAre("A"));
  EXPECT_NEAR(r.standard_error, std::sqrt(0.12 / 1.0 + 0.12 / 4.0) / 2.0, 1e-15);
  EXPECT_GE(r.low, 0.0);
  EXPECT_LE(r.high, 1.0);
  // B alone (mean 0.5) spans 0.2-0.8 in fours; A's 0.2072 pulls the lowest
  // means below what B alone reaches with A at 0.9.
  EXPECT_LT(r.low, (0.9 + 0.2) / 2.0);
  EXPECT_THAT(r.describe(), HasSubstr("A has one log, and the spread of the other classes' logs"));
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
  }
}

TEST(AccuracyRange, TooFewLogsBeyondEachClassesFirstSayNothing) {
  // One log beyond each class's first (A's second): alike by chance, two
  // logs would give every class no spread at all.
  const AccuracyRange r = accuracy_range(scores_of({{"A", 0.5}, {"A", 0.5}, {"B", 0.9}, {"C", 0.1}}));
  EXPECT_FALSE(r.known());
  EXPECT_NEAR(r.mean, 0.5, 1e-15);
  EXPECT_THAT(r.describe(), HasSubstr("too few logs of each class"));
}

TEST(AccuracyRange, AnotherSetMustCountEachScoredClassAndNoOther) {
  const std::vector<LogScore> scores = scores_of({{"A", 0.5}, {"A", 0.6}, {"B", 0.9}, {"B", 0.8}});
  EXPECT_NO_THROW(check_logs_per_class(scores, {{"A", 1}, {"B", 7}}));
  try {
    accuracy_range(scores, {{"A", 2}});
    FAIL() << "a class left out";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("leaves out class 'B'"));
  }
  try {
    accuracy_range(scores, {{"A", 2}, {"B", 2}, {"SNOW", 3}});
    FAIL() << "a class not scored";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("class 'SNOW' of the other set has no scored log here"));
  }
  EXPECT_THROW(accuracy_range(scores, {{"A", 0}, {"B", 2}}), std::invalid_argument);
  EXPECT_THROW(accuracy_range(scores, {}, 1.0), std::invalid_argument);
}

TEST(AccuracyRange, LogsPerClassAreReadFromClassEqualsCount) {
  EXPECT_EQ(parse_logs_per_class("ASPHALT=2,SANDY_LOAM=4"),
            (std::map<std::string, int>{{"ASPHALT", 2}, {"SANDY_LOAM", 4}}));
  for (const std::string bad : {"", "ASPHALT", "ASPHALT=", "=2", "ASPHALT=0", "ASPHALT=2.5", "ASPHALT=-1", "A=1,A=2"}) {
    EXPECT_THROW(parse_logs_per_class(bad), std::invalid_argument) << "'" << bad << "'";
  }
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
