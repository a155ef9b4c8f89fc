// How well modes are identified, from a time series of true and estimated
// modes. All fractions are of time, not of rows: row k stands for the
// interval [t_k, t_{k+1}) (the last row for the interval before it), so
// irregular sampling does not bias them.
#ifndef SKIDIMM_EVALUATION_MODE_METRICS_H_
#define SKIDIMM_EVALUATION_MODE_METRICS_H_

#include <array>
#include <map>
#include <string>
#include <vector>

namespace skidimm {
namespace evaluation {

struct LabelledStep {
  double t = 0.0;
  std::string truth;               // true mode (or class); empty: unlabelled, not scored
  std::string estimate;            // most likely mode (or class)
  double truth_probability = 0.0;  // probability the estimator gave the truth (0 if not in the bank)
  double estimate_probability = 0.0;  // probability the estimator gave its estimate (0 for "unknown")
  // The step's Brier score, sum over the classes of (p_c - [c is the truth])^2,
  // in [0, 2]: 0 for certainty in the truth, 2 for certainty in a wrong class.
  double brier = 0.0;
};

// How often the estimate is right at each level of the probability the
// estimator gave it (a reliability diagram): bin b holds the time whose
// estimate had a probability in [b/10, (b+1)/10), the last bin [0.9, 1].
// A calibrated estimator is right, in each bin, about as often as it says.
inline constexpr int kCalibrationBins = 10;
struct CalibrationBin {
  double seconds = 0.0;     // time in the bin
  double correct = 0.0;     // ... of which the estimate was right
  double confidence = 0.0;  // integral of the estimate's probability over it (s)
  double accuracy() const { return seconds > 0.0 ? correct / seconds : 0.0; }
  double mean_confidence() const { return seconds > 0.0 ? confidence / seconds : 0.0; }
};

// The floor under log(truth_probability): a truth the bank cannot answer, or
// a probability of exactly 0, counts as log(1e-12) instead of -infinity, so
// one such row cannot decide a mean.
inline constexpr double kMinScoredProbability = 1e-12;

// How early (s) an estimate may move to the next true mode and still count as
// having followed the current one: smoothed estimates see switches coming.
inline constexpr double kAnticipation = 1.0;

// A true switch from `from` to `to` at `time`, and when the estimate
// followed. `latency`: until the most likely mode becomes `to` and stays so
// until the next switch (or the end); moving on to the next true mode up to
// kAnticipation seconds before that next switch still counts as staying. `first_latency`: until it is `to` for
// the first time (a flicker back later does not count against it). Both are
// NaN when that never happens.
struct SwitchDetection {
  double time = 0.0;
  std::string from;
  std::string to;
  double latency = 0.0;
  double first_latency = 0.0;
  long changes = 0;  // times the estimate changed from this switch until the next one
  bool detected() const { return latency == latency; }
};

struct ModeMetrics {
  double duration = 0.0;           // s with a truth label
  double unlabelled = 0.0;         // s without one (not scored)
  double correct = 0.0;            // s where estimate == truth
  double truth_probability = 0.0;  // integral of the true mode's probability (s)
  double truth_log_probability = 0.0;  // integral of its log, floored at kMinScoredProbability (s)
  // confusion[truth][estimate] = seconds.
  std::map<std::string, std::map<std::string, double>> confusion;
  // Per truth: the integral of log p(truth) over its own time (s).
  std::map<std::string, double> log_probability_by_truth;
  std::vector<SwitchDetection> switches;
  // True modes that are not in the bank, with their duration (s).
  std::map<std::string, double> truth_absent;
  long estimate_changes = 0;    // times the estimate changed between labelled steps (a log's first
                                // decision, out of a leading "unknown", is not a change)
  long truth_changes = 0;       // ... and the truth
  double unknown_seconds = 0.0; // time the estimate was "unknown" (a decision not yet, or no longer, taken)
  // Calibration of the estimate's probability; time "unknown" is in no bin
  // (a decision withheld claims nothing).
  std::array<CalibrationBin, kCalibrationBins> calibration{};
  double brier = 0.0;           // integral of the steps' Brier scores (s)

  double accuracy() const { return duration > 0.0 ? correct / duration : 0.0; }
  double estimate_changes_per_minute() const { return duration > 0.0 ? 60.0 * estimate_changes / duration : 0.0; }
  double truth_changes_per_minute() const { return duration > 0.0 ? 60.0 * truth_changes / duration : 0.0; }
  double mean_truth_probability() const { return duration > 0.0 ? truth_probability / duration : 0.0; }
  // The time average of log p(truth): what `skidimm tune` maximises. It
  // rewards confidence in the right answer and punishes confidence in a wrong
  // one, where accuracy only counts the argmax.
  double mean_truth_log_probability() const { return duration > 0.0 ? truth_log_probability / duration : 0.0; }
  double mean_brier() const { return duration > 0.0 ? brier / duration : 0.0; }
  // Expected calibration error: the time-weighted mean over bins of
  // |accuracy - mean probability|, over the time that is in a bin.
  double expected_calibration_error() const;
  // Of the time the estimate had probability >= 0.9 (the last bin): the
  // share of all binned time it makes up, and how often it was right (NaN
  // when there is none).
  double confident_fraction() const;
  double confident_accuracy() const;

  // Seconds a truth was in effect (its confusion row); 0 if never.
  double truth_seconds(const std::string& truth) const;
  // The fraction of a truth's own time the estimate was it; 0 if never in effect.
  double truth_accuracy(const std::string& truth) const;
  // The time average of log p(truth) over that truth's own time; 0 if never in effect.
  double truth_mean_log_probability(const std::string& truth) const;

  // Adds another run's metrics (several logs, seeds or scenarios).
  void merge(const ModeMetrics& other);
};

// The truth with the most time in `m` (a log's class); empty if none.
std::string main_truth(const ModeMetrics& m);

// `bank_modes`: the names the estimator can answer with. A step stands for
// the interval to the next step of the log, labelled or not (the last for
// the one before it); the intervals of unlabelled steps add to `unlabelled`.
// Throws skidimm::Error where the intervals do not sum to a finite time (time
// stamps near 1e308, which a bank with sampling.skip_gaps lets through):
// every time-weighted figure would be NaN.
ModeMetrics compute_mode_metrics(const std::vector<LabelledStep>& steps, const std::vector<std::string>& bank_modes);

// Of the true switches `reference` (the most likely mode) ever detected, how
// many `other` (e.g. the decision over the same steps) never did: what a
// smoother estimate loses against the raw one. Both must hold the same
// switches, in the same order (metrics of one labelled run); throws
// std::invalid_argument if they do not.
long switches_lost(const ModeMetrics& reference, const ModeMetrics& other);

}  // namespace evaluation
}  // namespace skidimm

#endif  // SKIDIMM_EVALUATION_MODE_METRICS_H_
