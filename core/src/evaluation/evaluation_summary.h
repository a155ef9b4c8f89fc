// The reduction of per-log results (log_evaluation.h) into what `skidimm
// eval` reports for a group of logs, for every front end: the CLI reduces
// logs it evaluated, Python and Dask logs evaluated elsewhere whose
// LogResults came back. Merged in the order given, so the figures are the
// same to the last digit whoever reduces the same logs in the same order.
#ifndef SKIDIMM_CORE_SRC_EVALUATION_EVALUATION_SUMMARY_H_
#define SKIDIMM_CORE_SRC_EVALUATION_EVALUATION_SUMMARY_H_

#include <cstddef>
#include <map>
#include <string>
#include <vector>

#include "skidimm/evaluation/consistency.h"
#include "skidimm/evaluation/log_evaluation.h"
#include "skidimm/evaluation/log_scores.h"
#include "skidimm/evaluation/mode_metrics.h"

namespace skidimm {
namespace evaluation {

// The spread of a figure over logs.
struct PerLogSpread {
  double mean = 0.0;                // NaN over no log
  double standard_deviation = 0.0;  // the sample's (n - 1); 0 under two logs
  double min = 0.0;                 // NaN over no log
};

struct EvaluationSummary {
  ExtrapolationCounts extrapolation;  // over every log
  ModeMetrics metrics;    // of the most likely mode (class), merged over the logs
  ModeMetrics decisions;  // of the decision
  std::map<std::string, NisAccumulator> nis;  // per true mode
  std::vector<double> state_rmse;             // per state; NaN without true_<state> values
  std::size_t logs = 0;                       // every log summarized, scored or not
  std::vector<double> accuracies;             // per log with labelled time
  std::vector<double> decision_accuracies;    // per log with a decision (an estimates file may have no column of it)
  PerLogSpread accuracy_per_log;              // of `accuracies`
  PerLogSpread decision_accuracy_per_log;     // of `decision_accuracies`
  long decision_lost = 0;  // switches the most likely mode detected and the decision never did
  // Over classes, each scored over its own true time (ModeMetrics::truth_accuracy):
  // the mean of their accuracies and of their mean log p(truth). A class that
  // is the truth for a moment of a switching log counts as much as one that
  // is the truth of whole logs. NaN without labelled time.
  double mean_class_accuracy = 0.0;
  double mean_class_log_probability = 0.0;
  // tune's figure (log_scores.h): each log counted for its main truth only,
  // per class the mean over its logs, then the mean over classes; and the
  // logs' scores it is the mean of (those with labelled time).
  ScoreSummary by_log_class;
  std::vector<LogScore> log_scores;
};

// The truths of `m` in `classes`' order, then any other (a truth the bank
// does not have) by name: the order of a confusion's rows and columns.
std::vector<std::string> truths_in_order(const ModeMetrics& m, const std::vector<std::string>& classes);

// `states`: how many states the bank has (state RMSE), 0 when unknown.
EvaluationSummary summarize(const std::vector<const LogResult*>& logs, std::size_t states);

// How fast an estimate followed the true switches of `m`.
struct LatencyStats {
  long switches = 0;
  long detected = 0;
  double median = 0.0, mean = 0.0, max = 0.0;  // s over detected switches; NaN when none
  double median_changes = 0.0;  // estimate changes per switch, the median over switches; NaN when none
};
// Over the switches' settled latencies, or (`first`) their first-detection ones.
LatencyStats latency_stats(const ModeMetrics& m, bool first = false);

}  // namespace evaluation
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_EVALUATION_EVALUATION_SUMMARY_H_
