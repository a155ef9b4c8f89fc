#include "skidimm/evaluation/log_evaluation.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "skidimm/engine/decision.h"
#include "skidimm/engine/imm.h"
#include "skidimm/engine/input_envelope.h"
#include "skidimm/errors.h"
#include "skidimm/io/estimates_writer.h"
#include "skidimm/printable.h"
#include "skidimm/sdk/angles.h"

namespace skidimm {
namespace evaluation {

ClassScorer::ClassScorer(const BankConfig& bank)
    : bank_(&bank), names_(bank.class_names()), class_of_mode_(bank.class_of_modes()) {
  class_probabilities_.resize(static_cast<Eigen::Index>(names_.size()));
}

int ClassScorer::class_of_label(const std::string& label) const { return bank_->class_index(label); }

LabelledStep ClassScorer::score(double t, const std::string& label, const Eigen::VectorXd& mode_probabilities,
                                double unknown_probability) const {
  class_probabilities_.setZero();
  for (Eigen::Index j = 0; j < mode_probabilities.size(); ++j) {
    class_probabilities_[class_of_mode_[static_cast<std::size_t>(j)]] += mode_probabilities[j];
  }
  Eigen::Index best = 0;
  class_probabilities_.maxCoeff(&best);
  LabelledStep step;
  step.t = t;
  last_truth_ = -1;
  if (unknown_outweighs(unknown_probability, class_probabilities_[best])) {
    step.estimate = "unknown";
    step.estimate_probability = 0.0;
    last_estimate_ = -1;
  } else {
    step.estimate = names_[static_cast<std::size_t>(best)];
    step.estimate_probability = class_probabilities_[best];
    last_estimate_ = static_cast<int>(best);
  }
  if (!label.empty()) {
    const int c = class_of_label(label);
    last_truth_ = c;
    step.truth = c >= 0 ? names_[static_cast<std::size_t>(c)] : printable(label);  // a CSV cell: make it safe
    // The truth is always one of the classes, so "none of these" says nothing
    // about which: its probability is spread evenly over the classes, as a
    // uniform guess would. Counting it as wrong instead would make an honest
    // "I don't know" cost more than a guess, and tuning by these scores
    // would always silence it.
    const double spread = unknown_probability / static_cast<double>(class_probabilities_.size());
    // A truth the bank cannot answer is a class of probability 0.
    step.truth_probability = c >= 0 ? class_probabilities_[c] + spread : 0.0;
    const double classes = static_cast<double>(class_probabilities_.size());
    step.brier = class_probabilities_.squaredNorm() + spread * (2.0 * class_probabilities_.sum() + classes * spread) +
                 1.0 -
                 (c >= 0 ? 2.0 * (class_probabilities_[c] + spread) : 0.0);
  }
  return step;
}

LabelledStep ClassScorer::decided(const LabelledStep& step, const std::string& decision) const {
  LabelledStep out = step;
  out.estimate = decision;
  const auto found = std::find(names_.begin(), names_.end(), decision);
  out.estimate_probability = found == names_.end() ? 0.0 : class_probabilities_[found - names_.begin()];
  return out;
}

namespace {

// A label the bank knows, or a truth column the bank names: before the log
// is read.
void require_a_truth(const BankConfig& config, const LogSpec& log) {
  if (log.label.empty() && config.columns.truth_mode.empty()) {
    throw Error(config.shown_file() + ": the bank names no columns.truth_mode, so there is nothing to evaluate " +
                log.text + " against; label the log (MODE=" + log.text + ") or name the truth column");
  }
  if (!log.label.empty() && config.class_index(log.label) < 0) {
    throw Error(log.text + ": " + config.unknown_label(log.label));
  }
}

// ... and, without a label, the truth column in the log.
void require_the_truth_column(const BankConfig& config, const LogSpec& log, const LogReader& reader) {
  if (log.label.empty() && !reader.has_truth()) {
    throw Error(log.text + ": nothing to score against: label the log (MODE=" + log.text +
                ") or give the bank a truth column (columns.truth_mode)" +
                (config.columns.truth_mode.empty() ? "" : "; the log has no column '" + config.columns.truth_mode + "'"));
  }
}

// What the reader, at the end of a log, says of it that its scores do not:
// measurements never given, rows the bank's options left out.
void say_what_the_reader_left(const BankConfig& config, const LogReader& reader, LogResult* result) {
  result->unmeasured = reader.unmeasured(config);
  result->skipped = reader.skipped_by_options();
}

}  // namespace

RecordedLog record_labelled_log(const BankConfig& config, const LogSpec& log, const SamplingConfig& sampling,
                                LogResult* said) {
  require_a_truth(config, log);
  LogReader reader(config, log.files, sampling);
  require_the_truth_column(config, log, reader);
  RecordedLog recorded = RecordedLog::record(&reader);
  if (said != nullptr) say_what_the_reader_left(config, reader, said);
  return recorded;
}

LogResult evaluate_log(const Bank& bank, const LogSpec& log, const SamplingConfig& sampling,
                       const std::filesystem::path& estimates, const EstimatorOptions& estimator) {
  const BankConfig& config = bank.config;
  require_a_truth(config, log);
  LogReader reader(config, log.files, sampling);
  require_the_truth_column(config, log, reader);
  LogResult result = evaluate_log(bank, &reader, log.name(), log.label, estimates, estimator);
  result.source = joined_paths(log.files);
  say_what_the_reader_left(config, reader, &result);
  return result;
}

namespace {

// Counts the step `scorer` scored last in `counts`: whether its inputs are
// outside the ranges of the class estimated there and of the true class
// (InputEnvelope), and where the estimate was right.
void count_extrapolation(const InputEnvelope& envelope, const ClassScorer& scorer, const LogSample& sample,
                         ExtrapolationCounts* counts) {
  ++counts->steps;
  const int estimate = scorer.last_estimate();
  const Excursion from_estimate = envelope.outside(estimate, sample.u);
  if (from_estimate.input >= 0) ++counts->outside_estimate;
  const int truth = scorer.last_truth();
  const Excursion& farthest = truth >= 0 ? envelope.outside(truth, sample.u) : from_estimate;
  if (truth >= 0) {
    ++counts->labelled;
    const bool right = estimate == truth;
    if (farthest.input >= 0) {
      ++counts->outside_truth;
      if (right) ++counts->outside_truth_right;
    } else if (right) {
      ++counts->inside_truth_right;
    }
  }
  if (farthest.input >= 0 && farthest.beyond > counts->farthest_beyond) {
    counts->farthest_beyond = farthest.beyond;
    counts->farthest = envelope.describe(truth >= 0 ? truth : estimate, farthest);
  }
}

// One IMM over `source`: the result, and every step scored for the most
// likely class and for the decision.
struct ScoredRun {
  LogResult result;
  std::vector<LabelledStep> steps, decisions;
};

ScoredRun score_run(const Bank& bank, SampleSource* source, const std::string& name, const std::string& label_given,
                    const std::filesystem::path& estimates, const EstimatorOptions& estimator,
                    const StepObserver& observer = {}) {
  const BankConfig& config = bank.config;
  const ClassScorer scorer(config);
  ScoredRun run;
  LogResult& result = run.result;
  result.name = name;
  result.source = name;
  result.classes = scorer.class_names();
  result.squared_state_error.assign(config.state_names.size(), 0.0);
  result.state_error_count.assign(config.state_names.size(), 0);
  std::optional<EstimatesWriter> writer;
  if (!estimates.empty()) writer.emplace(estimates, config, /*with_truth=*/true);
  ModeDecision decision(config);
  const InputEnvelope envelope(config);
  double smallest = std::numeric_limits<double>::infinity();
  run_log(bank, source, estimator, [&](const LogSample& sample, const ImmEstimate& e) {
    if (!e.mode_probabilities.allFinite() || !std::isfinite(e.unknown_probability)) {
      smallest = std::numeric_limits<double>::quiet_NaN();  // and stays so: std::min keeps its first NaN
    }
    smallest = std::min(smallest, e.mode_probabilities.minCoeff());
    if (config.unknown.enabled()) smallest = std::min(smallest, e.unknown_probability);
    const std::string& label = label_given.empty() ? sample.truth_mode : label_given;
    // A smoothed step carries the measurements after it: it does not go stale.
    const bool current = estimator.kind != EstimatorOptions::Kind::kFilter || e.measured();
    const std::string& decided = decision.name(decision.update(sample.t, e.mode_probabilities, current));
    if (writer) writer->write(sample.t, e, decided, label);
    run.steps.push_back(scorer.score(sample.t, label, e.mode_probabilities, e.unknown_probability));
    run.decisions.push_back(scorer.decided(run.steps.back(), decided));
    if (observer) observer(sample, run.steps.back());
    if (!envelope.empty()) count_extrapolation(envelope, scorer, sample, &result.extrapolation);
    const int truth_mode = config.mode_index(label);
    if (truth_mode >= 0 && e.status == StepStatus::kUpdated && std::isfinite(e.nis[truth_mode])) {
      result.nis[label].add(e.nis[truth_mode], e.num_measured);
    }
    for (Eigen::Index s = 0; s < sample.true_state.size(); ++s) {
      if (!std::isfinite(sample.true_state[s])) continue;
      double d = e.state[s] - sample.true_state[s];
      if (config.angle_mask[static_cast<std::size_t>(s)]) d = sdk::wrap_angle(d);
      result.squared_state_error[static_cast<std::size_t>(s)] += d * d;
      ++result.state_error_count[static_cast<std::size_t>(s)];
    }
    if (e.num_rejected_modes > 0 || e.num_gated_modes > 0) {
      count_mode_rejections(e, result.steps + 1, sample.t, &result.rejections);
      if (e.num_rejected_modes == config.num_modes()) ++result.steps_every_mode_rejected;
    }
    ++result.steps;
  });
  // A smoothed step's probabilities are not the ones the filter floored.
  if (estimator.kind == EstimatorOptions::Kind::kFilter && result.steps > 0) result.smallest_probability = smallest;
  result.metrics = compute_mode_metrics(run.steps, scorer.class_names());
  result.decision_metrics = compute_mode_metrics(run.decisions, scorer.class_names());
  if (writer) writer->commit();
  return run;
}

}  // namespace

LogResult evaluate_log(const Bank& bank, SampleSource* source, const std::string& name, const std::string& label_given,
                       const std::filesystem::path& estimates, const EstimatorOptions& estimator,
                       const StepObserver& observer) {
  return score_run(bank, source, name, label_given, estimates, estimator, observer).result;
}

std::vector<LogResult> evaluate_spliced(const Bank& bank, SampleSource* source, const std::vector<std::string>& names,
                                        const std::vector<long>& steps_per_log, LogResult* whole,
                                        const std::filesystem::path& estimates) {
  ScoredRun run = score_run(bank, source, "", "", estimates, EstimatorOptions{});
  const std::vector<std::string> classes = bank.config.class_names();
  std::vector<LogResult> out;
  std::size_t first = 0;
  for (std::size_t i = 0; i < names.size(); ++i) {
    const std::size_t end = std::min(run.steps.size(), first + static_cast<std::size_t>(steps_per_log[i]));
    const auto slice = [&](const std::vector<LabelledStep>& steps) {
      return std::vector<LabelledStep>(steps.begin() + static_cast<std::ptrdiff_t>(first),
                                       steps.begin() + static_cast<std::ptrdiff_t>(end));
    };
    LogResult r;
    r.name = names[i];
    r.metrics = compute_mode_metrics(slice(run.steps), classes);
    r.decision_metrics = compute_mode_metrics(slice(run.decisions), classes);
    r.steps = static_cast<long>(end - first);
    out.push_back(std::move(r));
    first = end;
  }
  if (whole != nullptr) *whole = std::move(run.result);
  return out;
}

}  // namespace evaluation
}  // namespace skidimm
