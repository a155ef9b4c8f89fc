#include "skidimm/io/sample_source.h"

namespace skidimm {

RecordedLog RecordedLog::record(SampleSource* source) {
  RecordedLog log;
  log.has_truth_ = source->has_truth();
  LogSample sample;
  while (source->next(&sample)) log.samples_.push_back(sample);
  return log;
}

bool RecordedLog::Replay::next(LogSample* sample) {
  if (next_ >= log_->samples_.size()) return false;
  *sample = log_->samples_[next_++];
  return true;
}

}  // namespace skidimm
