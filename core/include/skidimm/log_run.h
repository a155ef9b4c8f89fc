// Running a bank over a log, step by step: the filter's estimates, or the
// smoother's (imm_smoother.h), fixed-interval over the whole log or with a
// fixed lag. What `skidimm run` writes and `skidimm eval` scores.
#ifndef SKIDIMM_LOG_RUN_H_
#define SKIDIMM_LOG_RUN_H_

#include <functional>

#include "skidimm/bank.h"
#include "skidimm/imm_estimate.h"
#include "skidimm/log_reader.h"

namespace skidimm {

struct EstimatorOptions {
  enum class Kind {
    kFilter,         // causal: each step given the log up to it
    kFixedInterval,  // each step given the whole log (the log is held in memory)
    kFixedLag,       // each step given the log up to `lag` seconds after it
  };
  Kind kind = Kind::kFilter;
  double lag = 0.0;  // s, kFixedLag
};

// Calls sink(sample, estimate) for every step of the log in time order. For
// the smoothers, `estimate` holds the smoothed probabilities, mode states
// and combined state (the filter's status, likelihoods and NIS). Steps the
// filter rejected (rejected_time, rejected_input) are passed through with the
// filter's estimate. Returns the number of steps.
long run_log(const Bank& bank, LogReader* reader, const EstimatorOptions& options,
             const std::function<void(const LogSample&, const ImmEstimate&)>& sink);

}  // namespace skidimm

#endif  // SKIDIMM_LOG_RUN_H_
