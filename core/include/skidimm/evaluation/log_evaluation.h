// Running a bank over a labelled log and scoring it: what `skidimm eval`
// prints and `skidimm tune` maximises.
//
// Truth comes from the log's label (LABEL=FILE on the command line) or else
// the bank's truth column, and may name a mode or a class (`classes:` in the
// bank). Scores are by class: a class's probability is the sum of its modes',
// and the estimate is the most probable class. A bank without classes scores
// every mode as its own class, which is mode identification.
#ifndef SKIDIMM_EVALUATION_LOG_EVALUATION_H_
#define SKIDIMM_EVALUATION_LOG_EVALUATION_H_

#include <Eigen/Core>
#include <filesystem>
#include <functional>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "skidimm/config/bank.h"
#include "skidimm/engine/log_run.h"
#include "skidimm/evaluation/consistency.h"
#include "skidimm/evaluation/extrapolation_counts.h"
#include "skidimm/evaluation/mode_metrics.h"
#include "skidimm/io/log_reader.h"

namespace skidimm {
namespace evaluation {

// Turns mode probabilities into a scored step.
class ClassScorer {
 public:
  explicit ClassScorer(const BankConfig& bank);

  const std::vector<std::string>& class_names() const { return names_; }
  // The class index of a mode or class name; -1 if neither.
  int class_of_label(const std::string& label) const;
  // The step for truth `label` ("" for unlabelled) given the modes' probabilities.
  // With an unknown hypothesis (BankConfig::unknown) the mode probabilities
  // sum to 1 - unknown_probability; when "none of these" outweighs every
  // class, the estimate is "unknown" at probability 0, as the decision's
  // "unknown" is: never right, never confident. For the probability of the
  // truth (log p, Brier) its probability is spread evenly over the classes:
  // "none of these" scores as a uniform guess, no better, no worse.
  LabelledStep score(double t, const std::string& label, const Eigen::VectorXd& mode_probabilities,
                     double unknown_probability = 0.0) const;
  // The same step with a decision for its estimate (a class name or
  // "unknown"), and that class's probability, from the last score().
  LabelledStep decided(const LabelledStep& step, const std::string& decision) const;
  // The class indices of the last score()'s estimate and truth; -1 for
  // "unknown", an unlabelled step or a truth the bank lacks.
  int last_estimate() const { return last_estimate_; }
  int last_truth() const { return last_truth_; }

 private:
  const BankConfig* bank_;
  std::vector<std::string> names_;
  std::vector<int> class_of_mode_;
  mutable Eigen::VectorXd class_probabilities_;
  mutable int last_estimate_ = -1;
  mutable int last_truth_ = -1;
};

// One log's results.
struct LogResult {
  std::string name;    // for tables: the files' names joined by '+' (distinct_names(), log_spec.h)
  std::string source;  // the log as given: its files' paths joined by '+' (eval --json keys logs by it)
  std::vector<std::string> classes;  // what the estimator answers with, in the bank's order
  ModeMetrics metrics;           // of the most likely mode (class)
  ModeMetrics decision_metrics;  // of the decision (decision.h), "unknown" counted wrong
  std::map<std::string, NisAccumulator> nis;  // per true mode, while it is the truth
  std::vector<double> squared_state_error;    // per state, against true_<state> columns
  std::vector<long> state_error_count;
  long steps = 0;
  // The smallest probability the filter gave any mode, or the unknown
  // hypothesis, at any step: the bank's mode_probability_floor changed a
  // step if and only if this is at most the floor. NaN where not tracked
  // (smoothed estimates, a spliced run's logs).
  double smallest_probability = std::numeric_limits<double>::quiet_NaN();
  // Steps outside the input ranges the classes were fitted on (input_envelope.h).
  ExtrapolationCounts extrapolation;
  // Per mode, once one was rejected or gated: how often and the first time
  // why (log_run.h), so that a model failing is said, not only scored.
  std::vector<ModeRejections> rejections;
  long steps_every_mode_rejected = 0;  // steps where no mode's filter ran
  // The log reader's words for each measurement that had no value at any
  // step (LogReader::unmeasured()): scored on the others, so said.
  std::vector<std::string> unmeasured;
  // ... and for what the bank's options left out of the log
  // (LogReader::skipped_by_options()): scored without it, so said too.
  std::vector<std::string> skipped;
};

// Runs a fresh IMM of `bank` over `log` and scores it; with `estimates`, also
// writes the steps there as `skidimm run` does (estimates_writer.h). Throws
// Error when the log has neither a label nor the bank's truth column, and
// LogError on bad rows.
// `estimator`: score the filter's probabilities (default) or the smoother's.
LogResult evaluate_log(const Bank& bank, const LogSpec& log, const SamplingConfig& sampling,
                       const std::filesystem::path& estimates = {}, const EstimatorOptions& estimator = {});

// Called with each step as it is scored, in order: what a caller needs to
// follow a scoring as it goes (tune stops a candidate's scoring, by ending its
// source, once the steps so far show it cannot win).
using StepObserver = std::function<void(const LogSample&, const LabelledStep&)>;

// The same over steps from any source (e.g. a RecordedLog's replay), named
// `name` in the result; `label` (may be empty: the source's truth column) is
// the truth for every step. The caller has checked that there is a truth.
LogResult evaluate_log(const Bank& bank, SampleSource* source, const std::string& name, const std::string& label,
                       const std::filesystem::path& estimates = {}, const EstimatorOptions& estimator = {},
                       const StepObserver& observer = {});

// Every step of `log` read into memory, after the checks evaluate_log()
// makes: a truth for it (its label, a class of the bank, or the bank's truth
// column in the log). For splicing logs (SplicedReplay) to score as one run.
// `said` (optional) gets what LogResult::unmeasured and ::skipped would say of the log.
RecordedLog record_labelled_log(const BankConfig& config, const LogSpec& log, const SamplingConfig& sampling,
                                LogResult* said = nullptr);

// Several logs spliced end to end into one run (`source` gives their steps
// in turn, `steps_per_log[i]` of log i, each with its truth in the sample's
// truth_mode): one IMM over all of them, as a robot that drives from one
// terrain onto the next. Returns one result per log, over its own steps,
// named names[i]; `whole` (optional) gets the whole run's, whose switches
// are the changes from one log's truth to the next. The first step of each
// log scores how the run so far left the filter, as a real change would.
// With `estimates`, the whole run's steps are written there, as `skidimm run` does.
std::vector<LogResult> evaluate_spliced(const Bank& bank, SampleSource* source, const std::vector<std::string>& names,
                                        const std::vector<long>& steps_per_log, LogResult* whole = nullptr,
                                        const std::filesystem::path& estimates = {});

}  // namespace evaluation
}  // namespace skidimm

#endif  // SKIDIMM_EVALUATION_LOG_EVALUATION_H_
