#include "skidimm/fitting/tuning.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <mutex>
#include <numeric>
#include <set>
#include <thread>
#include <tuple>

#include "assessment_protocols.h"
#include "check.h"
#include "parallel.h"
#include "scoring_sources.h"
#include "skidimm/errors.h"
#include "skidimm/evaluation/log_evaluation.h"
#include "skidimm/fitting/bank_fit.h"
#include "skidimm/io/spliced_replay.h"
#include "skidimm/progress.h"
#include "tuned_settings.h"

namespace skidimm {
namespace fitting {

namespace {

using internal::BoundedSource;
using internal::brief;
using internal::complement;
using internal::ScoreBound;

// The modes' logs of a set of tuning logs, merged by mode.
std::vector<ModeLogs> training_data(const std::vector<TuningLog>& logs, const std::vector<int>& members) {
  std::map<int, ModeLogs> by_mode;
  for (int i : members) {
    for (const ModeLogs& d : logs[static_cast<std::size_t>(i)].fit_data) {
      by_mode[d.mode].mode = d.mode;
      by_mode[d.mode].logs.insert(by_mode[d.mode].logs.end(), d.logs.begin(), d.logs.end());
    }
  }
  std::vector<ModeLogs> out;
  for (auto& [mode, d] : by_mode) out.push_back(std::move(d));
  return out;
}

}  // namespace

std::vector<LogScore> score_logs(const Bank& bank, const std::vector<const TuningLog*>& logs,
                                 const SamplingConfig& sampling, const std::vector<std::filesystem::path>& estimates) {
  std::vector<LogScore> out;
  for (std::size_t i = 0; i < logs.size(); ++i) {
    const TuningLog* log = logs[i];
    out.push_back(evaluation::score_of(
        evaluation::evaluate_log(bank, log->spec, sampling, i < estimates.size() ? estimates[i] : std::filesystem::path())));
  }
  return out;
}

namespace {

// The tuner's working state: worker banks, the fit cache, the logs.
class Tuner {
 public:
  Tuner(const std::function<Bank()>& make_bank, const std::vector<TuningLog>& logs,
        const std::map<std::string, BankFitter>& fitters, const TuneOptions& options)
      : logs_(logs), names_(table_names(logs)), fitters_(fitters), options_(options) {
    // At most one thread per core: each worker holds a whole bank, and more
    // threads than cores only wait (a million of them never finished loading).
    const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    workers_ = options.threads > 0 ? std::min(options.threads, cores) : cores;
    for (int w = 0; w < workers_; ++w) banks_.push_back(make_bank());
    kept_models_.resize(banks_.size());
    base_ = values_of(banks_[0]);
    const BankConfig& config = banks_[0].config;
    base_transition_ = config.transition;
    if (config.transition.kind == TransitionConfig::Kind::kDwellTimes &&
        (config.transition.dwell_seconds.array() == config.transition.dwell_seconds[0]).all()) {
      base_dwell_ = config.transition.dwell_seconds[0];
    }
    base_floor_ = config.mode_probability_floor;
    base_weight_ = config.likelihood_weight;
    base_dof_ = config.likelihood_dof;
    base_unknown_inflation_ = config.unknown.inflation;
    base_extrapolation_scale_ = config.extrapolation_scale;
    if (!config.unknown.enabled() &&
        std::find(options.knobs.begin(), options.knobs.end(), Knob::kUnknownInflation) != options.knobs.end()) {
      throw Error(config.shown_file() +
                  ": --tune unknown-inflation needs a bank with an unknown hypothesis (the key `unknown:`, "
                  "docs/bank-format.md)");
    }
    // Each log's class, for stratified folds and summaries: from a first scoring at the starting values.
    classes_.resize(logs.size());
    std::vector<const TuningLog*> all;
    for (const TuningLog& l : logs) all.push_back(&l);
    // The logs are read once, here (which also checks that each can be
    // scored), and replayed from memory for the hundreds of scorings below.
    recorded_.resize(logs.size());
    parallel_for(static_cast<int>(logs.size()), workers_, [&](int i, int w) {
      const LogScore first =
          score_logs(banks_[static_cast<std::size_t>(w)], {all[static_cast<std::size_t>(i)]}, options_.sampling)
              .front();
      // Scored as accuracy 0 and log p(truth) 0, the best there is, a log
      // without labelled time would move every mean it entered.
      if (!(first.seconds > 0.0)) {
        throw Error(all[static_cast<std::size_t>(i)]->spec.text +
                    ": no labelled time to score: a log needs two steps or more with a truth (its truth column, or "
                    "MODE= before the log)");
      }
      classes_[static_cast<std::size_t>(i)] = first.truth;
      LogReader reader(banks_[static_cast<std::size_t>(w)].config, all[static_cast<std::size_t>(i)]->spec.files,
                       options_.sampling);
      recorded_[static_cast<std::size_t>(i)] = RecordedLog::record(&reader);
    });
    step_weights_.resize(logs.size());
    truth_seconds_.assign(logs.size(), 0.0);
    for (std::size_t i = 0; i < logs.size(); ++i) weigh_steps(i);
  }

