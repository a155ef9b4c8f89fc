// Scores of whole logs and their mean over classes: the figure `skidimm
// tune` chooses settings by, and which `skidimm eval` reports next to its
// time-based figures so the two can be compared.
//
// A log's class here is its main truth (the class with the most time in
// it); a class's score is the mean over its logs, and the summary the mean
// over classes, so that a class with many logs weighs as much as one with few.
#ifndef SKIDIMM_EVALUATION_LOG_SCORES_H_
#define SKIDIMM_EVALUATION_LOG_SCORES_H_

#include <limits>
#include <map>
#include <string>
#include <vector>

#include "skidimm/evaluation/extrapolation_counts.h"
#include "skidimm/evaluation/log_evaluation.h"

namespace skidimm {
namespace evaluation {

// One log's score.
struct LogScore {
  std::string log;
  std::string truth;  // the class with the most time in it
  double accuracy = 0.0;
  double mean_log_probability = 0.0;
  double seconds = 0.0;
  std::string settings;  // what scored it, when several did (tune's nested folds: the fold's settings)
  // tune's nested folds: which held-out set of its protocol scored the log
  // (0, 1, ... in the protocol's order), and the mean log p(truth) by which
  // that set's settings were chosen, over the other logs alone (the inner
  // cross-validation's). What a choice made inside the outer loop, between
  // two banks say, compares: the set's own scores never enter it. -1 and NaN
  // elsewhere.
  int fold = -1;
  double selection_score = std::numeric_limits<double>::quiet_NaN();
  double smallest_probability = std::numeric_limits<double>::quiet_NaN();  // LogResult's
  ExtrapolationCounts extrapolation;                                       // LogResult's
  // LogResult's: the steps, and per mode its filter's rejections, so that a
  // model that fails is said where the log is only scored (tune).
  long steps = 0;
  std::vector<ModeRejections> rejections;
  // LogResult's decision (decision.h): the share of the labelled time it was
  // right, and the share it was `unknown` (counted wrong there); NaN where
  // the log's result has no decision scored.
  double decision_accuracy = std::numeric_limits<double>::quiet_NaN();
  double decision_unknown = std::numeric_limits<double>::quiet_NaN();
};

// Over logs: mean over classes of the mean over each class's logs.
struct ScoreSummary {
  double accuracy = 0.0;
  double mean_log_probability = 0.0;
  std::map<std::string, double> class_accuracy;
  std::map<std::string, double> class_log_probability;
  // The decision's shares of time right and `unknown` (LogScore's), as
  // summarised alike over the logs that have them; NaN where none has.
  double decision_accuracy = std::numeric_limits<double>::quiet_NaN();
  double decision_unknown = std::numeric_limits<double>::quiet_NaN();
};

// A log's result as its score (name, main truth, accuracy, mean log p(truth), labelled seconds).
LogScore score_of(const LogResult& result);

ScoreSummary summarize(const std::vector<LogScore>& scores);

// Whether scored logs tell their classes apart at all: a guess that gives
// each of K classes probability 1/K scores log p(truth) = -log K at every
// step, so a bank whose held-out mean log p(truth) is no higher has learnt
// nothing these logs can show, however its accuracy reads (K = 4: 25%, by
// chance). Over logs: the mean of each log's mean log p(truth) and its
// standard error; the classes whose own mean is no better than the guess.
struct Separability {
  enum class Verdict {
    kSeparated,     // the mean is above the guess by more than two standard errors
    kUnclear,       // above it, by less
    kNotSeparated,  // at or below it, by at most two standard errors
    kWorse,         // below it by more: surer of wrong classes than the guess
  };
  int classes = 0;
  double uniform = 0.0;  // log(1/K)
  double mean = 0.0;
  double standard_error = 0.0;  // 0 over fewer than two logs
  double accuracy = 0.0;        // mean over logs of each log's accuracy
  int logs = 0;
  Verdict verdict = Verdict::kNotSeparated;
  std::vector<std::string> not_separated;  // classes at or below the guess
  // One or two sentences for a user: what the logs show, and what to do
  // about it when they show nothing.
  std::string describe() const;
  // The accuracy well above chance (by a quarter or more) where the log
  // probability is not: the classes differ, and the probabilities are too
  // sure when wrong, which tempering them mends, not other logs.
  bool overconfident() const { return classes > 0 && accuracy >= 1.0 / classes + 0.25; }
};
// `classes`: K, the number of classes the bank answers with (>= 2).
Separability separability(const std::vector<LogScore>& scores, int classes);

}  // namespace evaluation
}  // namespace skidimm

#endif  // SKIDIMM_EVALUATION_LOG_SCORES_H_
