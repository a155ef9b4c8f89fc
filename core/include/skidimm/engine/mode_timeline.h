// ModeTimeline: the dominant (most likely) mode over time, as intervals.
//
// Fed one step at a time, it merges consecutive steps with the same most
// likely mode into an interval and keeps the mean probability of that mode
// over it. This is the summary `skidimm run` prints.
#ifndef SKIDIMM_ENGINE_MODE_TIMELINE_H_
#define SKIDIMM_ENGINE_MODE_TIMELINE_H_

#include <string>
#include <vector>

namespace skidimm {

struct ModeInterval {
  int mode = 0;        // ModeTimeline::kTie where no mode was ahead
  double start = 0.0;  // time of the first step in the interval (s)
  double end = 0.0;    // time of the last step in the interval (s)
  long steps = 0;
  double mean_probability = 0.0;
};

class ModeTimeline {
 public:
  // The mode of a step where two or more modes share the top probability
  // (the first step of a bank with uniform initial probabilities): no mode
  // is ahead, and naming the first of them would say one was.
  static constexpr int kTie = -1;

  void add(double t, int most_likely_mode, double probability);
  const std::vector<ModeInterval>& intervals() const { return intervals_; }
  long steps() const { return steps_; }
  // How many times the most likely mode changed: from one mode to another,
  // across any ties between them (a tie and the mode after it is no change).
  long changes() const;

  // A readable table, at most `max_rows` intervals (the first and last halves
  // when there are more), with the mode names. Times are the steps' own,
  // or from origin() where that is not 0.
  std::string format(const std::vector<std::string>& mode_names, std::size_t max_rows = 40) const;
  // What format() subtracts from the times: time_origin() of the first step
  // (skidimm/time_origin.h), as plot counts from it.
  double origin() const;

 private:
  std::vector<ModeInterval> intervals_;
  long steps_ = 0;
};

}  // namespace skidimm

#endif  // SKIDIMM_ENGINE_MODE_TIMELINE_H_
