// The sample source the tuner scores a bank from, beyond a log's own replay
// and held-out logs spliced into one run (spliced_replay.h): a replay that
// ends as soon as a candidate's score can no longer win (the bound a search
// prunes with).
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
