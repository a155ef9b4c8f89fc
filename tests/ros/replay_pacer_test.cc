// ReplayPacer: the wall-clock schedule of `skidimm run --serve` replaying a
// file, checked on the times it returns (a clock passed in), never by
// sleeping.
#include "skidimm/io/ros/replay_pacer.h"

#include <gtest/gtest.h>

#include <chrono>
#include <limits>

namespace skidimm {
namespace ros {
namespace {

using Clock = ReplayPacer::Clock;
using std::chrono::milliseconds;
using std::chrono::seconds;

// A fixed reading of the clock to count from.
const Clock::time_point kStart = Clock::time_point() + seconds(1000);

TEST(ReplayPacer, EachRowIsDueItsGapAfterThePreviousRowDividedByTheSpeed) {
  ReplayPacer real_time(1.0);
  EXPECT_EQ(real_time.due(5.0, kStart), kStart);
  EXPECT_EQ(real_time.due(5.5, kStart), kStart + milliseconds(500));
  EXPECT_EQ(real_time.due(6.25, kStart), kStart + milliseconds(1250));
  ReplayPacer four_times(4.0);
  EXPECT_EQ(four_times.due(0.0, kStart), kStart);
  EXPECT_EQ(four_times.due(2.0, kStart), kStart + milliseconds(500));
}

// A filter slower than the replay is behind its schedule; the next rows are
// due on the schedule (at once, as it is past), not a gap after now, so the
// replay catches up instead of drifting.
TEST(ReplayPacer, AReplayThatFellBehindKeepsItsSchedule) {
  ReplayPacer pacer(1.0);
  pacer.due(0.0, kStart);
  EXPECT_EQ(pacer.due(1.0, kStart + seconds(30)), kStart + seconds(1));
  EXPECT_EQ(pacer.due(2.0, kStart + seconds(31)), kStart + seconds(2));
}

// Ten thousand times slower than real time: a 0.02 s step waits 200 s. The
// schedule used to treat every wait over a minute as a jump of the clock,
// and published such a replay unpaced.
TEST(ReplayPacer, ASlowReplayWaitsEveryRowsFullTime) {
  ReplayPacer slow(1e-4);
  slow.due(0.0, kStart);
  EXPECT_EQ(slow.due(0.02, kStart), kStart + seconds(200));
  EXPECT_EQ(slow.due(0.04, kStart), kStart + seconds(400));
}

// A pause in the recording longer than a minute of the log's clock, a clock
// that goes backwards or a time that is not a number: that row at once, and
// the schedule goes on from it.
TEST(ReplayPacer, APauseABackwardsStepOrANanIsDueAtOnceAndTheScheduleGoesOnFromIt) {
  ReplayPacer pacer(2.0);
  pacer.due(0.0, kStart);
  const Clock::time_point later = kStart + seconds(7);
  EXPECT_EQ(pacer.due(ReplayPacer::kLongestPacedGap + 1.0, later), later);
  EXPECT_EQ(pacer.due(ReplayPacer::kLongestPacedGap + 2.0, later), later + milliseconds(500));
  const Clock::time_point after = later + seconds(3);
  EXPECT_EQ(pacer.due(10.0, after), after);
  EXPECT_EQ(pacer.due(11.0, after), after + milliseconds(500));
  EXPECT_EQ(pacer.due(std::numeric_limits<double>::quiet_NaN(), after), after);
  EXPECT_EQ(pacer.due(12.0, after), after + milliseconds(500)) << "12 s is a second after the last time that was one";
  // A minute exactly is still waited.
  ReplayPacer one_minute(1.0);
  one_minute.due(0.0, kStart);
  EXPECT_EQ(one_minute.due(ReplayPacer::kLongestPacedGap, kStart), kStart + seconds(60));
}

// A speed of 1e-300 would make a second of the log 1e300 s: the wait is
// capped, and the clock's count does not overflow.
TEST(ReplayPacer, AnAbsurdlySlowSpeedWaitsAtMostTheLongestWait) {
  ReplayPacer pacer(1e-300);
  pacer.due(0.0, kStart);
  const Clock::time_point due = pacer.due(1.0, kStart);
  EXPECT_EQ(due - kStart, std::chrono::duration_cast<Clock::duration>(
                              std::chrono::duration<double>(ReplayPacer::kLongestWait)));
  EXPECT_GT(due, kStart);
}

}  // namespace
}  // namespace ros
}  // namespace skidimm
