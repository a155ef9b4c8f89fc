#include "skidimm/evaluation/log_scores.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
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
  s.smallest_probability = r.smallest_probability;
  s.extrapolation = r.extrapolation;
  s.steps = r.steps;
  s.rejections = r.rejections;
  if (r.decision_metrics.duration > 0.0) {
    s.decision_accuracy = r.decision_metrics.accuracy();
    s.decision_unknown = r.decision_metrics.unknown_seconds / r.decision_metrics.duration;
  }
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
  std::map<std::string, std::pair<double, double>> decided;  // right, unknown
  std::map<std::string, int> decided_counts;
  for (const LogScore& l : scores) {
    if (!std::isfinite(l.decision_accuracy)) continue;
    decided[l.truth].first += l.decision_accuracy;
    decided[l.truth].second += l.decision_unknown;
    ++decided_counts[l.truth];
  }
  if (!decided.empty()) {
    s.decision_accuracy = s.decision_unknown = 0.0;
    for (const auto& [c, sum] : decided) {
      s.decision_accuracy += sum.first / decided_counts[c] / static_cast<double>(decided.size());
      s.decision_unknown += sum.second / decided_counts[c] / static_cast<double>(decided.size());
    }
  }
  return s;
}

Separability separability(const std::vector<LogScore>& scores, int classes) {
  Separability s;
  s.classes = classes;
  s.uniform = -std::log(static_cast<double>(std::max(classes, 1)));
  const double n = static_cast<double>(scores.size());
  if (scores.empty()) return s;
  for (const LogScore& l : scores) {
    s.mean += l.mean_log_probability / n;
    s.accuracy += l.accuracy / n;
  }
  if (scores.size() > 1) {
    double squares = 0.0;
    for (const LogScore& l : scores) squares += (l.mean_log_probability - s.mean) * (l.mean_log_probability - s.mean);
    s.standard_error = std::sqrt(squares / (n - 1.0) / n);
  }
  s.logs = static_cast<int>(scores.size());
  // A mean that is the guess to round-off (every probability uniform, summed
  // in another order) is the guess: not above it, nor below it.
  const double tie = 1e-9 * std::abs(s.uniform);
  s.verdict = s.mean - 2.0 * s.standard_error > s.uniform + tie    ? Separability::Verdict::kSeparated
              : s.mean > s.uniform + tie                           ? Separability::Verdict::kUnclear
              : s.mean + 2.0 * s.standard_error >= s.uniform - tie ? Separability::Verdict::kNotSeparated
                                                                   : Separability::Verdict::kWorse;
  for (const auto& [name, log_p] : summarize(scores).class_log_probability) {
    if (log_p <= s.uniform) s.not_separated.push_back(name);
  }
  return s;
}

std::string Separability::describe() const {
  auto number = [](double v) {
    char b[32];
    std::snprintf(b, sizeof(b), "%.3f", v);
    return std::string(b);
  };
  // One log has no spread over logs to weigh its mean by: said, not shown as +- 0.
  const std::string figures = "mean log p(truth) " + number(mean) +
                              (logs == 1 ? " on one log (no standard error over logs)"
                                         : " +- " + number(standard_error) + " over logs (each log's mean, averaged)") +
                              ", against " + number(uniform) + " for a uniform guess over " + std::to_string(classes) +
                              " classes";
  std::string out;
  switch (verdict) {
    case Verdict::kSeparated:
      out = "the classes are told apart (" + figures + ")";
      break;
    case Verdict::kUnclear:
      out = "the classes are told apart no more clearly than by chance (" + figures +
            ": within two standard errors); more logs, or logs that excite what differs between the modes, would "
            "tell";
      break;
    case Verdict::kNotSeparated:
      out =
          "these modes cannot be told apart from these logs (" + figures +
          "): the probability the truth is given is what a guess gives it, however the accuracy reads (a bank "
          "right most of the time and sure of the wrong class the rest scores so); " +
          (overconfident() ? "here the most likely class is right " + number(accuracy) + " of the time against " +
                                 number(1.0 / classes) +
                                 " by chance, so the classes differ and the probabilities are too sure when wrong: a "
                                 "likelihood weight or a Student-t likelihood (skidimm tune --tune "
                                 "likelihood-weight,likelihood-dof) makes them honest"
                           : std::string("fit on logs that excite what differs between the modes, or measure what does "
                                         "differ"));
      break;
    case Verdict::kWorse:
      out = "worse than a uniform guess (" + figures + "): the bank is sure of wrong classes on these logs; " +
            (overconfident()
                 ? "yet the most likely class is right " + number(accuracy) + " of the time against " +
                       number(1.0 / classes) +
                       " by chance: the probabilities are too sure when wrong, which a likelihood weight or a "
                       "Student-t likelihood (skidimm tune --tune likelihood-weight,likelihood-dof) tempers"
                 : std::string("they differ from the logs it was fitted and tuned on, or are labelled wrong"));
      break;
  }
  if (!not_separated.empty() && (verdict == Verdict::kSeparated || verdict == Verdict::kUnclear)) {
    std::string names;
    for (const std::string& c : not_separated) names += (names.empty() ? "" : ", ") + c;
    out += "; no better than the guess: " + names;
  }
  return out;
}

}  // namespace evaluation
}  // namespace skidimm