  TuneResult run() {
    std::vector<int> development;
    std::vector<int> lockbox;
    for (std::size_t i = 0; i < logs_.size(); ++i) (logs_[i].lockbox ? lockbox : development).push_back(static_cast<int>(i));
    development_ = development;
    if (development.size() < 2) throw Error("tuning by cross-validation needs at least two logs besides the lockbox");
    const auto outer = grouped_folds(development, classes_, options_.folds);
    std::vector<std::vector<std::vector<int>>> protocol_folds;
    if (options_.assess) {
      for (const Protocol& p : options_.protocols) protocol_folds.push_back(folds_of(p, development, outer));
    }
    // Every fit the run needs, computed once, in parallel. The final fit on
    // every development log among them: it may not fail where a fold's may
    // (a corrupt cell, a mode too short to fit), and failing there, after
    // every search, lost them all.
    std::vector<std::pair<std::string, std::vector<int>>> fits;
    for (const std::string& objective : options_.objectives) {
      fits.emplace_back(objective, development);
      for (const auto& held : outer) fits.emplace_back(objective, complement(held, development));
      for (const auto& folds : protocol_folds) {
        for (const auto& held : folds) {
          const std::vector<int> inner_logs = complement(held, development);
          fits.emplace_back(objective, inner_logs);
          for (const auto& inner_held : grouped_folds(inner_logs, classes_, options_.inner_folds)) {
            fits.emplace_back(objective, complement(inner_held, inner_logs));
          }
        }
      }
    }
    progress(work_statement(fits, outer, protocol_folds, development, lockbox));
    compute_fits(fits);

    TuneResult result;
    // Selection: the settings that score best over the outer folds.
    double best = -std::numeric_limits<double>::infinity();
    for (const std::string& objective : options_.objectives) {
      TunedSettings s = search(objective, outer, development, &result.selection_scores, false,
                               result.start_scores.empty() ? &result.start_scores : nullptr);
      const double score = summarize(result.selection_scores).mean_log_probability;
      progress("objective " + objective + ": cross-validated mean log p(truth) " + brief(score));
      if (score > best) {
        best = score;
        result.settings = s;
      }
    }
    result.selection_scores = evaluate(result.settings, outer, development);
    result.selection = summarize(result.selection_scores);
    for (LogScore& score : result.selection_scores) score.selection_score = result.selection.mean_log_probability;

    // Assessment, per protocol: each held-out set scored with settings tuned
    // on the other logs alone.
    for (std::size_t p = 0; p < protocol_folds.size(); ++p) {
      result.assessments.push_back(assess(options_.protocols[p], protocol_folds[p], development));
    }

    // The final bank: the chosen objective fitted on every log but the lockbox.
    compute_fits({{result.settings.objective, development}});
    result.fitted = fit_of(result.settings.objective, development);
    result.lockbox.protocol.kind = Protocol::Kind::kLogs;
    if (!lockbox.empty()) {
      std::vector<int> all = development;
      all.insert(all.end(), lockbox.begin(), lockbox.end());
      result.lockbox.scores = evaluate(result.settings, {lockbox}, all, "lockbox", &result.lockbox);
      for (LogScore& score : result.lockbox.scores) {
        score.settings = result.settings.describe(banks_[0].config);
        score.fold = 0;
        score.selection_score = result.selection.mean_log_probability;
      }
      result.lockbox.summary = summarize(result.lockbox.scores);
      progress("lockbox: " + std::to_string(lockbox.size()) + " logs scored once by the tuned bank");
    }
    progress("searches: " + std::to_string(settings_scored_) + " settings scored, " +
             std::to_string(settings_known_to_tie_) +
             " more known to tie without a run (probability floors no run met)");
    // One line per distinct warning: folds repeat them.
    std::map<std::string, int> seen;
    for (const std::string& w : warnings_) {
      if (seen[w]++ == 0) result.warnings.push_back(w);
    }
    for (std::string& w : result.warnings) {
      if (seen[w] > 1) w += " (" + std::to_string(seen[w]) + " folds)";
    }
    return result;
  }

 private:
  using FitKey = std::pair<std::string, std::vector<int>>;

  void progress(const std::string& line) const {
    if (options_.progress) options_.progress(line);
  }

  // "<what> 20/60 <unit>", and with options_.progress_rates the rate and
  // the time left since `start`.
  void progress(const std::string& what, long done, long total, const std::string& unit,
                std::chrono::steady_clock::time_point start) const {
    std::string line = what + " " + std::to_string(done) + "/" + std::to_string(total) + " " + unit;
    if (options_.progress_rates) {
      const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      const std::string rate = format_rate_and_time_left(done, total, elapsed, unit);
      if (!rate.empty()) line += ", " + rate;
    }
    progress(line);
  }

  // Each step's weight in log i's score, as compute_mode_metrics() weighs it
  // (the time to the next step, the last step's to the one before), and the
  // seconds of its truth: what ScoreBound needs. Left empty (no bound from
  // the log) unless every labelled step has the same truth and the times
  // increase, so that the log's score is its steps' weighted log p(truth)
  // over truth_seconds_.
  void weigh_steps(std::size_t i) {
    const std::vector<LogSample>& samples = recorded_[i].samples();
    const std::string& label = logs_[i].spec.label;
    const std::size_t all = samples.size();
    std::vector<double> weights(all, 0.0);
    std::string truth;
    double seconds = 0.0;
    for (std::size_t k = 0; k < all; ++k) {
      const double w = all == 1 ? 0.0
                       : k + 1 < all ? samples[k + 1].t - samples[k].t
                                     : samples[k].t - samples[k - 1].t;
      if (!(w >= 0.0) || !std::isfinite(w)) return;
      weights[k] = w;
      const std::string& step_truth = label.empty() ? samples[k].truth_mode : label;
      if (step_truth.empty()) continue;
      if (truth.empty()) truth = step_truth;
      if (step_truth != truth) return;
      seconds += w;
    }
    if (!(seconds > 0.0)) return;
    step_weights_[i] = std::move(weights);
    truth_seconds_[i] = seconds;
  }

  // At most how many settings one coordinate search scores: the start, then
  // each knob's candidates in each sweep (search()).
  int settings_per_search() const {
    const BankConfig& config = banks_[0].config;
    int count = 1;
    for (int sweep = 0; sweep < options_.sweeps; ++sweep) {
      const int line = sweep == 0 ? 6 : 4;
      for (Knob knob : options_.knobs) {
        switch (knob) {
          case Knob::kRComponents:
            count += line * static_cast<int>(config.measurement.r.rows());
            break;
          case Knob::kQModes:
            count += line * config.num_modes();
            break;
          case Knob::kLikelihoodDof:
          case Knob::kExtrapolationScale:
            count += sweep == 0 ? 7 : 2;
            break;
          default:
            count += line;
        }
      }
    }
    return count;
  }

