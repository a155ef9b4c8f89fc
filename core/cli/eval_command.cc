// skidimm eval: identification metrics over one or many logs.
#include <iostream>
#include <optional>

#include "commands.h"
#include "skidimm/config/run_overrides.h"
#include "skidimm/errors.h"
#include "skidimm/evaluation/evaluation_report.h"
#include "skidimm/evaluation/log_groups.h"

namespace skidimm {
namespace cli {

namespace {

// A mode whose model failed is reset and scores as if it had not: its
// failures are said (stderr, as `run` says them), per log, and a log on which
// no mode's filter ever ran is named as such, whatever its scores read. So is
// a measurement a log never gave (in a splice, each line names its log).
void report_each_logs_problems(const Bank& bank, const std::vector<evaluation::LogGroup>& groups, bool spliced) {
  std::cout.flush();
  for (const evaluation::LogGroup& group : groups) {
    for (const evaluation::LogResult& log : group.logs) {
      // A measurement the log never gave (a misspelt column name in a bag's
      // sequence) leaves the log scored on the others, without a word otherwise.
      const std::string where = spliced ? "" : printable(log.source) + ": ";
      for (const std::string& line : log.unmeasured) {
        std::cerr << "skidimm eval: warning: " << where << printable(line) << "\n";
      }
      // Left out by the bank's options, as asked: said, not warned of.
      for (const std::string& line : log.skipped) std::cerr << "skidimm eval: " << where << printable(line) << "\n";
      bool any = false;
      for (const ModeRejections& r : log.rejections) any = any || r.rows > 0;
      if (!any) continue;
      std::cerr << "skidimm eval: " << printable(log.source) << ": modes rejected and reset (their steps score the "
                << "reset filter, not the model):\n";
      print_rejections(bank, log.rejections);
      if (log.steps_every_mode_rejected > 0) {
        std::cerr << "  on " << log.steps_every_mode_rejected << " of " << log.steps
                  << " steps every mode was rejected: no model ran there, and the scores above do not measure "
                     "the bank on them\n";
      }
    }
  }
}

// The most combinations of decision settings one eval compares.
constexpr std::size_t kMostDecisionSettingsCompared = 1000;

// Every combination of the decision settings given (a list each, in the
// order given: enter slowest, hold fastest), over `base` for those not given.
std::vector<DecisionConfig> decision_grid(const DecisionConfig& base, const EvalOptions& options) {
  const auto or_base = [](const std::vector<double>& given, double value) {
    return given.empty() ? std::vector<double>{value} : given;
  };
  std::vector<DecisionConfig> grid;
  for (double enter : or_base(options.decision_enter, base.enter)) {
    for (double leave : or_base(options.decision_leave, base.leave)) {
      for (double hold : or_base(options.decision_hold, base.min_hold)) {
        RunOverrides overrides;
        overrides.decision_enter = enter;
        overrides.decision_leave = leave;
        overrides.decision_hold = hold;
        overrides.decision_stale = options.overrides.decision_stale;  // one value for every combination
        // Checks each as a bank's setting.
        grid.push_back(settings_given_on_the_command_line([&] { return decision_settings_of(base, overrides); }));
      }
    }
  }
  return grid;
}

// The logs that failed, after the report of the others (stderr), and the
// exit code: a failure even when every other log was scored. `spliced`: the
// logs scored were joined into one run (--splice), this many.
int report_failures(const std::vector<evaluation::LogGroup>& groups,
                    const std::vector<evaluation::LogFailure>& failures, std::optional<std::size_t> spliced) {
  if (failures.empty()) return kExitOk;
  std::cout.flush();
  std::size_t scored = 0;
  for (const evaluation::LogGroup& g : groups) scored += g.logs.size();
  if (spliced) scored = *spliced;
  for (const evaluation::LogFailure& f : failures) {
    std::cerr << "skidimm eval: error: " << printable(f.message) << "\n";
  }
  std::cerr << "skidimm eval: " << failures.size() << " of " << failures.size() + scored
            << " log(s) failed and are left out of "
            << (groups.empty() ? std::string("every figure: nothing was scored")
                : spliced      ? "the splice above, which joins the other " + std::to_string(scored)
                               : "the report above, which scores the other " + std::to_string(scored))
            << "\n";
  return kExitFailure;
}

}  // namespace

int eval(const EvalOptions& given) {
  return report_errors("skidimm eval", [&] {
    // One value of each decision setting overrides the bank's; lists compare settings (--estimates).
    EvalOptions options = given;
    const bool compares_decisions =
        options.decision_enter.size() > 1 || options.decision_leave.size() > 1 || options.decision_hold.size() > 1;
    if (compares_decisions && !options.range_for.empty()) {
      throw UsageError(
          "--range-for gives the range of one report's accuracy, and lists of --decision-* settings compare "
          "decisions: give one or the other");
    }
    // Each combination scores every file again, and the report has a table for each.
    const std::size_t combinations = std::max<std::size_t>(1, options.decision_enter.size()) *
                                     std::max<std::size_t>(1, options.decision_leave.size()) *
                                     std::max<std::size_t>(1, options.decision_hold.size());
    if (combinations > kMostDecisionSettingsCompared) {
      throw UsageError("lists of --decision-* settings make " + std::to_string(combinations) +
                       " combinations; at most " + std::to_string(kMostDecisionSettingsCompared) +
                       " are compared (each scores every file again): give shorter lists");
    }
    if (compares_decisions && options.estimates.empty()) {
      throw UsageError(
          "lists of --decision-* settings are compared on files a filter already wrote (--estimates): run the logs "
          "once with `skidimm run`, then score them with each setting");
    }
    if (!compares_decisions) {
      if (!options.decision_enter.empty()) options.overrides.decision_enter = options.decision_enter.front();
      if (!options.decision_leave.empty()) options.overrides.decision_leave = options.decision_leave.front();
      if (!options.decision_hold.empty()) options.overrides.decision_hold = options.decision_hold.front();
    }
    std::vector<evaluation::LogGroup> groups;
    // Decision settings compared (lists given), and the groups scored with each.
    std::vector<DecisionConfig> grid;
    std::vector<std::vector<evaluation::LogGroup>> compared;
    std::vector<std::string> classes, states;
    std::string decision_made;
    // A log that fails half-way costs the others nothing: they are reported,
    // the failures listed after them, and the exit code says it.
    std::vector<evaluation::LogFailure> failures;
    std::optional<Bank> ran;  // the bank run over the logs (not with --estimates)
    std::optional<std::size_t> spliced;  // with --splice, how many logs the run joins
    const EstimatorOptions estimator = command_line_estimator(options.smooth, options.lag, options.overrides);
    if (options.splice && (!options.estimates.empty() || options.smooth || options.lag)) {
      throw UsageError(options.estimates.empty()
                           ? std::string("--splice scores the filter as it runs across each change, and ") +
                                 (options.smooth ? "--smooth" : "--lag") +
                                 " would smooth it with the measurements after the change: give one or the other"
                           : "--splice runs the bank over logs given with --input and --bank, and --estimates scores "
                             "files `skidimm run` already wrote: give one or the other");
    }
    if (!options.estimates.empty()) {
      // The files hold what a filter already computed; these would change the filter.
      if (options.overrides.likelihood_weight || options.overrides.innovation_gate) {
        throw UsageError(
            std::string(options.overrides.likelihood_weight ? "--likelihood-weight" : "--innovation-gate") +
            " changes how the filter runs, and --estimates scores files a filter already wrote: give the "
            "logs with --bank and --input, or run them again with `skidimm run` and this setting");
      }
      // ... and these would be ignored: the files were run, smoothed or not, at their rate.
      const char* unused = !options.inputs.empty()  ? "--input"
                           : options.smooth         ? "--smooth"
                           : options.lag            ? "--lag"
                           : options.overrides.rate ? "--rate"
                                                    : nullptr;
      if (unused != nullptr) {
        throw UsageError(std::string(unused) +
                         " is for logs the bank is run over, and --estimates scores files `skidimm run` already "
                         "wrote (smoothed or not, at their rate): give one or the other");
      }
      std::optional<BankConfig> bank;
      if (!options.bank.empty()) bank = load_bank_config(options.bank);
      if (compares_decisions) {
        grid = decision_grid(bank ? bank->decision : DecisionConfig{}, options);
        compared =
            evaluation::evaluate_estimate_groups(options.estimates, bank ? &*bank : nullptr, grid,
                                                 unpaired_runs("skidimm eval", options.skip_unpaired), &failures);
        groups = compared.front();
      } else {
        // Given on the command line, the decision is made again from each
        // file's probabilities (from the bank's settings, or the defaults).
        std::optional<DecisionConfig> decide;
        if (options.overrides.changes_decision()) {
          decide = settings_given_on_the_command_line(
              [&] { return decision_settings_of(bank ? bank->decision : DecisionConfig{}, options.overrides); });
        }
        decision_made = decide ? "made again: " + evaluation::decision_settings_text(*decide)
                               : std::string("the files' decision column");
        groups = evaluation::evaluate_estimate_groups(options.estimates, bank ? &*bank : nullptr,
                                                      decide ? &*decide : nullptr,
                                                      unpaired_runs("skidimm eval", options.skip_unpaired), &failures);
      }
      classes = evaluation::classes_of(groups);
    } else {
      if (options.bank.empty()) throw UsageError("give --bank with --input, or --estimates");
      Bank& bank = ran.emplace(Bank::load(options.bank, options.plugin_paths));
      settings_given_on_the_command_line([&] { apply_overrides(options.overrides, &bank.config); });
      {
        FatalSignalWording wording;
        wording.lost = "nothing is scored (the report comes when every log is done)";
        wording.every_model_call_marked = false;  // the smoother calls the models itself
        wording.several_threads = true;           // logs are scored on every core
        name_plugins_in_fatal_signals("skidimm eval", bank, wording);
      }
      warn_of_rate_unlike_the_banks("skidimm eval", options.bank, bank.config, options.overrides.rate);
      decision_made = evaluation::decision_settings_text(bank.config.decision);
      classes = bank.config.class_names();
      states = bank.config.state_names;
      const SamplingConfig sampling = sampling_of(bank.config, options.overrides.rate);
      const LogArgumentOptions expansion = unpaired_runs("skidimm eval", options.skip_unpaired);
      if (options.splice) {
        spliced.emplace();
        groups = evaluation::evaluate_spliced_logs(bank, options.inputs, sampling, expansion, &failures, &*spliced);
      } else {
        groups = evaluation::evaluate_log_groups(bank, options.inputs, sampling, estimator, expansion, &failures);
      }
    }
    if (groups.empty() && failures.empty()) {
      throw Error("nothing to evaluate: give --input (with --bank) or --estimates");
    }
    if (!groups.empty()) {
      std::cout << (!grid.empty() ? evaluation::report_decision_settings(grid, compared, classes, states, options.json)
                    : options.json
                        ? evaluation::report_json(groups, classes, states, options.range_for)
                        : evaluation::report_tables(groups, classes, states, decision_made, options.range_for));
    }
    // A count that does not fit the scored classes is said in the report
    // (which keeps every other figure) and fails the command.
    const std::string range_problem = options.range_for.empty() || groups.empty()
                                          ? ""
                                          : evaluation::logs_per_class_problem(groups, options.range_for);
    if (ran) report_each_logs_problems(*ran, groups, spliced.has_value());
    const int code = report_failures(groups, failures, spliced);
    // A report of no labelled time scores nothing: a script or CI check must
    // not read it as a pass.
    bool scored = false;
    for (const evaluation::LogGroup& g : groups) {
      for (const evaluation::LogResult& l : g.logs) scored = scored || l.metrics.duration > 0.0;
    }
    if (!groups.empty() && !scored) {
      std::cerr << "skidimm eval: error: no log has labelled time (two steps or more with a truth): nothing was "
                   "scored\n";
      return kExitFailure;
    }
    if (!range_problem.empty()) {
      std::cerr << "skidimm eval: error: --range-for: " << printable(range_problem)
                << " (the report above has every other figure)\n";
      if (code == kExitOk) return kExitUsage;  // a log that failed is said first
    }
    return code;
  });
}

}  // namespace cli
}  // namespace skidimm
