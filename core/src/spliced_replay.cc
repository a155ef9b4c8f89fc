#include "skidimm/io/spliced_replay.h"

#include <utility>

namespace skidimm {

SplicedReplay::SplicedReplay(std::vector<const RecordedLog*> logs, std::vector<std::string> labels, double gap)
    : logs_(std::move(logs)), labels_(std::move(labels)), gap_(gap) {}

bool SplicedReplay::next(LogSample* sample) {
  while (log_ < logs_.size()) {
    const std::vector<LogSample>& samples = logs_[log_]->samples();
    if (index_ >= samples.size()) {
      ++log_;
      index_ = 0;
      continue;
    }
    if (index_ == 0) {
      const double gap = gap_ > 0.0 ? gap_ : last_interval_;
      shift_ = log_ == 0 ? 0.0 : last_t_ + gap - samples.front().t;
    }
    *sample = samples[index_];
    sample->t += shift_;
    if (!labels_[log_].empty()) sample->truth_mode = labels_[log_];
    sample->row = ++row_;
    if (index_ > 0) last_interval_ = sample->t - last_t_;
    last_t_ = sample->t;
    ++index_;
    return true;
  }
  return false;
}

}  // namespace skidimm