  // What the run faces, before it starts: the rows, the fits and the filter
  // runs of the searches (each scores every log of its folds once per setting).
  std::string work_statement(const std::vector<FitKey>& fits, const std::vector<std::vector<int>>& outer,
                             const std::vector<std::vector<std::vector<int>>>& protocol_folds,
                             const std::vector<int>& development, const std::vector<int>& lockbox) const {
    long rows = 0;
    for (const RecordedLog& r : recorded_) rows += static_cast<long>(r.samples().size());
    const auto logs_in = [](const std::vector<std::vector<int>>& folds) {
      long n = 0;
      for (const auto& f : folds) n += static_cast<long>(f.size());
      return n;
    };
    const long objectives = static_cast<long>(options_.objectives.size());
    long searches = objectives;
    long scored = objectives * logs_in(outer);
    std::set<std::vector<int>> searched;  // tuned_without() searches a held-out set once
    for (const auto& folds : protocol_folds) {
      for (std::vector<int> held : folds) {
        std::sort(held.begin(), held.end());
        if (!searched.insert(held).second) continue;
        const std::vector<int> inner_logs = complement(held, development);
        searches += objectives;
        scored += objectives * logs_in(grouped_folds(inner_logs, classes_, options_.inner_folds));
      }
    }
    const long settings = settings_per_search();
    return "work: " + std::to_string(recorded_.size()) + " logs of " + std::to_string(rows) + " rows in all (" +
           std::to_string(lockbox.size()) + " in the lockbox), " + std::to_string(banks_[0].config.num_modes()) +
           " modes; " + std::to_string(fits.size()) + " fits, " + std::to_string(searches) + " searches of at most " +
           std::to_string(settings) + " settings, at most " + std::to_string(scored * settings) +
           " filter runs over a log";
  }

  // The held-out sets of a protocol over the development logs.
  std::vector<std::vector<int>> folds_of(const Protocol& protocol, const std::vector<int>& development,
                                         const std::vector<std::vector<int>>& outer) const {
    if (protocol.kind == Protocol::Kind::kLogs) return outer;
    std::vector<std::string> sessions;
    for (const TuningLog& l : logs_) sessions.push_back(l.session);
    std::vector<double> ranking(logs_.size(), 0.0);
    if (protocol.kind == Protocol::Kind::kExtrapolation) ranking = extrapolation_ranking(protocol, development);
    return protocol_folds(protocol, development, classes_, sessions, ranking, options_.folds);
  }

  // Mean |value| over each development log's steps of what ranks logs for
  // an extrapolation protocol: the log read again with `expression` (or the
  // bank input's) as its only input.
  std::vector<double> extrapolation_ranking(const Protocol& protocol, const std::vector<int>& development) const {
    BankConfig config = banks_[0].config;
    const std::string expression =
        protocol.expression.empty() ? config.columns.inputs[static_cast<std::size_t>(input_index(protocol.input))]
                                    : protocol.expression;
    config.input_names = {protocol.input};
    config.columns.inputs = {expression};
    std::vector<double> ranking(logs_.size(), 0.0);
    try {
      for (int i : development) {
        LogReader reader(config, logs_[static_cast<std::size_t>(i)].spec.files, options_.sampling);
        LogSample sample;
        double sum = 0.0;
        long count = 0;
        while (reader.next(&sample)) {
          if (std::isfinite(sample.u[0])) {
            sum += std::abs(sample.u[0]);
            ++count;
          }
        }
        ranking[static_cast<std::size_t>(i)] = count > 0 ? sum / static_cast<double>(count) : 0.0;
      }
    } catch (const Error& e) {
      // The reader names the bank's file and its inputs; an expression the
      // protocol gave is the command line's, not the bank's: that name goes.
      std::string what = e.what();
      const std::string bank_field = config.shown_file() + ": columns.inputs." + protocol.input + ": ";
      const std::string bank_column = " (the bank's columns.inputs." + protocol.input + ")";
      if (!protocol.expression.empty()) {
        if (what.compare(0, bank_field.size(), bank_field) == 0) what.erase(0, bank_field.size());
        const std::size_t at = what.find(bank_column);
        if (at != std::string::npos) what.erase(at, bank_column.size());
      }
      throw Error("--assess extrapolation:" + protocol.input + "=" + expression + ": " + what);
    }
    return ranking;
  }

  int input_index(const std::string& name) const {
    const std::vector<std::string>& inputs = banks_[0].config.input_names;
    const auto found = std::find(inputs.begin(), inputs.end(), name);
    if (found == inputs.end()) {
      std::string known;
      for (const std::string& n : inputs) known += (known.empty() ? "" : ", ") + n;
      throw Error("extrapolation: '" + name + "' is not an input of bank '" + banks_[0].config.name + "' (inputs: " +
                  known + "); give an expression of the log's columns: extrapolation:" + name + "=EXPRESSION");
    }
    return static_cast<int>(found - inputs.begin());
  }

  // A protocol's nested assessment: each held-out set scored by models fitted
  // and settings tuned (by the inner cross-validation) on the others alone.
  Assessment assess(const Protocol& protocol, const std::vector<std::vector<int>>& folds,
                    const std::vector<int>& development) {
    Assessment out;
    out.protocol = protocol;
    int done = 0;
    const auto start = std::chrono::steady_clock::now();
    for (const auto& held : folds) {
      const auto& [fold_best, inner_score] = tuned_without(held, development);
      for (LogScore& score : evaluate(fold_best, {held}, development, protocol.slug(), &out)) {
        score.settings = fold_best.describe(banks_[0].config);
        score.fold = done;
        score.selection_score = inner_score;
        out.scores.push_back(score);
      }
      progress("assessment (" + protocol.name() + "):", ++done, static_cast<long>(folds.size()), "folds", start);
    }
    out.summary = summarize(out.scores);
    return out;
  }

  // The settings an inner cross-validation on the development logs but
  // `held` chooses, and their mean log p(truth) there. Protocols that hold
  // out the same logs share the search (a session of one log is that log's
  // fold of `logs`): the same logs, folds and fits give the same choice, so
  // it is made once.
  const std::pair<TunedSettings, double>& tuned_without(const std::vector<int>& held,
                                                       const std::vector<int>& development) {
    std::vector<int> key = held;
    std::sort(key.begin(), key.end());
    if (const auto known = settings_without_.find(key); known != settings_without_.end()) return known->second;
    const std::vector<int> inner_logs = complement(held, development);
    const auto inner = grouped_folds(inner_logs, classes_, options_.inner_folds);
    TunedSettings best;
    double best_score = -std::numeric_limits<double>::infinity();
    for (const std::string& objective : options_.objectives) {
      std::vector<LogScore> scores;
      TunedSettings s = search(objective, inner, inner_logs, &scores, /*quiet=*/true);
      const double score = summarize(scores).mean_log_probability;
      if (score > best_score) {
        best_score = score;
        best = s;
      }
    }
    return settings_without_.emplace(std::move(key), std::make_pair(best, best_score)).first->second;
  }

