#include "skidimm/engine/mode_timeline.h"

#include <gtest/gtest.h>

namespace skidimm {
namespace {

TEST(ModeTimeline, MergesConsecutiveStepsAndAveragesProbability) {
  ModeTimeline timeline;
  timeline.add(0.0, 1, 0.6);
  timeline.add(0.1, 1, 0.8);
  timeline.add(0.2, 0, 0.9);
  timeline.add(0.3, 1, 0.7);
  ASSERT_EQ(timeline.intervals().size(), 3u);
  EXPECT_EQ(timeline.intervals()[0].mode, 1);
  EXPECT_EQ(timeline.intervals()[0].steps, 2);
  EXPECT_DOUBLE_EQ(timeline.intervals()[0].end, 0.1);
  EXPECT_NEAR(timeline.intervals()[0].mean_probability, 0.7, 1e-15);
  EXPECT_EQ(timeline.steps(), 4);
  const std::string text = timeline.format({"grass", "asphalt"});
  EXPECT_NE(text.find("0.000 -      0.100 s  asphalt  (2 steps, mean p = 0.700)"), std::string::npos) << text;
}

// A step where modes share the top probability names no mode, and leaving
// it for a mode is no change of the most likely mode.
TEST(ModeTimeline, ATieNamesNoModeAndIsNoChange) {
  ModeTimeline timeline;
  timeline.add(0.0, ModeTimeline::kTie, 0.5);
  timeline.add(0.1, 1, 0.6);
  timeline.add(0.2, ModeTimeline::kTie, 0.5);
  timeline.add(0.3, 1, 0.8);
  timeline.add(0.4, 0, 0.9);
  EXPECT_EQ(timeline.intervals().size(), 5u);
  EXPECT_EQ(timeline.changes(), 1) << "asphalt -> grass; the ties are no change";
  const std::string text = timeline.format({"grass", "asphalt"});
  EXPECT_NE(text.find("0.000 -      0.000 s  (a tie)  (1 steps, mean p = 0.500)"), std::string::npos) << text;
  EXPECT_NE(text.find("0.100 -      0.100 s  asphalt  (1 steps"), std::string::npos) << text;
}

// A log stamped by a wall clock: the table counts from the first step, so
// that the durations, not the date's digits, fill it.
TEST(ModeTimeline, TimesOfAWallClockCountFromTheFirstStep) {
  ModeTimeline timeline;
  timeline.add(1700000000.25, 0, 0.6);
  timeline.add(1700000002.75, 1, 0.8);
  EXPECT_EQ(timeline.origin(), 1700000000.25);
  const std::string text = timeline.format({"grass", "asphalt"});
  EXPECT_NE(text.find("      0.000 -      0.000 s  grass"), std::string::npos) << text;
  EXPECT_NE(text.find("      2.500 -      2.500 s  asphalt"), std::string::npos) << text;
  ModeTimeline from_zero;
  from_zero.add(12.5, 0, 0.6);
  EXPECT_EQ(from_zero.origin(), 0.0);
  EXPECT_EQ(ModeTimeline().origin(), 0.0);
}

TEST(ModeTimeline, LongTimelinesAreElided) {
  ModeTimeline timeline;
  for (int k = 0; k < 100; ++k) timeline.add(k, k % 2, 1.0);
  const std::string text = timeline.format({"a", "b"}, 10);
  EXPECT_NE(text.find("... 90 more intervals ..."), std::string::npos);
}

}  // namespace
}  // namespace skidimm
