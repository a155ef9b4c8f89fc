#include "skidimm/evaluation/log_scores.h"

#include <utility>

namespace skidimm {
namespace evaluation {

LogScore score_of(const LogResult& r) {
  LogScore s;
  s.log = r.name;
  s.truth = main_truth(r.metrics);
  s.accuracy = r.metrics.accuracy();
  s.mean_log_probability = r.metrics.mean_truth_log_probability();
  s.seconds = r.metrics.duration;
  return s;
}

ScoreSummary summarize(const std::vector<LogScore>& scores) {
  ScoreSummary s;
  std::map<std::string, std::pair<double, double>> sums;  // accuracy, log p
  std::map<std::string, int> counts;
  for (const LogScore& l : scores) {
    sums[l.truth].first += l.accuracy;
    sums[l.truth].second += l.mean_log_probability;
    ++counts[l.truth];
  }
  for (const auto& [c, sum] : sums) {
    s.class_accuracy[c] = sum.first / counts[c];
    s.class_log_probability[c] = sum.second / counts[c];
    s.accuracy += s.class_accuracy[c];
    s.mean_log_probability += s.class_log_probability[c];
  }
  if (!sums.empty()) {
    s.accuracy /= static_cast<double>(sums.size());
    s.mean_log_probability /= static_cast<double>(sums.size());
  }
  return s;
}

}  // namespace evaluation
}  // namespace skidimm