  void compute_fits(const std::vector<FitKey>& keys) {
    std::vector<FitKey> joint;
    std::vector<FitKey> separable;
    for (const FitKey& k : keys) (options_.separable.count(k.first) ? separable : joint).push_back(k);
    compute_separable_fits(separable);
    compute_joint_fits(joint);
  }

  // The logs among `members` that train mode j.
  std::vector<int> members_of_mode(const std::vector<int>& members, int j) const {
    std::vector<int> out;
    for (int i : members) {
      for (const ModeLogs& d : logs_[static_cast<std::size_t>(i)].fit_data) {
        if (d.mode == j) {
          out.push_back(i);
          break;
        }
      }
    }
    return out;
  }

  // An objective that fits each mode from its own logs alone (no joint R,
  // no bank-level parameters): a mode is fitted once per distinct set of its
  // training logs. Leaving out a run of one terrain then refits that
  // terrain's modes only, and nested leave-one-out folds share most fits.
  void compute_separable_fits(const std::vector<FitKey>& keys) {
    using ModeKey = std::tuple<std::string, int, std::vector<int>>;
    const int modes = banks_[0].config.num_modes();
    std::vector<ModeKey> todo;
    std::set<ModeKey> seen;
    for (const FitKey& k : keys) {
      if (fits_.count(k)) continue;
      for (int j = 0; j < modes; ++j) {
        ModeKey key{k.first, j, members_of_mode(k.second, j)};
        if (!std::get<2>(key).empty() && mode_fits_.count(key) == 0 && seen.insert(key).second) todo.push_back(key);
      }
    }
    std::vector<ModeFit> values(todo.size());
    std::vector<std::string> failures(todo.size());
    std::atomic<int> finished{0};
    std::mutex progress_mutex;
    const auto start = std::chrono::steady_clock::now();
    parallel_for(static_cast<int>(todo.size()), workers_, [&](int i, int w) {
      Bank& bank = banks_[static_cast<std::size_t>(w)];
      reset(&bank);
      const auto& [objective, j, members] = todo[static_cast<std::size_t>(i)];
      std::vector<ModeLogs> data;
      for (ModeLogs& d : training_data(logs_, members)) {
        if (d.mode == j) data.push_back(std::move(d));
      }
      // A fold may leave a mode too little data to fit (a protocol that holds
      // out every straight run of a terrain): the fold keeps the mode's
      // starting values, and says so; the final fit on every log may not.
      bool fitted_it = true;
      try {
        fitters_.at(objective)(&bank, data);
      } catch (const FitError& e) {
        failures[static_cast<std::size_t>(i)] = e.what();
        fitted_it = false;
      }
      if (fitted_it) {
        const FittedValues fitted = values_of(bank);
        values[static_cast<std::size_t>(i)] = {fitted.parameters[static_cast<std::size_t>(j)],
                                               fitted.q[static_cast<std::size_t>(j)],
                                               fitted.parameter_covariance[static_cast<std::size_t>(j)],
                                               fitted.residual_correlation[static_cast<std::size_t>(j)],
                                               fitted.fitted_inputs[static_cast<std::size_t>(j)]};
      }
      // A fit that failed is done too: the count reaches the whole (it
      // stopped short, at the fits that succeeded).
      const int n = ++finished;
      std::lock_guard<std::mutex> lock(progress_mutex);
      if (n == static_cast<int>(todo.size()) || n % 20 == 0) {
        progress("fitted", n, static_cast<long>(todo.size()), "modes", start);
      }
    });
    for (std::size_t i = 0; i < todo.size(); ++i) {
      if (failures[i].empty()) {
        mode_fits_[todo[i]] = values[i];
      } else {
        mode_fit_failures_[todo[i]] = failures[i];
      }
    }
    for (const FitKey& k : keys) {
      if (fits_.count(k)) continue;
      FittedValues v = base_;
      std::string missing;
      std::vector<int> fitted_modes;
      for (int j = 0; j < modes; ++j) {
        const ModeKey key{k.first, j, members_of_mode(k.second, j)};
        const auto failed = mode_fit_failures_.find(key);
        if (failed != mode_fit_failures_.end()) {
          if (k.second == development_) throw FitError(failed->second);
          warnings_.push_back("a fold could not fit mode '" + banks_[0].config.modes[static_cast<std::size_t>(j)].name +
                              "' and kept its starting values: " + failed->second);
          continue;
        }
        const auto found = mode_fits_.find(key);
        if (found == mode_fits_.end()) {
          missing += " '" + banks_[0].config.modes[static_cast<std::size_t>(j)].name + "'";
          continue;
        }
        v.parameters[static_cast<std::size_t>(j)] = found->second.parameters;
        v.q[static_cast<std::size_t>(j)] = found->second.q;
        v.parameter_covariance[static_cast<std::size_t>(j)] = found->second.parameter_covariance;
        v.residual_correlation[static_cast<std::size_t>(j)] = found->second.residual_correlation;
        v.fitted_inputs[static_cast<std::size_t>(j)] = found->second.fitted_inputs;
        fitted_modes.push_back(j);
      }
      if (options_.pooled_process_noise.count(k.first) && !fitted_modes.empty()) {
        std::vector<Eigen::MatrixXd> q;
        for (int j : fitted_modes) q.push_back(v.q[static_cast<std::size_t>(j)]);
        const Eigen::MatrixXd pooled = pooled_process_noise(q);
        for (int j : fitted_modes) v.q[static_cast<std::size_t>(j)] = pooled;
      }
      if (options_.partial_pooling.count(k.first) && !fitted_modes.empty()) {
        const PartialPooling outcome =
            pool_parameters_partially(banks_[0], fitted_modes, &v.parameters, &v.parameter_covariance);
        const std::string whose = k.second == development_ ? "the development fit's" : "a fold's";
        for (const auto& [name, why] : outcome.kept_own) {
          warnings_.push_back(whose + " partial pooling kept mode '" + name + "' to its own estimates: " + why +
                              " (objective " + k.first + ")");
        }
        if (outcome.regimes == 0 && k.second == development_) {
          warnings_.push_back(std::string(kNothingPooled) + " (objective " + k.first + ")");
        }
      }
      fits_[k] = v;
      if (!missing.empty() && options_.fit_nothing.count(k.first) == 0) {
        warnings_.push_back("a fold without logs of mode(s)" + missing + " kept their starting values (objective " +
                            k.first + ")");
      }
    }
  }

