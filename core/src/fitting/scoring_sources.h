// The sample sources the tuner scores a bank from, beyond a log's own replay:
// held-out logs spliced into one run, and a replay that ends as soon as a
// candidate's score can no longer win (the bound a search prunes with).
// Private to the fitting library (tuning.cc).
#ifndef SKIDIMM_CORE_SRC_FITTING_SCORING_SOURCES_H_
#define SKIDIMM_CORE_SRC_FITTING_SCORING_SOURCES_H_

#include <atomic>
#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "skidimm/io/sample_source.h"

namespace skidimm {
namespace fitting {
namespace internal {

// Recorded logs end to end, as one log: each log's steps in turn, its times
// shifted to follow the previous log's last step by `gap` seconds (or by the
// previous log's last step interval when gap is 0), its truth its label where
// one is given.
class SplicedReplay : public SampleSource {
 public:
  SplicedReplay(std::vector<const RecordedLog*> logs, std::vector<std::string> labels, double gap)
      : logs_(std::move(logs)), labels_(std::move(labels)), gap_(gap) {}

  bool next(LogSample* sample) override {
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
  bool has_truth() const override { return true; }

 private:
  std::vector<const RecordedLog*> logs_;
  std::vector<std::string> labels_;
  double gap_;
  std::size_t log_ = 0, index_ = 0;
  double shift_ = 0.0, last_t_ = 0.0, last_interval_ = 1.0;
  long row_ = 0;
};

// A candidate's score while it is computed. The score (summarize()) is a
// weighted sum, with positive weights, of each step's log p(truth), which is
// at most 0: the sum over the steps scored so far can only fall. Once it is
// below what the candidate must beat, the candidate has lost, and the
// scoring stops (every source it reads ends): a search then chooses exactly
// what it would have chosen had every log been scored to its end.
//
// Which candidates lose does not depend on the order the logs are scored in,
// only how soon they are found to: the logs that cost the last full scoring
// most (`costs`, each log's weighted sum, most negative first) are scored
// first, so that a losing candidate crosses the bound after as few steps as
// the search can foresee.
struct ScoreBound {
  ScoreBound(double must_beat, std::vector<double>* log_costs) : threshold(must_beat), costs(log_costs) {}
  const double threshold;
  std::vector<double>* const costs;  // per log; written only for logs scored to their end
  std::atomic<double> so_far{0.0};
  std::atomic<bool> lost{false};

  void add(double term) {
    double seen = so_far.load(std::memory_order_relaxed);
    while (!so_far.compare_exchange_weak(seen, seen + term, std::memory_order_relaxed)) {
    }
    if (seen + term < threshold) lost = true;  // NaN: never
  }
};

// A source that ends early, when its bound says the scoring has lost.
class BoundedSource : public SampleSource {
 public:
  BoundedSource(SampleSource* source, const ScoreBound* bound) : source_(source), bound_(bound) {}
  bool next(LogSample* sample) override { return !bound_->lost && source_->next(sample); }
  bool has_truth() const override { return source_->has_truth(); }

 private:
  SampleSource* source_;
  const ScoreBound* bound_;
};

}  // namespace internal
}  // namespace fitting
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_FITTING_SCORING_SOURCES_H_
