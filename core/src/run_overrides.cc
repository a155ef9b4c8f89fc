#include "skidimm/config/run_overrides.h"

#include <cmath>

#include "skidimm/errors.h"
#include "skidimm/io/csv.h"
#include "skidimm/io/log_reader.h"

namespace skidimm {

SamplingConfig sampling_of(const BankConfig& bank, std::optional<double> rate) {
  if (rate && !(*rate >= 0.0 && *rate <= 1e6)) {
    throw Error("rate: expected a rate in Hz, > 0 and at most 1e6 (or 0 for the bank's), got " +
                CsvWriter::format(*rate));
  }
  SamplingConfig sampling = bank.sampling;
  if (rate && *rate > 0.0) sampling.rate = *rate;
  return sampling;
}

std::string rate_unlike_the_banks(const BankConfig& bank, std::optional<double> rate) {
  if (!rate || !(*rate > 0.0) || !(bank.sampling.rate > 0.0) || *rate == bank.sampling.rate) return std::string();
  const std::vector<std::string> aggregated = LogReader::aggregated_measurements(bank);
  if (aggregated.empty()) return std::string();
  std::string names;
  for (const std::string& name : aggregated) names += (names.empty() ? "" : ", ") + name;
  return "at another rate than its sampling.rate of " + CsvWriter::format(bank.sampling.rate) + " Hz: " + names +
         " aggregate the rows of a step, and over steps of " + CsvWriter::format(1.0 / *rate) +
         " s they measure something other than what its modes were fitted on, so its estimates can be "
         "confidently wrong";
}

void check_decision_settings(const DecisionConfig& d) {
  if (!(d.enter > 0.0 && d.enter <= 1.0 && d.leave >= 0.0 && d.leave < d.enter)) {
    throw Error("decision thresholds: need 0 <= leave < enter <= 1, got enter " + CsvWriter::format(d.enter) +
                ", leave " + CsvWriter::format(d.leave));
  }
  // The bank's own bound (bank_loader.cc): a hold of 1e308 s was taken from the command line.
  if (!(d.min_hold >= 0.0 && d.min_hold < kLongestDecisionHold)) {
    throw Error("decision hold: need min_hold >= 0 s and under 1e9 s, got " + CsvWriter::format(d.min_hold));
  }
}

DecisionConfig decision_settings_of(const DecisionConfig& bank, const RunOverrides& overrides) {
  DecisionConfig d = bank;
  if (overrides.decision_enter) d.enter = *overrides.decision_enter;
  if (overrides.decision_leave) d.leave = *overrides.decision_leave;
  if (overrides.decision_hold) d.min_hold = *overrides.decision_hold;
  if (overrides.decision_stale) {
    // The bank's own bound (bank_loader.cc); unset (< 0) is the bank's alone.
    if (!(*overrides.decision_stale >= 0.0 && *overrides.decision_stale < kLongestDecisionHold)) {
      throw Error("decision stale_after: need seconds >= 0 (0: never) and under 1e9, got " +
                  CsvWriter::format(*overrides.decision_stale));
    }
    d.stale_after = *overrides.decision_stale;
  }
  check_decision_settings(d);
  return d;
}

void apply_overrides(const RunOverrides& overrides, BankConfig* config) {
  // Every value is checked before any is set.
  const DecisionConfig decision = decision_settings_of(config->decision, overrides);
  if (overrides.innovation_gate && !(*overrides.innovation_gate >= 0.0 && *overrides.innovation_gate < 1.0)) {
    throw Error("innovation gate: expected a probability in (0, 1), or 0 for none, got " +
                CsvWriter::format(*overrides.innovation_gate));
  }
  if (overrides.likelihood_weight && !(*overrides.likelihood_weight > 0.0 && *overrides.likelihood_weight <= 1.0)) {
    throw Error("likelihood weight: expected a weight in (0, 1], got " +
                CsvWriter::format(*overrides.likelihood_weight));
  }
  config->decision = decision;
  if (overrides.innovation_gate) config->innovation_gate = *overrides.innovation_gate;
  if (overrides.likelihood_weight) config->likelihood_weight = *overrides.likelihood_weight;
}

EstimatorOptions estimator_options(bool smooth, std::optional<double> lag) {
  EstimatorOptions estimator;
  if (smooth && lag) {
    throw Error("smooth (over the whole log) and lag (smoothing with a fixed lag) exclude each other: give one, not both");
  }
  if (smooth) estimator.kind = EstimatorOptions::Kind::kFixedInterval;
  if (lag) {
    if (!(*lag >= 0.0)) throw Error("lag: expected seconds >= 0, got " + CsvWriter::format(*lag));
    estimator.kind = EstimatorOptions::Kind::kFixedLag;
    estimator.lag = *lag;
  }
  return estimator;
}

}  // namespace skidimm