  void compute_joint_fits(const std::vector<FitKey>& keys) {
    std::vector<FitKey> todo;
    std::set<FitKey> seen;
    for (const FitKey& k : keys) {
      if (fits_.count(k) == 0 && seen.insert(k).second) todo.push_back(k);
    }
    if (todo.empty()) return;
    std::vector<FittedValues> values(todo.size());
    std::vector<std::string> notes(todo.size());
    std::atomic<int> finished{0};
    std::mutex progress_mutex;
    const auto start = std::chrono::steady_clock::now();
    parallel_for(static_cast<int>(todo.size()), workers_, [&](int i, int w) {
      Bank& bank = banks_[static_cast<std::size_t>(w)];
      reset(&bank);
      const auto& [objective, members] = todo[static_cast<std::size_t>(i)];
      const std::vector<ModeLogs> data = training_data(logs_, members);
      for (int j = 0; j < bank.config.num_modes(); ++j) {
        bool present = false;
        for (const ModeLogs& d : data) present = present || d.mode == j;
        if (!present) notes[static_cast<std::size_t>(i)] += " '" + bank.config.modes[static_cast<std::size_t>(j)].name + "'";
      }
      fitters_.at(objective)(&bank, data);
      values[static_cast<std::size_t>(i)] = values_of(bank);
      const int n = ++finished;
      std::lock_guard<std::mutex> lock(progress_mutex);
      if (n == static_cast<int>(todo.size()) || n % 10 == 0) {
        progress("fitted", n, static_cast<long>(todo.size()), "folds", start);
      }
    });
    for (std::size_t i = 0; i < todo.size(); ++i) {
      fits_[todo[i]] = values[i];
      if (!notes[i].empty() && options_.fit_nothing.count(todo[i].first) == 0) {
        warnings_.push_back("a fold without logs of mode(s)" + notes[i] + " kept their starting values (objective " +
                            todo[i].first + ")");
      }
    }
  }

  const FittedValues& fit_of(const std::string& objective, const std::vector<int>& members) const {
    return fits_.at(FitKey{objective, members});
  }

  // <folder>/NNN_<label>_<first file's stem>.csv: unique even when runs of two
  // terrains share file names, and telling which is which; a log without a
  // label whose first file's name another log's shares is named by its folder
  // too (pavement/run_00.csv beside ice/run_00.csv: NNN_pavement_run_00.csv),
  // as the tables name it.
  std::filesystem::path estimates_path(const std::string& folder, int i) const {
    const LogSpec& spec = logs_[static_cast<std::size_t>(i)].spec;
    char index[16];
    std::snprintf(index, sizeof(index), "%03d_", i);
    const std::filesystem::path& first = spec.files.front().path;
    std::string prefix = spec.label.empty() ? "" : spec.label + "_";
    const std::string parent = first.parent_path().filename().string();
    if (spec.label.empty() && !parent.empty() && parent != "." && parent != "..") {
      const bool shared = std::any_of(logs_.begin(), logs_.end(), [&](const TuningLog& other) {
        return &other.spec != &spec && other.spec.files.front().path.filename() == first.filename();
      });
      if (shared) prefix = parent + "_";
    }
    return options_.assessment_estimates / folder / (index + prefix + first.stem().string() + ".csv");
  }

  // Back to the starting values, before a fit or a scoring.
  void reset(Bank* bank) const {
    bank->config.transition = base_transition_;
    bank->config.mode_probability_floor = base_floor_;
    bank->config.likelihood_weight = base_weight_;
    bank->config.likelihood_dof = base_dof_;
    bank->config.unknown.inflation = base_unknown_inflation_;
    bank->config.extrapolation_scale = base_extrapolation_scale_;
    apply(base_, TunedSettings{}, bank);
  }

