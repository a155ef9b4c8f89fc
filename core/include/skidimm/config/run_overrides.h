// What a front end may set over a bank's own settings for one run: the
// command line's --rate, --decision-*, --innovation-gate,
// --likelihood-weight, --smooth and --lag, and Python's keyword arguments of
// the same names. The values are checked here, once, so that every front end
// refuses the same values with the same words; a front end never edits a
// bank's configuration itself.
#ifndef SKIDIMM_CONFIG_RUN_OVERRIDES_H_
#define SKIDIMM_CONFIG_RUN_OVERRIDES_H_

#include <optional>
#include <string>

#include "skidimm/config/bank.h"
#include "skidimm/engine/log_run.h"

namespace skidimm {

// Each field given replaces the bank's; an empty one keeps it.
struct RunOverrides {
  std::optional<double> rate;               // Hz, > 0: sampling.rate
  std::optional<double> decision_enter;     // decision.enter
  std::optional<double> decision_leave;     // decision.leave
  std::optional<double> decision_hold;      // decision.min_hold (s)
  std::optional<double> decision_stale;     // decision.stale_after (s); 0: never
  std::optional<double> innovation_gate;    // in [0, 1); 0: no gate
  std::optional<double> likelihood_weight;  // in (0, 1]

  bool changes_decision() const { return decision_enter || decision_leave || decision_hold || decision_stale; }
};

// The bank's sampling with `rate` (Hz) when it is given and > 0. Throws
// Error for a rate that is negative, not a number or above 1e6 Hz.
SamplingConfig sampling_of(const BankConfig& bank, std::optional<double> rate);

// Why stepping `bank` at `rate` (Hz, a front end's --rate) changes what it
// measures, from "at another rate than its sampling.rate": its
// measurements that aggregate a step's rows (mean(), std(), rms()) were
// fitted over steps of its sampling.rate, and over steps of another length
// measure something else, so its estimates can be confidently wrong. Empty
// when no rate is given, it is the bank's, the bank has none, or nothing
// aggregates. Every front end warns with it.
std::string rate_unlike_the_banks(const BankConfig& bank, std::optional<double> rate);

// Throws Error naming the values unless 0 <= leave < enter <= 1 and
// min_hold >= 0: decision settings given by a front end (the bank loader
// checks the file's own, naming the file and line).
void check_decision_settings(const DecisionConfig& settings);

// `bank`'s decision settings with the overrides' decision_* where given, checked.
DecisionConfig decision_settings_of(const DecisionConfig& bank, const RunOverrides& overrides);

// Replaces the settings of `config` that `overrides` give (decision,
// innovation gate, likelihood weight; the rate is the readers', through
// sampling_of). Throws Error naming the setting and the value expected; on
// an error `config` is unchanged.
void apply_overrides(const RunOverrides& overrides, BankConfig* config);

// What a run's steps are estimated with: the filter, or smoothing over the
// whole log (`smooth`), or smoothing with a fixed lag of `lag` seconds. The
// two smoothers exclude each other: giving both is an Error, as is a
// negative lag.
EstimatorOptions estimator_options(bool smooth, std::optional<double> lag);

}  // namespace skidimm

#endif  // SKIDIMM_CONFIG_RUN_OVERRIDES_H_
