#include "evaluation_summary.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "not_a_number.h"

namespace skidimm {
namespace evaluation {

namespace {

using ::skidimm::internal::kNaN;

double mean(const std::vector<double>& v) {
  double sum = 0.0;
  for (double x : v) sum += x;
  return v.empty() ? kNaN : sum / v.size();
}

PerLogSpread spread(const std::vector<double>& v) {
  PerLogSpread s;
  s.mean = mean(v);
  s.standard_deviation = 0.0;
  if (v.size() >= 2) {
    double sum = 0.0;
    for (double x : v) sum += (x - s.mean) * (x - s.mean);
    s.standard_deviation = std::sqrt(sum / (v.size() - 1));
  }
  s.min = v.empty() ? kNaN : *std::min_element(v.begin(), v.end());
  return s;
}

double median_of_sorted(const std::vector<double>& v) {
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

}  // namespace

EvaluationSummary summarize(const std::vector<const LogResult*>& logs, std::size_t states) {
  EvaluationSummary s;
  std::vector<double> squared(states, 0.0);
  std::vector<long> counts(states, 0);
  std::vector<LogScore> scores;
  s.logs = logs.size();
  for (const LogResult* log : logs) {
    s.metrics.merge(log->metrics);
    s.extrapolation.merge(log->extrapolation);
    s.decisions.merge(log->decision_metrics);
    if (log->decision_metrics.duration > 0.0) s.decision_lost += switches_lost(log->metrics, log->decision_metrics);
    for (const auto& [mode, acc] : log->nis) s.nis[mode].merge(acc);
    for (std::size_t i = 0; i < log->squared_state_error.size() && i < states; ++i) {
      squared[i] += log->squared_state_error[i];
      counts[i] += log->state_error_count[i];
    }
    // A log without labelled time has no accuracy: a 0 would pull every mean down.
    if (!(log->metrics.duration > 0.0)) continue;
    s.accuracies.push_back(log->metrics.accuracy());
    if (log->decision_metrics.duration > 0.0) s.decision_accuracies.push_back(log->decision_metrics.accuracy());
    LogScore score = score_of(*log);
    if (!score.truth.empty()) scores.push_back(std::move(score));
  }
  for (std::size_t i = 0; i < states; ++i) {
    s.state_rmse.push_back(counts[i] > 0 ? std::sqrt(squared[i] / counts[i]) : kNaN);
  }
  double accuracy = 0.0, log_probability = 0.0, classes = 0.0;
  for (const auto& [truth, row] : s.metrics.confusion) {
    if (!(s.metrics.truth_seconds(truth) > 0.0)) continue;
    accuracy += s.metrics.truth_accuracy(truth);
    log_probability += s.metrics.truth_mean_log_probability(truth);
    classes += 1.0;
  }
  s.mean_class_accuracy = classes > 0 ? accuracy / classes : kNaN;
  s.mean_class_log_probability = classes > 0 ? log_probability / classes : kNaN;
  s.accuracy_per_log = spread(s.accuracies);
  s.decision_accuracy_per_log = spread(s.decision_accuracies);
  s.by_log_class = summarize(scores);
  s.log_scores = std::move(scores);
  return s;
}

std::vector<std::string> truths_in_order(const ModeMetrics& m, const std::vector<std::string>& classes) {
  std::vector<std::string> out;
  for (const std::string& c : classes) {
    if (m.confusion.count(c) != 0) out.push_back(c);
  }
  for (const auto& [truth, row] : m.confusion) {
    if (std::find(classes.begin(), classes.end(), truth) == classes.end()) out.push_back(truth);
  }
  return out;
}

LatencyStats latency_stats(const ModeMetrics& m, bool first) {
  LatencyStats s;
  s.median = s.mean = s.max = s.median_changes = kNaN;
  std::vector<double> values;
  for (const auto& d : m.switches) {
    ++s.switches;
    const double latency = first ? d.first_latency : d.latency;
    if (latency == latency) values.push_back(latency);
  }
  s.detected = static_cast<long>(values.size());
  std::vector<double> changes;
  for (const auto& d : m.switches) changes.push_back(static_cast<double>(d.changes));
  if (!changes.empty()) {
    std::sort(changes.begin(), changes.end());
    s.median_changes = median_of_sorted(changes);
  }
  if (!values.empty()) {
    std::sort(values.begin(), values.end());
    s.median = median_of_sorted(values);
    s.mean = mean(values);
    s.max = values.back();
  }
  return s;
}

}  // namespace evaluation
}  // namespace skidimm
