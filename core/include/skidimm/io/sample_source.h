// Where a run's steps come from: a log being read (log_reader.h), or steps
// read once and replayed from memory (RecordedLog), e.g. when `skidimm tune`
// scores the same held-out log under hundreds of candidate settings.
#ifndef SKIDIMM_IO_SAMPLE_SOURCE_H_
#define SKIDIMM_IO_SAMPLE_SOURCE_H_

#include <Eigen/Core>
#include <string>
#include <vector>

namespace skidimm {

// One step of a log, at the filter's rate: what the IMM is given and what it
// is scored against.
struct LogSample {
  double t = 0.0;
  Eigen::VectorXd u;
  Eigen::VectorXd z;           // NaN where not measured at this step
  std::string truth_mode;      // held; empty if the bank has no truth column or none seen yet
  Eigen::VectorXd true_state;  // held true_<state> columns; NaN where absent
  long row = 0;                // 1-based step number
};

class SampleSource {
 public:
  virtual ~SampleSource() = default;
  // Reads the next step. Returns false at the end of the log.
  virtual bool next(LogSample* sample) = 0;
  // Whether the log has the bank's truth column.
  virtual bool has_truth() const = 0;
};

// Steps held in memory, replayed from the first by every reader made with
// replay(). Reading them once costs what one pass of the log costs; every
// replay afterwards costs only the copies.
class RecordedLog {
 public:
  // Reads every step of `source`.
  static RecordedLog record(SampleSource* source);

  const std::vector<LogSample>& samples() const { return samples_; }
  bool has_truth() const { return has_truth_; }

  // A source over the recorded steps; it refers to this RecordedLog, which
  // must outlive it. Any number may read at once.
  class Replay : public SampleSource {
   public:
    explicit Replay(const RecordedLog& log) : log_(&log) {}
    bool next(LogSample* sample) override;
    bool has_truth() const override { return log_->has_truth_; }

   private:
    const RecordedLog* log_;
    std::size_t next_ = 0;
  };
  Replay replay() const { return Replay(*this); }

 private:
  std::vector<LogSample> samples_;
  bool has_truth_ = false;
};

}  // namespace skidimm

#endif  // SKIDIMM_IO_SAMPLE_SOURCE_H_
