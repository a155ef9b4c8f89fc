// Progress of long work, for a person watching a terminal: how far, how fast
// and how long still to go. Shown only when stderr is a terminal: a log file
// or a pipe gets none of it, so what a script captures is the same from run
// to run and never fills with carriage returns.
#ifndef SKIDIMM_PROGRESS_H_
#define SKIDIMM_PROGRESS_H_

#include <chrono>
#include <string>
#include <utility>

namespace skidimm {

// "0:07", "12:05", "1:02:03": whole seconds, rounded up (a wait of 0.2 s
// left is shown as 0:01, never as nothing left).
std::string format_duration(double seconds);

// The rate and the time left of work `done` of `total` units after
// `elapsed_seconds`: "1500 rows/s, 0:42 left". With `total` <= 0 (not known)
// the time so far instead: "3.4 iterations/s, 0:12 so far". The time left
// assumes the rate so far continues; `fraction` (0..1, or negative for
// done / total) measures how far when the units are not what is counted
// (bytes of a log read, while rows are counted). Rates below 10 keep two
// significant digits, larger ones are whole numbers. Empty before any unit
// is done or kSettleSeconds have passed: a rate over less is noise (a first
// solver iteration in microseconds would promise millions per second).
constexpr double kSettleSeconds = 1.0;
std::string format_rate_and_time_left(long done, long total, double elapsed_seconds, const std::string& unit,
                                      double fraction = -1.0);

// Whether stderr is a terminal: the rule for every progress display.
bool stderr_is_terminal();

// One line on stderr, rewritten in place at most five times a second:
// "skidimm run:  42.0%  3000 rows, 1500 rows/s, 0:04 left". Shows nothing
// unless `enabled` and stderr is a terminal; cleared when destroyed.
class ProgressLine {
 public:
  ProgressLine(std::string label, std::string unit, bool enabled);
  ~ProgressLine();
  ProgressLine(const ProgressLine&) = delete;
  ProgressLine& operator=(const ProgressLine&) = delete;

  bool enabled() const { return enabled_; }
  // `done` units of `total` (<= 0: not known); `fraction` as for
  // format_rate_and_time_left; `what` (may be empty) says what is being done.
  void update(long done, long total, double fraction = -1.0, const std::string& what = "");
  // Restarts the clock (a new stage of the work).
  void restart();
  void clear();

 private:
  bool enabled_;
  bool shown_ = false;
  std::string label_, unit_;
  std::chrono::steady_clock::time_point start_, last_{};
};

// Progress of work in stages of unknown length (a fit's solves, one per
// mode): one ProgressLine whose clock restarts when the stage changes,
// "skidimm fit: mode 'ice' (window objective)  12 iterations, 3.4 iterations/s,
// 0:04 so far". Callable as a fitting::FitProgress.
class StagedProgress {
 public:
  StagedProgress(std::string label, std::string unit, bool enabled)
      : line_(std::move(label), std::move(unit), enabled) {}
  bool enabled() const { return line_.enabled(); }
  void operator()(const std::string& stage, long done) {
    if (stage != stage_) {
      stage_ = stage;
      line_.restart();
    }
    line_.update(done, 0, -1.0, stage);
  }
  void clear() { line_.clear(); }

 private:
  ProgressLine line_;
  std::string stage_;
};

}  // namespace skidimm

#endif  // SKIDIMM_PROGRESS_H_