  // Scores each fold's held-out logs with the fold's fit and `settings`.
  // With `estimates_folder`, each held-out log's steps are written under
  // assessment_estimates/estimates_folder (when set).
  // With `spliced`, the spliced runs' metrics are merged there (splice).
  // With `bound`, the scoring stops once the bound has lost (ScoreBound);
  // the scores are then incomplete, and only bound->lost counts.
  std::vector<LogScore> evaluate(const TunedSettings& settings, const std::vector<std::vector<int>>& folds,
                                 const std::vector<int>& within, const std::string& estimates_folder = "",
                                 Assessment* spliced = nullptr, ScoreBound* bound = nullptr) {
    const bool write_estimates = !estimates_folder.empty() && !options_.assessment_estimates.empty();
    // Each log's weight in summarize()'s mean over classes of its logs' means.
    std::vector<double> weight(logs_.size(), 0.0);
    if (bound != nullptr) {
      std::map<std::string, int> per_class;
      for (const auto& held_out : folds) {
        for (int i : held_out) {
          ++per_class[classes_[static_cast<std::size_t>(i)]];
          if (step_weights_[static_cast<std::size_t>(i)].empty()) bound = nullptr;  // no bound from it
        }
      }
      if (options_.splice || spliced != nullptr) bound = nullptr;
      for (const auto& held_out : bound != nullptr ? folds : std::vector<std::vector<int>>{}) {
        for (int i : held_out) {
          weight[static_cast<std::size_t>(i)] = 1.0 / (static_cast<double>(per_class.size()) *
                                                       per_class[classes_[static_cast<std::size_t>(i)]] *
                                                       truth_seconds_[static_cast<std::size_t>(i)]);
        }
      }
    }
    if (write_estimates) std::filesystem::create_directories(options_.assessment_estimates / estimates_folder);
    std::vector<std::vector<LogScore>> per_fold(folds.size());
    std::vector<evaluation::LogResult> wholes(folds.size());
    std::vector<int> order(folds.size());
    std::iota(order.begin(), order.end(), 0);
    if (bound != nullptr && bound->costs != nullptr) {
      const auto cost = [&](int f) {
        double sum = 0.0;
        for (int i : folds[static_cast<std::size_t>(f)]) sum += (*bound->costs)[static_cast<std::size_t>(i)];
        return sum;
      };
      std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return cost(a) < cost(b); });
    }
    parallel_for(static_cast<int>(folds.size()), workers_, [&](int k, int w) {
      const int f = order[static_cast<std::size_t>(k)];
      if (bound != nullptr && bound->lost) return;
      Bank& bank = banks_[static_cast<std::size_t>(w)];
      reset(&bank);
      const std::vector<int>& held_out = folds[static_cast<std::size_t>(f)];
      const std::vector<int> training = complement(held_out, within);
      for (int i : held_out) {
        SKIDIMM_CHECK(std::find(training.begin(), training.end(), i) == training.end(),
                      "a held-out log is in its fold's training set");
      }
      internal::apply(fit_of(settings.objective, training), settings, &bank,
                      &kept_models_[static_cast<std::size_t>(w)]);
      if (options_.splice && held_out.size() > 1) {
        // Named by the fold's first log, as a log's own file would be.
        char name[32];
        std::snprintf(name, sizeof(name), "spliced_%03d.csv", held_out.front());
        const std::filesystem::path estimates =
            write_estimates ? options_.assessment_estimates / estimates_folder / name : std::filesystem::path();
        per_fold[static_cast<std::size_t>(f)] =
            score_spliced(bank, held_out, &wholes[static_cast<std::size_t>(f)], estimates);
        return;
      }
      for (int i : held_out) {
        const std::filesystem::path estimates =
            write_estimates ? estimates_path(estimates_folder, i) : std::filesystem::path();
        per_fold[static_cast<std::size_t>(f)].push_back(
            score_recorded(bank, i, estimates, bound, weight[static_cast<std::size_t>(i)]));
      }
    });
    std::vector<LogScore> out;
    for (auto& scores : per_fold) out.insert(out.end(), scores.begin(), scores.end());
    if (spliced != nullptr) {
      for (const evaluation::LogResult& whole : wholes) {
        spliced->spliced.merge(whole.metrics);
        spliced->spliced_decision.merge(whole.decision_metrics);
      }
    }
    return out;
  }

  // The logs of `held_out` as one run, classes taking turns (splice): the
  // scores of each log's own steps, in `held_out`'s order.
  std::vector<LogScore> score_spliced(const Bank& bank, const std::vector<int>& held_out, evaluation::LogResult* whole,
                                      const std::filesystem::path& estimates) const {
    std::map<std::string, std::vector<int>> by_class;
    for (int i : held_out) by_class[classes_[static_cast<std::size_t>(i)]].push_back(i);
    std::vector<std::vector<int>> classes;
    for (const auto& [name, logs] : by_class) classes.push_back(logs);
    const std::vector<int> order = taking_turns(classes);
    std::vector<const RecordedLog*> recorded;
    std::vector<std::string> labels, names;
    std::vector<long> steps;
    for (int i : order) {
      const TuningLog& log = logs_[static_cast<std::size_t>(i)];
      recorded.push_back(&recorded_[static_cast<std::size_t>(i)]);
      labels.push_back(log.spec.label);
      names.push_back(names_[static_cast<std::size_t>(i)]);
      steps.push_back(static_cast<long>(recorded_[static_cast<std::size_t>(i)].samples().size()));
    }
    SplicedReplay source(recorded, labels, options_.sampling.rate > 0.0 ? 1.0 / options_.sampling.rate : 0.0);
    const std::vector<evaluation::LogResult> results =
        evaluation::evaluate_spliced(bank, &source, names, steps, whole, estimates);
    std::vector<LogScore> by_log(held_out.size());
    for (std::size_t k = 0; k < order.size(); ++k) {
      const std::size_t at = static_cast<std::size_t>(std::find(held_out.begin(), held_out.end(), order[k]) -
                                                      held_out.begin());
      by_log[at] = score_of(results[k]);
    }
    return by_log;
  }

  // Log i scored by `bank`; with `bound`, each step's weighted log p(truth)
  // times `weight` (the log's in the score) is added to it as it comes.
  LogScore score_recorded(const Bank& bank, int i, const std::filesystem::path& estimates,
                          ScoreBound* bound = nullptr, double weight = 0.0) const {
    const LogSpec& spec = logs_[static_cast<std::size_t>(i)].spec;
    RecordedLog::Replay replay = recorded_[static_cast<std::size_t>(i)].replay();
    if (bound == nullptr) {
      return evaluation::score_of(
          evaluation::evaluate_log(bank, &replay, names_[static_cast<std::size_t>(i)], spec.label, estimates));
    }
    BoundedSource source(&replay, bound);
    const std::vector<double>& step_weight = step_weights_[static_cast<std::size_t>(i)];
    std::size_t k = 0;
    double cost = 0.0;
    const auto observe = [&](const LogSample&, const evaluation::LabelledStep& step) {
      const double w = step_weight[k++];
      if (step.truth.empty()) return;
      const double term = weight * w * std::log(std::max(step.truth_probability, evaluation::kMinScoredProbability));
      cost += term;
      bound->add(term);
    };
    LogScore score = evaluation::score_of(evaluation::evaluate_log(bank, &source, names_[static_cast<std::size_t>(i)],
                                                                   spec.label, estimates, EstimatorOptions{}, observe));
    // Each log is in one fold of an evaluation: no other thread writes its entry.
    if (bound->costs != nullptr && !bound->lost) (*bound->costs)[static_cast<std::size_t>(i)] = cost;
    return score;
  }

