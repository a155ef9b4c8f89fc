// Running a bank over a log, step by step: the filter's estimates, or the
// smoother's (imm_smoother.h), fixed-interval over the whole log or with a
// fixed lag. What `skidimm run` writes and `skidimm eval` scores.
#ifndef SKIDIMM_ENGINE_LOG_RUN_H_
#define SKIDIMM_ENGINE_LOG_RUN_H_

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "skidimm/config/bank.h"
#include "skidimm/engine/imm_checkpoint.h"
#include "skidimm/engine/imm_estimate.h"
#include "skidimm/engine/input_envelope.h"
#include "skidimm/engine/mode_timeline.h"
#include "skidimm/io/estimates_writer.h"
#include "skidimm/io/log_reader.h"

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

// A filter's run that goes on from an earlier one (`skidimm run --resume`,
// --save-checkpoint): the filter only, not a smoother.
struct RunContinuation {
  // Where the run's Imm (and decision, if the checkpoint has one) start; the
  // log's first step must come after the checkpoint's time. May be null.
  const ImmCheckpoint* resume = nullptr;
  // When not null, set to the Imm's (and decision's) checkpoint after the
  // last step, also when the run ends on an error.
  std::optional<ImmCheckpoint>* last = nullptr;
  // When given, called with the checkpoint after the first step and then
  // after each step `every` seconds of the log's time past the last call
  // (a live run that may be killed outright keeps a recent one).
  double every = 0.0;
  std::function<void(const ImmCheckpoint&)> save;
};

// Calls sink(sample, estimate) for every step of the log in time order. For
// the smoothers, `estimate` holds the smoothed probabilities, mode states
// and combined state (the filter's status, likelihoods and NIS). Steps the
// filter rejected (rejected_time, rejected_input) are passed through with the
// filter's estimate. Returns the number of steps.
// `continuation`: where the filter starts and its checkpoint at the end (the
// decision's part is left empty here).
long run_log(const Bank& bank, SampleSource* reader, const EstimatorOptions& options,
             const std::function<void(const LogSample&, const ImmEstimate&)>& sink,
             const RunContinuation& continuation = {});

// How often one mode's filter was rejected (and reset) over a run, and the
// first time why; and how often it gated the measurement.
struct ModeRejections {
  long rows = 0;                           // rows where this mode's filter was rejected (is_rejection)
  long by_failure[kNumModeFailures] = {};  // rows by ModeFailure, kGated included
  long first_row = 0;                 // the first such row (1-based, as in the output)
  double first_t = 0.0;
  ModeFailure first_failure = ModeFailure::kNone;
  std::string first_reason;  // the model's own words (ModeFailure::kModel)
};

// Counts the rejected and gated modes of step `e`, the `row`-th (1-based) at
// time `t`, into `rejections` (one per mode, made on the first count).
void count_mode_rejections(const ImmEstimate& e, long row, double t, std::vector<ModeRejections>* rejections);

// What `skidimm run` reports about a log besides its rows.
struct RunSummary {
  long rows = 0;
  long truth_rows = 0;        // rows with a truth label
  long truth_matches = 0;     // ... whose most likely mode's class is the truth's
  long predict_only = 0;      // rows without a measurement
  long rejected = 0;          // rows where at least one mode's filter failed or diverged (and was reset)
  long gated = 0;             // rows whose measurement every mode gated (status gated)
  long mode_gated = 0;        // rows whose measurement some modes gated (status mode_gated or mode_reset)
  long decision_changes = 0;  // changes of the decision after its first out of a leading `unknown` (as eval counts)
  long decision_unknown = 0;  // rows whose decision was `unknown`
  double first_t = 0.0;       // s, the first and the last row's time
  double last_t = 0.0;
  // Rows whose inputs were outside the ranges the most likely class was
  // fitted on (input_envelope.h; 0 for a bank that records none), and the
  // farthest out of them, in the terms of that class.
  long outside_fitted_inputs = 0;
  Excursion farthest_outside;
  int farthest_outside_class = -1;
  ModeTimeline timeline;      // the most likely mode over time
  // One per mode once a mode's filter was rejected or gated (empty until then).
  std::vector<ModeRejections> rejections;
};

// What `skidimm run --strict` throws at the first row where a mode's filter
// was rejected: an Error naming the row, the mode, its plugin file and the
// reason. The row itself has been written.
std::string describe_first_rejection(const Bank& bank, const ImmEstimate& e, long row);

// `skidimm run`'s loop: runs the log (run_log), decides each step
// (decision.h, with `decision` settings), writes it (`writer`, whose truth
// column, if any, gets `label` or else the log's truth column) and counts into
// *summary as it goes, so that a caller catching an error knows how many rows
// were written. `progress` (may be empty) is called every 1024 rows.
//
// With the filter (not a smoother), nothing here allocates per row: the log
// is read in place, the step allocates nothing, numbers are formatted into
// the writer's buffer. (The timeline grows by an interval when the most likely
// mode changes, amortised; a longer truth label than any before is copied.)
// `strict`: the first row with a rejected mode filter is written, then an
// Error (describe_first_rejection) ends the run; a gated measurement is not a
// rejection.
void write_estimates(const Bank& bank, SampleSource* reader, const EstimatorOptions& options,
                     const DecisionConfig& decision, const std::string& label, bool with_truth, EstimatesWriter* writer,
                     RunSummary* summary, const std::function<void()>& progress = {}, bool strict = false,
                     const RunContinuation& continuation = {});

}  // namespace skidimm

#endif  // SKIDIMM_ENGINE_LOG_RUN_H_
