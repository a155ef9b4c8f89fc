// Recorded logs end to end, as one log: a robot that drives from one
// terrain onto the next, made of runs that each hold one (tune --splice,
// eval --splice).
#ifndef SKIDIMM_IO_SPLICED_REPLAY_H_
#define SKIDIMM_IO_SPLICED_REPLAY_H_

#include <cstddef>
#include <string>
#include <vector>

#include "skidimm/io/sample_source.h"

namespace skidimm {

// Each log's steps in turn, its times shifted to follow the previous log's
// last step by `gap` seconds (or by the previous log's last step interval
// when gap is 0), its truth its label where one is given (else its own truth
// column's). The logs must outlive the replay.
class SplicedReplay : public SampleSource {
 public:
  SplicedReplay(std::vector<const RecordedLog*> logs, std::vector<std::string> labels, double gap);

  bool next(LogSample* sample) override;
  bool has_truth() const override { return true; }

 private:
  std::vector<const RecordedLog*> logs_;
  std::vector<std::string> labels_;
  double gap_;
  std::size_t log_ = 0, index_ = 0;
  double shift_ = 0.0, last_t_ = 0.0, last_interval_ = 1.0;
  long row_ = 0;
};

// The items of `groups` in the order a splice takes them: the first of each
// group in order, then the second of each, and so on (the groups, terrains
// say, taking turns while each has items left).
template <typename T>
std::vector<T> taking_turns(const std::vector<std::vector<T>>& groups) {
  std::vector<T> order;
  for (std::size_t round = 0, placed = 1; placed > 0; ++round) {
    placed = 0;
    for (const std::vector<T>& group : groups) {
      if (round < group.size()) {
        order.push_back(group[round]);
        ++placed;
      }
    }
  }
  return order;
}

}  // namespace skidimm

#endif  // SKIDIMM_IO_SPLICED_REPLAY_H_
