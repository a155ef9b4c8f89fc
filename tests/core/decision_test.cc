#include "skidimm/engine/decision.h"

#include <gtest/gtest.h>

#include <cmath>

namespace skidimm {
namespace {

BankConfig three_modes() {
  BankConfig c;
  for (const char* name : {"asphalt", "grass", "ice"}) {
    ModeConfig m;
    m.name = name;
    c.modes.push_back(m);
  }
  return c;
}

DecisionConfig settings(double enter, double leave, double hold) {
  DecisionConfig d;
  d.enter = enter;
  d.leave = leave;
  d.min_hold = hold;
  return d;
}

TEST(ModeDecision, UnknownUntilAModeIsConfidentThenHysteresis) {
  ModeDecision d(three_modes(), settings(0.9, 0.0, 0.0));
  EXPECT_EQ(d.update(0.0, Eigen::Vector3d(0.5, 0.3, 0.2)), ModeDecision::kUnknown);
  EXPECT_EQ(d.name(d.decision()), "unknown");
  EXPECT_EQ(d.update(0.1, Eigen::Vector3d(0.91, 0.05, 0.04)), 0);
  EXPECT_DOUBLE_EQ(d.probability(), 0.91);
  // Asphalt is no longer the most likely, but grass has not reached 0.9: kept.
  EXPECT_EQ(d.update(0.2, Eigen::Vector3d(0.3, 0.6, 0.1)), 0);
  EXPECT_EQ(d.update(0.3, Eigen::Vector3d(0.05, 0.89, 0.06)), 0);
  EXPECT_EQ(d.update(0.4, Eigen::Vector3d(0.05, 0.9, 0.05)), 1);
  EXPECT_EQ(d.name(1), "grass");
  d.reset();
  EXPECT_EQ(d.decision(), ModeDecision::kUnknown);
}

TEST(ModeDecision, AMinimumHoldIgnoresASpike) {
  ModeDecision d(three_modes(), settings(0.9, 0.0, 1.0));
  EXPECT_EQ(d.update(0.0, Eigen::Vector3d(0.95, 0.03, 0.02)), 0);
  EXPECT_EQ(d.update(0.5, Eigen::Vector3d(0.02, 0.96, 0.02)), 0) << "held for 1 s";
  EXPECT_EQ(d.update(0.9, Eigen::Vector3d(0.97, 0.02, 0.01)), 0);
  EXPECT_EQ(d.update(1.2, Eigen::Vector3d(0.02, 0.96, 0.02)), 1) << "after the hold, grass takes over";
}

TEST(ModeDecision, LeavingBelowTheThresholdGivesUnknownAfterTheHold) {
  ModeDecision d(three_modes(), settings(0.9, 0.2, 0.5));
  EXPECT_EQ(d.update(0.0, Eigen::Vector3d(0.95, 0.03, 0.02)), 0);
  EXPECT_EQ(d.update(0.1, Eigen::Vector3d(0.1, 0.5, 0.4)), 0) << "still held";
  EXPECT_EQ(d.update(0.6, Eigen::Vector3d(0.1, 0.5, 0.4)), ModeDecision::kUnknown);
  EXPECT_EQ(d.update(0.7, Eigen::Vector3d(0.1, 0.85, 0.05)), ModeDecision::kUnknown);
  EXPECT_EQ(d.update(0.8, Eigen::Vector3d(0.04, 0.93, 0.03)), 1);
}

TEST(ModeDecision, ADipBelowLeaveShorterThanTheHoldKeepsTheDecision) {
  ModeDecision d(three_modes(), settings(0.9, 0.2, 0.5));
  EXPECT_EQ(d.update(0.0, Eigen::Vector3d(0.95, 0.03, 0.02)), 0);
  EXPECT_EQ(d.update(1.0, Eigen::Vector3d(0.1, 0.5, 0.4)), 0) << "below leave for 0 s";
  EXPECT_EQ(d.update(1.3, Eigen::Vector3d(0.5, 0.3, 0.2)), 0) << "back above leave: the wait restarts";
  EXPECT_EQ(d.update(1.4, Eigen::Vector3d(0.1, 0.5, 0.4)), 0);
  EXPECT_EQ(d.update(1.8, Eigen::Vector3d(0.1, 0.5, 0.4)), 0) << "below leave for 0.4 s of 0.5";
  EXPECT_EQ(d.update(1.9, Eigen::Vector3d(0.1, 0.5, 0.4)), ModeDecision::kUnknown) << "for 0.5 s";
}

TEST(ModeDecision, AfterASwitchTheDecisionMovesStraightToTheNewModeWithinTheHold) {
  // The old mode's probability collapses at once; the new one needs 0.6 s to
  // become confident: one change, not two through unknown.
  ModeDecision d(three_modes(), settings(0.9, 0.05, 1.0));
  EXPECT_EQ(d.update(0.0, Eigen::Vector3d(0.95, 0.03, 0.02)), 0);
  EXPECT_EQ(d.update(5.0, Eigen::Vector3d(0.01, 0.5, 0.49)), 0);
  EXPECT_EQ(d.update(5.3, Eigen::Vector3d(0.01, 0.7, 0.29)), 0);
  EXPECT_EQ(d.update(5.6, Eigen::Vector3d(0.01, 0.92, 0.07)), 1);
  // Without a hold the decision is given up at once.
  ModeDecision at_once(three_modes(), settings(0.9, 0.05, 0.0));
  EXPECT_EQ(at_once.update(0.0, Eigen::Vector3d(0.95, 0.03, 0.02)), 0);
  EXPECT_EQ(at_once.update(5.0, Eigen::Vector3d(0.01, 0.5, 0.49)), ModeDecision::kUnknown);
  EXPECT_EQ(at_once.update(5.6, Eigen::Vector3d(0.01, 0.92, 0.07)), 1);
}

TEST(ModeDecision, DecidesOverClassesWhenTheBankHasThem) {
  BankConfig c = three_modes();
  c.classes.push_back(ClassConfig{"grip", {0, 1}});
  ModeDecision d(c, settings(0.9, 0.0, 0.0));
  ASSERT_EQ(d.names(), (std::vector<std::string>{"grip", "ice"}));
  // Neither asphalt nor grass alone is confident; together they are.
  EXPECT_EQ(d.update(0.0, Eigen::Vector3d(0.5, 0.45, 0.05)), 0);
  EXPECT_EQ(d.name(0), "grip");
}

// With no measurement the probabilities only relax towards the chain's
// prior: five classes sit at 0.2 for ever, above any `leave` under it.
// After stale_after seconds without one (by default the bank's shortest mean
// dwell time) the decision is unknown, and none is taken, until a measured
// step comes.
TEST(ModeDecision, NoMeasurementForStaleAfterSecondsGivesUnknown) {
  BankConfig c = three_modes();
  c.transition.kind = TransitionConfig::Kind::kDwellTimes;
  c.transition.dwell_seconds = Eigen::Vector3d(10.0, 20.0, 5.0);
  ModeDecision d(c, settings(0.9, 0.05, 1.0));
  EXPECT_EQ(d.stale_after(), 5.0) << "the shortest mean dwell time";
  const Eigen::Vector3d sure(0.95, 0.03, 0.02), uniform(1.0 / 3, 1.0 / 3, 1.0 / 3);
  EXPECT_EQ(d.update(0.0, sure, true), 0);
  EXPECT_EQ(d.update(4.9, uniform, false), 0) << "silent for 4.9 s, and 1/3 is above leave";
  EXPECT_EQ(d.update(5.0, uniform, false), ModeDecision::kUnknown) << "silent for 5 s";
  EXPECT_EQ(d.update(5.5, sure, false), ModeDecision::kUnknown) << "no decision is taken without a measurement";
  EXPECT_EQ(d.update(6.0, sure, true), 0) << "a measured step decides again";
  // Measured steps are never stale, whatever the probabilities say.
  EXPECT_EQ(d.update(20.0, sure, true), 0);
  // A time that is not finite, or goes back, does not count as the sensors speaking.
  EXPECT_EQ(d.update(std::nan(""), uniform, true), 0);
  EXPECT_EQ(d.update(19.0, uniform, true), 0);
  EXPECT_EQ(d.update(25.0, uniform, false), ModeDecision::kUnknown) << "silent since 20 s";

  // Given in the bank: that value; 0 never gives a decision up so.
  DecisionConfig given = settings(0.9, 0.05, 1.0);
  given.stale_after = 2.0;
  EXPECT_EQ(ModeDecision(c, given).stale_after(), 2.0);
  given.stale_after = 0.0;
  ModeDecision never(c, given);
  EXPECT_EQ(never.update(0.0, sure, true), 0);
  EXPECT_EQ(never.update(100.0, uniform, false), 0);
  // A per-step transition states no time: never, by default.
  EXPECT_EQ(ModeDecision(three_modes(), settings(0.9, 0.05, 1.0)).stale_after(), 0.0);
}

}  // namespace
}  // namespace skidimm
