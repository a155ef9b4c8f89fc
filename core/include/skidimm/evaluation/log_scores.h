// Scores of whole logs and their mean over classes: the figure `skidimm
// tune` chooses settings by, and which `skidimm eval` reports next to its
// time-based figures so the two can be compared.
//
// A log's class here is its main truth (the class with the most time in
// it); a class's score is the mean over its logs, and the summary the mean
// over classes, so that a class with many logs weighs as much as one with few.
#ifndef SKIDIMM_EVALUATION_LOG_SCORES_H_
#define SKIDIMM_EVALUATION_LOG_SCORES_H_

#include <map>
#include <string>
#include <vector>

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
};

// Over logs: mean over classes of the mean over each class's logs.
struct ScoreSummary {
  double accuracy = 0.0;
  double mean_log_probability = 0.0;
  std::map<std::string, double> class_accuracy;
  std::map<std::string, double> class_log_probability;
};

// A log's result as its score (name, main truth, accuracy, mean log p(truth), labelled seconds).
LogScore score_of(const LogResult& result);

ScoreSummary summarize(const std::vector<LogScore>& scores);

}  // namespace evaluation
}  // namespace skidimm

#endif  // SKIDIMM_EVALUATION_LOG_SCORES_H_
