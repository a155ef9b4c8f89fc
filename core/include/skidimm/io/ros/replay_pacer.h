// ReplayPacer: when each row of a recorded log is due on the wall clock,
// replayed `speed` times real time (`skidimm run --serve --serve-speed`).
//
// The schedule keeps the log's own spacing: each row is due its gap from
// the previous row, divided by `speed`, after that row was due, so a filter
// that falls behind catches up without drifting. A gap the replay should not
// wait out (longer than kLongestPacedGap seconds of the log's clock: a pause
// in the recording, a clock jump; or backwards) makes its row due at once
// and the schedule goes on from there. The gap is judged on the log's clock,
// not on the wait it would cost, so a slow replay (speed 1e-4: ten thousand
// times slower than the robot drove) waits every row's full time.
#ifndef SKIDIMM_IO_ROS_REPLAY_PACER_H_
#define SKIDIMM_IO_ROS_REPLAY_PACER_H_

#include <chrono>
#include <cmath>

namespace skidimm {
namespace ros {

class ReplayPacer {
 public:
  using Clock = std::chrono::steady_clock;
  // Seconds of the log's clock between two rows beyond which the replay
  // does not wait.
  static constexpr double kLongestPacedGap = 60.0;
  // One row's wait is at most this many seconds (a tiny speed times a long
  // gap would overflow the clock's count).
  static constexpr double kLongestWait = 1e9;

  // speed > 0 (times real time).
  explicit ReplayPacer(double speed) : speed_(speed) {}

  // When the row at log time `t` is due, the wall clock reading `now`.
  Clock::time_point due(double t, Clock::time_point now) {
    if (!started_) {
      started_ = true;
      due_ = now;
    } else {
      const double gap = t - previous_t_;
      if (gap >= 0.0 && gap <= kLongestPacedGap) {
        const double wait = gap / speed_ < kLongestWait ? gap / speed_ : kLongestWait;
        due_ += std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(wait));
      } else {
        due_ = now;  // NaN, backwards or a pause: at once
      }
    }
    if (std::isfinite(t)) previous_t_ = t;
    return due_;
  }

 private:
  double speed_;
  bool started_ = false;
  double previous_t_ = 0.0;
  Clock::time_point due_;
};

}  // namespace ros
}  // namespace skidimm

#endif  // SKIDIMM_IO_ROS_REPLAY_PACER_H_
