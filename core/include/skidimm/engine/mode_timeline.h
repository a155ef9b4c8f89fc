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
  int mode = 0;
  double start = 0.0;  // time of the first step in the interval (s)
  double end = 0.0;    // time of the last step in the interval (s)
  long steps = 0;
  double mean_probability = 0.0;
};

class ModeTimeline {
 public:
  void add(double t, int most_likely_mode, double probability);
  const std::vector<ModeInterval>& intervals() const { return intervals_; }
  long steps() const { return steps_; }

  // A readable table, at most `max_rows` intervals (the first and last halves
  // when there are more), with the mode names.
  std::string format(const std::vector<std::string>& mode_names, std::size_t max_rows = 40) const;

 private:
  std::vector<ModeInterval> intervals_;
  long steps_ = 0;
};

}  // namespace skidimm

#endif  // SKIDIMM_ENGINE_MODE_TIMELINE_H_
