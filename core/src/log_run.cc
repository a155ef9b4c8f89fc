#include "skidimm/engine/log_run.h"

#include <deque>
#include <exception>
#include <string>
#include <utility>
#include <vector>

#include "skidimm/engine/decision.h"
#include "skidimm/engine/imm.h"
#include "skidimm/engine/imm_smoother.h"
#include "skidimm/errors.h"
#include "skidimm/stop_request.h"

namespace skidimm {

void count_mode_rejections(const ImmEstimate& e, long row, double t, std::vector<ModeRejections>* rejections) {
  const std::size_t modes = e.mode_failures.size();
  if (rejections->size() != modes) rejections->resize(modes);
  for (std::size_t j = 0; j < modes; ++j) {
    const ModeFailure failure = e.mode_failures[j];
    if (failure == ModeFailure::kNone) continue;
    ModeRejections& r = (*rejections)[j];
    ++r.by_failure[static_cast<int>(failure)];
    if (!is_rejection(failure)) continue;
    if (r.rows++ == 0) {
      r.first_row = row;
      r.first_t = t;
      r.first_failure = failure;
      if (failure == ModeFailure::kModel) r.first_reason = e.failure_reasons[j];
    }
  }
}

namespace {

// The smoothed step in the filter's shape, with the filter's bookkeeping.
void fill(const SmoothedStep& s, const ImmEstimate& filtered, ImmEstimate* out) {
  *out = filtered;
  out->mode_probabilities = s.mode_probabilities;
  out->unknown_probability = s.unknown_probability;
  out->mode_states = s.mode_states;
  out->mode_covariances = s.mode_covariances;
  out->state = s.state;
  out->covariance = s.covariance;
  out->most_likely_mode = s.most_likely_mode;
}

bool accepted(StepStatus status) { return status != StepStatus::kRejectedTime && status != StepStatus::kRejectedInput; }

}  // namespace

std::string describe_first_rejection(const Bank& bank, const ImmEstimate& e, long row) {
  for (std::size_t j = 0; j < e.mode_failures.size(); ++j) {
    const ModeFailure failure = e.mode_failures[j];
    if (!is_rejection(failure)) continue;
    std::string plugin = "model " + bank.config.modes[j].model;
    if (j < bank.model_sources.size()) plugin = bank.model_sources[j].describe();
    std::string text = "row " + std::to_string(row) + " (t = " + CsvWriter::format(e.t) + "): mode '" +
                       bank.config.modes[j].name + "' (" + plugin + ") was rejected: " + to_string(failure);
    if (failure == ModeFailure::kModel && !e.failure_reasons[j].empty()) text += ": " + e.failure_reasons[j];
    return text + " (--strict stops at the first rejection)";
  }
  return "row " + std::to_string(row) + ": no mode was rejected";
}

namespace {

// A resumed run's first step at time t goes on from the checkpoint's last, at
// `last`: after it, and (unless the bank skips gaps) no further from it than
// the log reader lets two steps of one log be.
void refuse_a_break_in_the_clock(const BankConfig& config, double last, double t) {
  if (!(t > last)) {
    throw Error("the log's first step, at t = " + CsvWriter::format(t) +
                " s, does not come after the checkpoint's last, at t = " + CsvWriter::format(last) +
                " s: a resumed run goes on along the same clock");
  }
  if (!config.sampling.skip_gaps && t - last > config.sampling.max_gap) {
    throw Error("the log's first step, at t = " + CsvWriter::format(t) + " s, comes " + CsvWriter::format(t - last) +
                " s after the checkpoint's last, at t = " + CsvWriter::format(last) +
                " s: longer than the bank's sampling.max_gap (" + CsvWriter::format(config.sampling.max_gap) +
                " s); a longer gap is crossed in one step with sampling.skip_gaps: true");
  }
}

}  // namespace

long run_log(const Bank& bank, SampleSource* reader, const EstimatorOptions& options,
             const std::function<void(const LogSample&, const ImmEstimate&)>& sink,
             const RunContinuation& continuation) {
  Imm imm(bank);
  const ImmCheckpoint* resume = continuation.resume;
  if (resume != nullptr) {
    if (options.kind != EstimatorOptions::Kind::kFilter) {
      throw Error("a run resumed from a checkpoint is the filter's, not a smoother's");
    }
    imm.restore(*resume);
  }
  // The checkpoint after the last step, however the loop ends.
  struct LastCheckpoint {
    const Imm& imm;
    std::optional<ImmCheckpoint>* last;
    ~LastCheckpoint() {
      if (last == nullptr) return;
      try {
        *last = imm.checkpoint();
      } catch (...) {  // bad_alloc: no checkpoint rather than a crash while unwinding
        last->reset();
      }
    }
  } last_checkpoint{imm, continuation.last};
  LogSample sample;
  long steps = 0;
  double next_save = 0.0;  // when continuation.save is next called
  // A log that fails part way (a bad row), or a stop asked for from outside
  // (stop_request.h), still gets its steps so far handed on (smoothed over
  // the data read) before the error is raised: what was computed is not lost.
  std::exception_ptr read_error;
  const auto next = [&](LogSample* into) {
    try {
      if (const int signal = stop_requested()) {
        throw Error(std::string("stopped by ") + signal_name(signal) + " after " + std::to_string(steps) + " step(s)");
      }
      return reader->next(into);
    } catch (...) {
      read_error = std::current_exception();
      return false;
    }
  };
  if (options.kind == EstimatorOptions::Kind::kFilter) {
    while (next(&sample)) {
      if (steps == 0 && resume != nullptr && resume->started)
        refuse_a_break_in_the_clock(bank.config, resume->t, sample.t);
      sink(sample, imm.step(sample.t, sample.u, sample.z));
      ++steps;
      if (continuation.save && (steps == 1 || !(sample.t < next_save))) {
        continuation.save(imm.checkpoint());
        next_save = sample.t + continuation.every;
      }
    }
    if (read_error) std::rethrow_exception(read_error);
    return steps;
  }

  // The smoothers hold each step's sample and filter estimate until its
  // smoothed estimate is known.
  struct Held {
    LogSample sample;
    ImmEstimate filtered;
  };
  std::deque<Held> held;
  ImmEstimate out;
  auto release = [&](const std::vector<SmoothedStep>& smoothed) {
    for (const SmoothedStep& s : smoothed) {
      // Pass rejected steps before it through unchanged.
      while (!held.empty() && !accepted(held.front().filtered.status)) {
        sink(held.front().sample, held.front().filtered);
        held.pop_front();
      }
      fill(s, held.front().filtered, &out);
      sink(held.front().sample, out);
      held.pop_front();
    }
  };
  std::vector<SmoothedStep> ready;
  if (options.kind == EstimatorOptions::Kind::kFixedInterval) {
    std::vector<ForwardStep> forward;
    while (next(&sample)) {
      const ImmEstimate& e = imm.step(sample.t, sample.u, sample.z);
      if (accepted(e.status)) forward.push_back(record_step(sample.t, sample.u, e));
      held.push_back(Held{sample, e});
      ++steps;
    }
    ImmSmoother(bank).smooth(forward, &ready);
    release(ready);
  } else {
    FixedLagSmoother smoother(bank, options.lag);
    while (next(&sample)) {
      const ImmEstimate& e = imm.step(sample.t, sample.u, sample.z);
      held.push_back(Held{sample, e});
      ++steps;
      if (!accepted(e.status)) continue;
      ready.clear();
      smoother.add(record_step(sample.t, sample.u, e), &ready);
      release(ready);
    }
    ready.clear();
    smoother.finish(&ready);
    release(ready);
  }
  for (const Held& h : held) sink(h.sample, h.filtered);  // trailing rejected steps
  if (read_error) std::rethrow_exception(read_error);
  return steps;
}

void write_estimates(const Bank& bank, SampleSource* reader, const EstimatorOptions& options,
                     const DecisionConfig& decision_settings, const std::string& label, bool with_truth,
                     EstimatesWriter* writer, RunSummary* summary, const std::function<void()>& progress, bool strict,
                     const RunContinuation& continuation) {
  const BankConfig& config = bank.config;
  const std::vector<int> class_of_mode = config.class_of_modes();
  ModeDecision decision(config, decision_settings);
  if (continuation.resume != nullptr && continuation.resume->decision) {
    decision.restore(*continuation.resume->decision);
  }
  int last_decision = decision.decision();
  // Every row so far `unknown`: its first decision is not a change (as eval counts).
  bool undecided = last_decision == ModeDecision::kUnknown;
  // The decision's part of the checkpoint at the end, however the run ends.
  struct DecisionCheckpoint {
    const ModeDecision& decision;
    std::optional<ImmCheckpoint>* last;
    bool last_row_written = true;
    ~DecisionCheckpoint() {
      if (last == nullptr || !last->has_value()) return;
      if (!last_row_written) {
        // The filter went past a row the writer refused: resuming from it would lose that row.
        last->reset();
        return;
      }
      try {
        (*last)->decision = decision.memory();
      } catch (...) {  // bad_alloc: no checkpoint rather than a crash while unwinding
        last->reset();
      }
    }
  } decision_checkpoint{decision, continuation.last};
  // Checkpoints saved as the run goes carry the decision too.
  RunContinuation with_decision = continuation;
  if (continuation.save) {
    with_decision.save = [&decision, &continuation](const ImmCheckpoint& filter) {
      ImmCheckpoint checkpoint = filter;
      checkpoint.decision = decision.memory();
      continuation.save(checkpoint);
    };
  }
  const InputEnvelope envelope(config);
  // The truth's class: each label looked up once (class_index builds the
  // class names), then by comparison with the last one and the few seen.
  std::vector<std::pair<std::string, int>> classes_seen;
  const std::pair<std::string, int>* last = nullptr;
  run_log(
      bank, reader, options,
      [&](const LogSample& sample, const ImmEstimate& e) {
        RunSummary& s = *summary;
        const std::string& truth = label.empty() ? sample.truth_mode : label;
        // A smoothed step carries the measurements after it: it does not go stale.
        const int decided = decision.update(sample.t, e.mode_probabilities,
                                            options.kind != EstimatorOptions::Kind::kFilter || e.measured());
        s.decision_changes += decided != last_decision && s.rows > 0 && !undecided;
        undecided = undecided && decided == ModeDecision::kUnknown;
        s.decision_unknown += decided == ModeDecision::kUnknown;
        if (s.rows == 0) s.first_t = sample.t;
        s.last_t = sample.t;
        last_decision = decided;
        decision_checkpoint.last_row_written = false;
        writer->write(sample.t, e, decision.name(decided), truth);
        decision_checkpoint.last_row_written = true;
        ++s.rows;  // written: a row the writer refused is not among those kept
        if (e.num_rejected_modes > 0 || e.num_gated_modes > 0)
          count_mode_rejections(e, s.rows, sample.t, &s.rejections);
        if (strict && e.num_rejected_modes > 0) throw Error(describe_first_rejection(bank, e, s.rows));
        if (with_truth && !truth.empty()) {
          if (last == nullptr || last->first != truth) {
            last = nullptr;
            for (const auto& seen : classes_seen) {
              if (seen.first == truth) last = &seen;
            }
            if (last == nullptr) {
              classes_seen.emplace_back(truth, config.class_index(truth));
              last = nullptr;  // emplace_back may have moved the others
              for (const auto& seen : classes_seen) {
                if (seen.first == truth) last = &seen;
              }
            }
          }
          ++s.truth_rows;
          s.truth_matches += !e.unknown_is_most_likely() &&
                             last->second == class_of_mode[static_cast<std::size_t>(e.most_likely_mode)];
        }
        s.predict_only += e.status == StepStatus::kPredictOnly;
        s.rejected += e.num_rejected_modes > 0;
        s.gated += e.status == StepStatus::kGated;
        s.mode_gated += e.num_gated_modes > 0 && e.status != StepStatus::kGated;
        const double top = e.mode_probabilities[e.most_likely_mode];
        const bool tied = std::count(e.mode_probabilities.begin(), e.mode_probabilities.end(), top) > 1;
        s.timeline.add(sample.t, tied ? ModeTimeline::kTie : e.most_likely_mode, top);
        if (!envelope.empty() && !e.unknown_is_most_likely()) {
          const int c = class_of_mode[static_cast<std::size_t>(e.most_likely_mode)];
          const Excursion outside = envelope.outside(c, sample.u);
          if (outside.input >= 0) {
            ++s.outside_fitted_inputs;
            if (s.farthest_outside_class < 0 || outside.beyond > s.farthest_outside.beyond) {
              s.farthest_outside = outside;
              s.farthest_outside_class = c;
            }
          }
        }
        if (progress && s.rows % 1024 == 0) progress();
      },
      with_decision);
}

}  // namespace skidimm