  // Coordinate search over the knobs on log-spaced grids, coarse then fine.
  // `start_scores`, when given, receives the scores of the first candidate,
  // the starting settings.
  TunedSettings search(const std::string& objective, const std::vector<std::vector<int>>& folds,
                       const std::vector<int>& within, std::vector<LogScore>* best_scores, bool quiet = false,
                       std::vector<LogScore>* start_scores = nullptr) {
    const BankConfig& config = banks_[0].config;
    TunedSettings current;
    current.objective = objective;
    current.dwell_seconds = base_dwell_;
    current.probability_floor = base_floor_;
    current.likelihood_weight = base_weight_;
    current.likelihood_dof = base_dof_;
    if (config.unknown.enabled()) current.unknown_inflation = base_unknown_inflation_;
    const bool searches_extrapolation =
        std::find(options_.knobs.begin(), options_.knobs.end(), Knob::kExtrapolationScale) != options_.knobs.end();
    if (searches_extrapolation) current.extrapolation_scale = base_extrapolation_scale_;
    std::vector<double> log_costs(logs_.size(), 0.0);
    // A candidate is taken when it beats the best by more than 1e-9; its
    // scoring stops once it cannot (ScoreBound). The bound sits below that by
    // far more than the round-off between its sums and summarize()'s.
    auto score_of = [&](const TunedSettings& s, std::vector<LogScore>* scores, double best_so_far) {
      ++settings_scored_;
      const double must_beat = best_so_far + 1e-9 - 1e-6 * (1.0 + std::abs(best_so_far));
      ScoreBound bound(std::isfinite(must_beat) ? must_beat : -std::numeric_limits<double>::infinity(), &log_costs);
      *scores = evaluate(s, folds, within, "", nullptr, &bound);
      if (bound.lost) return -std::numeric_limits<double>::infinity();
      return summarize(*scores).mean_log_probability;
    };
    double best = score_of(current, best_scores, -std::numeric_limits<double>::infinity());
    if (start_scores != nullptr) *start_scores = *best_scores;
    const double floor_limit = 0.5 / config.num_modes();
    // The floor changes a run only at a step where some probability falls to
    // it. Where the best settings' runs never came down to either floor, the
    // candidate's runs are theirs step for step, bit for bit: a tie. (Most
    // banks never meet their floor; each such candidate cost a whole scoring.)
    const auto floor_changes_nothing = [&](double chosen, double candidate) {
      if (best_scores->empty()) return false;
      for (const LogScore& score : *best_scores) {
        if (!(score.smallest_probability > std::max(chosen, candidate))) return false;  // NaN: not known
      }
      return true;
    };
    for (int sweep = 0; sweep < options_.sweeps; ++sweep) {
      const double factor = sweep == 0 ? 4.0 : 1.5;
      const int steps = sweep == 0 ? 3 : 2;
      // Tries value * factor^k for k in [-steps, steps] on one scalar of the
      // settings: every k (LineSearch::kGrid), or a walk: k = -1, -2, ...
      // while each candidate beats the best, then, if none did, k = 1, 2, ...
      // the same way (kWalk). Where the score rises to one peak along the
      // line the walk ends on the grid's best, and the far candidates it
      // skips would have lost, each after up to a whole scoring.
      // Where the farthest candidate one way is the best, the score may rise
      // further: the line goes on a factor at a time, within the setting's
      // range, while each candidate beats the best, instead of stopping at
      // its reach (which depends on where the bank started) still rising.
      // `ties(chosen, candidate)`: true where the candidate is known to score
      // exactly what the best settings (whose value is `chosen`) scored; it is
      // then not run, as it could not be taken, and a walk goes on past it
      // (a floor changes nothing until some probability comes down to it).
      using Ties = std::function<bool(double, double)>;
      const bool walk = options_.line_search == TuneOptions::LineSearch::kWalk;
      auto line = [&](const std::string& name, double* value, double lowest, double highest, const Ties& ties = {}) {
        const double start = *value;
        double chosen = start;
        // The grid takes k = -steps ... -1, then 1 ... steps, as it always
        // has (the order decides between exact ties); a walk goes outward.
        for (const int direction : {-1, 1}) {
          std::vector<int> ks;
          for (int k = direction; std::abs(k) <= steps; k += direction) ks.push_back(k);
          if (!walk && direction < 0) std::reverse(ks.begin(), ks.end());  // -steps first, as it always has
          // Scores one candidate, unless it is known to tie, and takes it
          // where it beats the best.
          enum class Outcome { kTaken, kLost, kTied };
          const auto try_candidate = [&](double candidate) {
            if (ties && ties(chosen, candidate)) {
              ++settings_known_to_tie_;
              return Outcome::kTied;
            }
            *value = candidate;
            std::vector<LogScore> scores;
            const double score = score_of(current, &scores, best);
            if (!(score > best + 1e-9)) return Outcome::kLost;
            best = score;
            chosen = candidate;
            *best_scores = scores;
            return Outcome::kTaken;
          };
          const auto within = [&](double candidate) { return candidate >= lowest && candidate <= highest; };
          for (const int k : ks) {
            const double candidate = start * std::pow(factor, k);
            if (!within(candidate)) {
              if (walk) break;  // and every candidate beyond
              continue;
            }
            if (try_candidate(candidate) == Outcome::kLost && walk) break;
          }
          // Beyond the line's reach while the score still rises.
          for (int k = direction * (steps + 1); chosen == start * std::pow(factor, k - direction); k += direction) {
            const double candidate = start * std::pow(factor, k);
            if (!within(candidate) || try_candidate(candidate) != Outcome::kTaken) break;
          }
          if (walk && chosen != start) break;
        }
        *value = chosen;
        if (!quiet) progress("  " + objective + ": " + name + " " + brief(chosen) + " -> mean log p(truth) " + brief(best));
      };
      // A setting whose 0 turns a feature off (the Student-t degrees of
      // freedom: the Gaussian; the extrapolation scale: no discount), 0
      // among the candidates: a coarse ladder first, then the neighbours of
      // the best.
      auto ladder = [&](const std::string& name, double* value, const std::vector<double>& coarse_ladder, bool coarse,
                        const std::string& off) {
        const double start = *value;
        std::vector<double> candidates;
        if (coarse) {
          candidates = coarse_ladder;
        } else if (start > 0.0) {
          candidates = {start / std::sqrt(2.0), start * std::sqrt(2.0)};
        }
        double chosen = start;
        for (double candidate : candidates) {
          if (candidate == start) continue;
          *value = candidate;
          std::vector<LogScore> scores;
          const double score = score_of(current, &scores, best);
          if (score > best + 1e-9) {
            best = score;
            chosen = candidate;
            *best_scores = scores;
          }
        }
        *value = chosen;
        if (!quiet) {
          progress("  " + objective + ": " + name + " " + (chosen > 0.0 ? brief(chosen) : off) +
                   " -> mean log p(truth) " + brief(best));
        }
      };
      for (Knob knob : options_.knobs) {
        switch (knob) {
          case Knob::kRScale:
            line("R scale", &current.r_scale, 1e-4, 1e6);
            break;
          case Knob::kRComponents:
            if (current.r_component.size() == 0) current.r_component = Eigen::VectorXd::Ones(config.measurement.r.rows());
            for (Eigen::Index i = 0; i < current.r_component.size(); ++i) {
              line("R std scale of " + config.measurement.names[static_cast<std::size_t>(i)], &current.r_component[i],
                   1e-2, 1e3);
            }
            break;
          case Knob::kQScale:
            line("Q scale", &current.q_scale, 1e-6, 1e6);
            break;
          case Knob::kQModes:
            if (current.q_mode.size() == 0) current.q_mode = Eigen::VectorXd::Ones(config.num_modes());
            for (Eigen::Index j = 0; j < current.q_mode.size(); ++j) {
              line("Q scale of " + config.modes[static_cast<std::size_t>(j)].name, &current.q_mode[j], 1e-4, 1e4);
            }
            break;
          case Knob::kDwell:
            if (current.dwell_seconds <= 0.0) current.dwell_seconds = 10.0;
            line("dwell (s)", &current.dwell_seconds, 1e-2, 1e6);
            break;
          case Knob::kFloor:
            if (current.probability_floor <= 0.0) current.probability_floor = 1e-9;
            line("probability floor", &current.probability_floor, 1e-15, floor_limit, floor_changes_nothing);
            break;
          case Knob::kLikelihoodWeight:
            line("likelihood weight", &current.likelihood_weight, 1e-4, 1.0);
            break;
          case Knob::kLikelihoodDof:
            ladder("likelihood dof", &current.likelihood_dof, {0.0, 1.0, 2.0, 4.0, 8.0, 16.0, 32.0}, sweep == 0,
                   "Gaussian");
            break;
          case Knob::kExtrapolationScale:
            // In widths of a class's fitted input range (extrapolation_discount.h).
            ladder("extrapolation scale", &current.extrapolation_scale, {0.0, 0.125, 0.25, 0.5, 1.0, 2.0, 4.0},
                   sweep == 0, "off");
            break;
          case Knob::kUnknownInflation:
            line("unknown inflation", &current.unknown_inflation, 1.0 + 1e-6, 1e12);
            break;
        }
      }
    }
    return current;
  }

