#include "skidimm/evaluation/mode_metrics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "skidimm/errors.h"
#include "skidimm/io/csv.h"

namespace skidimm {
namespace evaluation {

void ModeMetrics::merge(const ModeMetrics& other) {
  duration += other.duration;
  unlabelled += other.unlabelled;
  correct += other.correct;
  truth_probability += other.truth_probability;
  truth_log_probability += other.truth_log_probability;
  for (const auto& [truth, row] : other.confusion) {
    for (const auto& [estimate, seconds] : row) confusion[truth][estimate] += seconds;
  }
  for (const auto& [truth, integral] : other.log_probability_by_truth) log_probability_by_truth[truth] += integral;
  switches.insert(switches.end(), other.switches.begin(), other.switches.end());
  for (const auto& [mode, seconds] : other.truth_absent) truth_absent[mode] += seconds;
  estimate_changes += other.estimate_changes;
  truth_changes += other.truth_changes;
  unknown_seconds += other.unknown_seconds;
  brier += other.brier;
  for (std::size_t b = 0; b < calibration.size(); ++b) {
    calibration[b].seconds += other.calibration[b].seconds;
    calibration[b].correct += other.calibration[b].correct;
    calibration[b].confidence += other.calibration[b].confidence;
  }
}

double ModeMetrics::truth_seconds(const std::string& truth) const {
  const auto row = confusion.find(truth);
  if (row == confusion.end()) return 0.0;
  double seconds = 0.0;
  for (const auto& [estimate, s] : row->second) seconds += s;
  return seconds;
}

double ModeMetrics::truth_accuracy(const std::string& truth) const {
  const double seconds = truth_seconds(truth);
  if (seconds <= 0.0) return 0.0;
  const auto& row = confusion.at(truth);
  const auto right = row.find(truth);
  return right == row.end() ? 0.0 : right->second / seconds;
}

double ModeMetrics::truth_mean_log_probability(const std::string& truth) const {
  const double seconds = truth_seconds(truth);
  const auto integral = log_probability_by_truth.find(truth);
  return seconds > 0.0 && integral != log_probability_by_truth.end() ? integral->second / seconds : 0.0;
}

std::string main_truth(const ModeMetrics& m) {
  std::string best;
  double most = -1.0;
  for (const auto& [truth, row] : m.confusion) {
    double seconds = 0.0;
    for (const auto& [estimate, s] : row) seconds += s;
    if (seconds > most) {
      most = seconds;
      best = truth;
    }
  }
  return best;
}

double ModeMetrics::expected_calibration_error() const {
  double binned = 0.0, error = 0.0;
  for (const CalibrationBin& b : calibration) {
    binned += b.seconds;
    error += std::abs(b.correct - b.confidence);  // seconds x |accuracy - confidence|
  }
  return binned > 0.0 ? error / binned : 0.0;
}

double ModeMetrics::confident_fraction() const {
  double binned = 0.0;
  for (const CalibrationBin& b : calibration) binned += b.seconds;
  return binned > 0.0 ? calibration.back().seconds / binned : 0.0;
}

double ModeMetrics::confident_accuracy() const {
  const CalibrationBin& b = calibration.back();
  return b.seconds > 0.0 ? b.correct / b.seconds : std::numeric_limits<double>::quiet_NaN();
}

ModeMetrics compute_mode_metrics(const std::vector<LabelledStep>& all_steps,
                                 const std::vector<std::string>& bank_modes) {
  ModeMetrics m;
  // Each step's interval, over every step of the log: a labelled step before
  // an unlabelled stretch stands for its own interval, not for the stretch.
  const std::size_t all = all_steps.size();
  std::vector<LabelledStep> steps;
  std::vector<double> weights;
  for (std::size_t k = 0; k < all; ++k) {
    const double w = all == 1 ? 0.0
                     : k + 1 < all ? all_steps[k + 1].t - all_steps[k].t
                                   : all_steps[k].t - all_steps[k - 1].t;
    if (all_steps[k].truth.empty()) {
      m.unlabelled += w;
      continue;
    }
    steps.push_back(all_steps[k]);
    weights.push_back(w);
  }
  const std::size_t n = steps.size();
  if (n == 0) return m;
  double seconds = m.unlabelled;
  for (double w : weights) seconds += w;
  if (!std::isfinite(seconds)) {
    throw Error("the intervals between its steps do not sum to a finite time (time stamps from " +
                CsvWriter::format(all_steps.front().t) + " to " + CsvWriter::format(all_steps.back().t) +
                " s): no time-weighted figure can be computed. Are the time stamps in seconds?");
  }
  auto weight = [&](std::size_t k) { return weights[k]; };
  // While the log's leading run of "unknown" lasts, no decision has been taken yet.
  bool undecided = steps[0].estimate == "unknown";
  for (std::size_t k = 0; k < n; ++k) {
    const double w = weight(k);
    const LabelledStep& s = steps[k];
    m.duration += w;
    m.confusion[s.truth][s.estimate] += w;
    if (s.estimate == s.truth) m.correct += w;
    m.truth_probability += w * s.truth_probability;
    m.brier += w * s.brier;
    if (s.estimate != "unknown") {
      const int bin = std::min(kCalibrationBins - 1,
                               std::max(0, static_cast<int>(std::floor(s.estimate_probability * kCalibrationBins))));
      CalibrationBin& b = m.calibration[static_cast<std::size_t>(bin)];
      b.seconds += w;
      b.confidence += w * s.estimate_probability;
      if (s.estimate == s.truth) b.correct += w;
    }
    const double log_probability = w * std::log(std::max(s.truth_probability, kMinScoredProbability));
    m.truth_log_probability += log_probability;
    m.log_probability_by_truth[s.truth] += log_probability;
    if (std::find(bank_modes.begin(), bank_modes.end(), s.truth) == bank_modes.end()) m.truth_absent[s.truth] += w;
    if (s.estimate == "unknown") m.unknown_seconds += w;
    if (k > 0) {
      const bool changed = steps[k].estimate != steps[k - 1].estimate;
      m.estimate_changes += changed && !undecided;
      undecided = undecided && steps[k].estimate == "unknown";
      m.truth_changes += steps[k].truth != steps[k - 1].truth;
    }
  }
  // Switches: the truth changes between rows k-1 and k.
  for (std::size_t k = 1; k < n; ++k) {
    if (steps[k].truth == steps[k - 1].truth) continue;
    SwitchDetection d;
    d.time = steps[k].t;
    d.from = steps[k - 1].truth;
    d.to = steps[k].truth;
    d.latency = std::numeric_limits<double>::quiet_NaN();
    d.first_latency = std::numeric_limits<double>::quiet_NaN();
    std::size_t end = k;
    while (end < n && steps[end].truth == d.to) ++end;
    for (std::size_t j = k; j < end; ++j) d.changes += steps[j].estimate != steps[j - 1].estimate;
    for (std::size_t j = k; j < end; ++j) {
      if (steps[j].estimate == d.to) {
        d.first_latency = steps[j].t - d.time;
        break;
      }
    }
    // The last row in [k, end) whose estimate is not `to`; detection is the
    // row after it. Moving to the next true mode within kAnticipation seconds
    // of the next switch (a smoother, which sees the future, does) does not
    // count against following this one.
    const bool has_next = end < n;
    std::size_t last_wrong = k;
    bool any_wrong = false;
    for (std::size_t j = k; j < end; ++j) {
      const bool anticipates = has_next && steps[j].estimate == steps[end].truth &&
                               steps[end].t - steps[j].t <= kAnticipation;
      if (steps[j].estimate != d.to && !anticipates) {
        last_wrong = j;
        any_wrong = true;
      }
    }
    if (!any_wrong) {
      d.latency = 0.0;
    } else if (last_wrong + 1 < end) {
      d.latency = steps[last_wrong + 1].t - d.time;
    }
    m.switches.push_back(d);
  }
  return m;
}

long switches_lost(const ModeMetrics& reference, const ModeMetrics& other) {
  if (reference.switches.size() != other.switches.size()) {
    throw std::invalid_argument("switches_lost: " + std::to_string(reference.switches.size()) + " switches against " +
                                std::to_string(other.switches.size()));
  }
  long lost = 0;
  for (std::size_t i = 0; i < reference.switches.size(); ++i) {
    const SwitchDetection& r = reference.switches[i];
    const SwitchDetection& o = other.switches[i];
    if (r.time != o.time || r.to != o.to) {
      throw std::invalid_argument("switches_lost: switch " + std::to_string(i) + " differs (" + r.to + " against " +
                                  o.to + ")");
    }
    lost += std::isfinite(r.first_latency) && !std::isfinite(o.first_latency);
  }
  return lost;
}

}  // namespace evaluation
}  // namespace skidimm
