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

}  // namespace skidimm

#endif  // SKIDIMM_IO_SPLICED_REPLAY_H_