  // Each log's name in the tables: its files' names, or paths where those would be the same.
  static std::vector<std::string> table_names(const std::vector<TuningLog>& logs) {
    std::vector<const LogSpec*> specs;
    for (const TuningLog& log : logs) specs.push_back(&log.spec);
    return distinct_names(specs);
  }

  const std::vector<TuningLog>& logs_;
  const std::vector<std::string> names_;
  const std::map<std::string, BankFitter>& fitters_;
  const TuneOptions& options_;
  int workers_ = 1;
  std::vector<Bank> banks_;
  std::vector<internal::KeptCovarianceModels> kept_models_;  // one per bank, as apply() meets fits again
  FittedValues base_;
  TransitionConfig base_transition_;
  double base_dwell_ = 0.0;
  double base_floor_ = 1e-9;
  double base_weight_ = 1.0;
  double base_dof_ = 0.0;
  double base_unknown_inflation_ = 0.0;  // the bank's unknown.inflation; 0: no unknown hypothesis
  double base_extrapolation_scale_ = 0.0;  // the bank's extrapolation_scale; 0: no discount
  std::vector<std::string> classes_;
  std::vector<RecordedLog> recorded_;
  std::vector<std::vector<double>> step_weights_;  // weigh_steps()
  std::vector<double> truth_seconds_;
  std::map<FitKey, FittedValues> fits_;
  // tuned_without(), by the held-out logs.
  std::map<std::vector<int>, std::pair<TunedSettings, double>> settings_without_;
  // One mode's fit.
  struct ModeFit {
    Eigen::VectorXd parameters;
    Eigen::MatrixXd q;
    Eigen::MatrixXd parameter_covariance;
    double residual_correlation = 0.0;
    std::map<std::string, InputRange> fitted_inputs;
  };
  std::map<std::tuple<std::string, int, std::vector<int>>, ModeFit> mode_fits_;
  std::map<std::tuple<std::string, int, std::vector<int>>, std::string> mode_fit_failures_;  // why a fold's fit failed
  std::vector<int> development_;  // every log but the lockbox: the final fit's
  std::vector<std::string> warnings_;
  long settings_scored_ = 0;        // by search()
  long settings_known_to_tie_ = 0;  // by search(), without a run
};

}  // namespace

TuneResult tune(const std::function<Bank()>& make_bank, const std::vector<TuningLog>& logs,
                const std::map<std::string, BankFitter>& fitters, const TuneOptions& options) {
  if (logs.size() < 2) throw Error("tuning by cross-validation needs at least two logs");
  if (options.objectives.empty()) throw Error("no fit objective to tune");
  // One group of logs leaves nothing to train each fold on.
  if (options.folds == 1 || options.folds < 0) {
    throw Error("folds: " + std::to_string(options.folds) +
                " cannot cross-validate; give 0 (leave one log out) or at least 2");
  }
  if (options.assess && (options.inner_folds == 1 || options.inner_folds < 0)) {
    throw Error("inner folds: " + std::to_string(options.inner_folds) +
                " cannot cross-validate; give 0 (leave one log out) or at least 2");
  }
  for (const std::string& o : options.objectives) {
    if (fitters.count(o) == 0) throw Error("unknown fit objective '" + o + "'");
  }
  Tuner tuner(make_bank, logs, fitters, options);
  return tuner.run();
}

}  // namespace fitting
}  // namespace skidimm
