// skidimm tune: choose what decides identification by cross-validation
// grouped by log file (fitting/tuning.h), and write the tuned bank.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <mutex>
#include <sstream>
#include <stdexcept>

#include "commands.h"
#include "skidimm/errors.h"
#include "skidimm/evaluation/accuracy_range.h"
#include "skidimm/evaluation/evaluation_report.h"
#include "skidimm/fitting/bank_fit.h"
#include "skidimm/fitting/bank_writer.h"
#include "skidimm/fitting/fit_logs.h"
#include "skidimm/fitting/sessions.h"
#include "skidimm/fitting/solver_messages.h"
#include "skidimm/fitting/tuning.h"
#include "skidimm/io/log_arguments.h"
#include "skidimm/io/output_file.h"
#include "skidimm/progress.h"

namespace skidimm {
namespace cli {

namespace fs = std::filesystem;
using fitting::LogScore;
using fitting::Summary;

namespace {

// Whether two logs read the same files (offsets aside: the same recording).
bool same_files(const LogSpec& a, const LogSpec& b) {
  if (a.files.size() != b.files.size()) return false;
  for (std::size_t k = 0; k < a.files.size(); ++k) {
    std::error_code ec;
    if (!fs::equivalent(a.files[k].path, b.files[k].path, ec)) return false;
  }
  return true;
}

// A log given twice would be scored by a fold whose fit trained on its copy,
// and a lockbox log that is also a development log is no lockbox: either
// would make the scores optimistic without a word.
void refuse_repeated_logs(const std::vector<fitting::TuningLog>& logs) {
  const auto given = [](const fitting::TuningLog& log) {
    return (log.lockbox ? "--lockbox " : "--log ") + log.spec.text;
  };
  for (std::size_t i = 0; i < logs.size(); ++i) {
    for (std::size_t j = 0; j < i; ++j) {
      if (!same_files(logs[j].spec, logs[i].spec)) continue;
      throw Error("the log " + logs[i].spec.name() + " is given twice (" + given(logs[j]) + " and " + given(logs[i]) +
                  "): a fold would score it with a fit trained on its copy; give each log once");
    }
  }
}

std::vector<std::string> split_list(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    if (!item.empty()) out.push_back(item);
  }
  return out;
}

std::string number(double v, const char* format = "%.3f") {
  char b[64];
  std::snprintf(b, sizeof(b), format, v);
  return b;
}

// The range of accuracy another set of logs would score (accuracy_range.h),
// holding `another`'s counts of each class (empty: as many as `scores`), or
// why `another` does not fit the scored logs' classes (`problem`).
struct RangeOrProblem {
  evaluation::AccuracyRange range;
  std::string problem;
};

RangeOrProblem range_or_problem(const std::vector<LogScore>& scores, const std::map<std::string, int>& another) {
  RangeOrProblem r;
  try {
    r.range = evaluation::accuracy_range(scores, another);
  } catch (const std::invalid_argument& e) {
    r.problem = e.what();
  }
  return r;
}

// `held_out`: the scores are of logs nothing chose the settings on, so the
// range another set of logs would score is said (not of the selection's own
// cross-validation, which chose them): of `another`'s counts of each class,
// or as many as were scored.
// `decision`: the bank's decision settings, as decision_settings_text() says them.
void print_scores(std::ostream& out, const std::string& title, const std::vector<LogScore>& scores,
                  const Summary& summary, const std::string& decision, bool with_settings, bool held_out,
                  const std::map<std::string, int>& another = {}) {
  std::size_t width = 8;
  for (const LogScore& s : scores) width = std::max(width, s.log.size());
  out << "\n" << title << "\n  " << std::string(width, ' ') << "  truth            accuracy  mean log p(truth)\n";
  for (const LogScore& s : scores) {
    out << "  " << s.log << std::string(width - s.log.size(), ' ') << "  " << s.truth
        << std::string(s.truth.size() < 16 ? 16 - s.truth.size() : 1, ' ') << " " << number(s.accuracy) << "     "
        << number(s.mean_log_probability) << (with_settings ? "   " + s.settings : "") << "\n";
  }
  out << "  per class (mean over its logs):";
  for (const auto& [c, a] : summary.class_accuracy) {
    out << " " << c << " " << number(a) << " (" << number(summary.class_log_probability.at(c), "%.2f") << ")";
  }
  out << "\n  mean over classes: accuracy " << number(summary.accuracy) << ", mean log p(truth) "
      << number(summary.mean_log_probability) << "\n";
  if (std::isfinite(summary.decision_accuracy)) {
    out << "  the decision (" << decision << "): right " << number(summary.decision_accuracy) << ", `unknown` "
        << number(summary.decision_unknown) << " of the time (mean over classes)\n";
  }
  if (held_out && scores.size() > 1) {
    const RangeOrProblem r = range_or_problem(scores, another);
    out << "  " << (r.problem.empty() ? r.range.describe() : "no range for --range-for: " + r.problem) << "\n";
  }
}

// One row per scored log: `kind` is the protocol of a nested assessment
// (logs, sessions, extrapolation-INPUT), lockbox, or selection; `fold` the
// held-out set of its protocol (empty for selection) and `selection_score`
// the mean log p(truth) its settings were chosen by, without it.
void write_table(const fs::path& file, const fitting::TuneResult& result) {
  std::ostringstream out;
  out << "kind,log,truth,accuracy,mean_log_probability,seconds,fold,selection_score,outside_fitted_inputs\n";
  auto rows = [&](const std::string& kind, const std::vector<LogScore>& scores) {
    for (const LogScore& s : scores) {
      const evaluation::ExtrapolationCounts& e = s.extrapolation;
      const double outside = e.labelled > 0 ? static_cast<double>(e.outside_truth) / static_cast<double>(e.labelled)
                                            : std::numeric_limits<double>::quiet_NaN();
      out << kind << "," << s.log << "," << s.truth << "," << number(s.accuracy, "%.6f") << ","
          << number(s.mean_log_probability, "%.6f") << "," << number(s.seconds, "%.3f") << ","
          << (s.fold >= 0 ? std::to_string(s.fold) : "") << "," << number(s.selection_score, "%.9g") << ","
          << number(outside, "%.6f") << "\n";
    }
  };
  for (const fitting::Assessment& a : result.assessments) rows(a.protocol.slug(), a.scores);
  rows("lockbox", result.lockbox.scores);
  rows("selection", result.selection_scores);
  write_file_atomically(file, out.str());  // output_file.h: checked, renamed when whole
}

// How much of the held-out logs' time asked the true class's models to
// extrapolate (outside the input ranges the fold's fit recorded), and the
// most likely class's accuracy there and elsewhere; nothing for a bank that
// records no ranges.
void print_extrapolation(std::ostream& out, const std::vector<LogScore>& scores) {
  evaluation::ExtrapolationCounts e;
  for (const LogScore& s : scores) e.merge(s.extrapolation);
  if (e.labelled == 0) return;
  const auto percent = [](long part, long whole) {
    return number(100.0 * static_cast<double>(part) / static_cast<double>(whole), "%.1f") + "%";
  };
  out << "  inputs outside the ranges the true class was fitted on: " << percent(e.outside_truth, e.labelled)
      << " of the labelled steps; the most likely class right on " << e.accuracy_by_truth_side() << "\n";
}

// How fast the spliced runs' changes of class were followed (tune --splice).
void print_switches(std::ostream& out, const fitting::Assessment& a) {
  const auto line = [&](const char* what, const evaluation::ModeMetrics& m) {
    std::vector<double> first;
    long never = 0;
    for (const evaluation::SwitchDetection& d : m.switches) {
      if (std::isfinite(d.first_latency)) {
        first.push_back(d.first_latency);
      } else {
        ++never;
      }
    }
    std::sort(first.begin(), first.end());
    const double median = first.empty() ? std::numeric_limits<double>::quiet_NaN()
                          : first.size() % 2 == 1 ? first[first.size() / 2]
                                                  : 0.5 * (first[first.size() / 2 - 1] + first[first.size() / 2]);
    out << "  " << what << ": " << m.switches.size() << " changes of class, followed after a median "
        << number(median, "%.1f") << " s, never " << never << "\n";
  };
  if (a.spliced.switches.empty()) return;
  line("most likely class", a.spliced);
  line("decision", a.spliced_decision);
}

// What each protocol asks, for the printed titles.
std::string question_of(const fitting::Protocol& p, int folds) {
  switch (p.kind) {
    case fitting::Protocol::Kind::kLogs:
      return folds > 0 ? std::to_string(folds) + " groups of logs held out in turn" : "each log held out";
    case fitting::Protocol::Kind::kSessions:
      return "each session held out";
    case fitting::Protocol::Kind::kExtrapolation:
      return "per class, the logs with the largest mean |" + p.input + "| held out together";
  }
  return "";
}

// Whether each class of the bank has steps in `log` (its fit data).
std::vector<bool> classes_shown(const BankConfig& config, const fitting::TuningLog& log) {
  const std::vector<int> class_of = config.class_of_modes();
  std::vector<bool> shown(config.class_names().size(), false);
  for (const fitting::ModeLogs& d : log.fit_data) {
    if (!d.logs.empty()) shown[static_cast<std::size_t>(class_of[static_cast<std::size_t>(d.mode)])] = true;
  }
  return shown;
}

// Modes whose filter was rejected and reset (the model failed, the filter
// diverged) while the chosen settings scored the development logs: said as
// eval says it, once for all the logs, since there the scores, and the
// settings chosen on them, measure a reset filter rather than the model.
void warn_of_rejected_modes(const Bank& bank, const std::vector<LogScore>& scores, const std::string& settings) {
  const std::size_t modes = bank.config.modes.size();
  std::vector<ModeRejections> merged(modes);
  std::vector<std::string> first_logs(modes);
  long steps = 0, logs_with_rejections = 0;
  for (const LogScore& score : scores) {
    steps += score.steps;
    bool any = false;
    for (std::size_t j = 0; j < std::min(modes, score.rejections.size()); ++j) {
      const ModeRejections& r = score.rejections[j];
      if (r.rows == 0) continue;
      any = true;
      ModeRejections& m = merged[j];
      if (m.rows == 0) {
        m.first_row = r.first_row;
        m.first_t = r.first_t;
        m.first_failure = r.first_failure;
        m.first_reason = r.first_reason;
        first_logs[j] = score.log;
      }
      m.rows += r.rows;
      for (int f = 0; f < kNumModeFailures; ++f) {
        if (f != static_cast<int>(ModeFailure::kGated)) m.by_failure[f] += r.by_failure[f];
      }
    }
    logs_with_rejections += any ? 1 : 0;
  }
  if (logs_with_rejections == 0) return;
  std::cerr << "skidimm tune: warning: modes rejected and reset on " << logs_with_rejections << " of " << scores.size()
            << " development log(s) (" << steps << " steps), scored " << settings
            << ": their steps score the reset filter, not the model; `skidimm eval` names each log's:\n";
  print_rejections(bank, merged, first_logs);
}

// A range for another set holding a class that no log holds could not be
// given under any table: said before the work, as a bad command line.
void refuse_ranges_of_classes_not_held(const BankConfig& config, const std::vector<fitting::TuningLog>& logs,
                                       std::size_t development, const std::map<std::string, int>& another) {
  if (another.empty()) return;
  const std::vector<std::string> classes = config.class_names();
  std::vector<bool> held(classes.size(), false);
  for (std::size_t i = 0; i < development; ++i) {
    const std::vector<bool> shown = classes_shown(config, logs[i]);
    for (std::size_t c = 0; c < classes.size(); ++c) held[c] = held[c] || shown[c];
  }
  for (std::size_t c = 0; c < classes.size(); ++c) {
    if (!held[c] && another.count(classes[c]) > 0) {
      throw UsageError("--range-for: no development log (--log) holds class '" + classes[c] +
                       "', so no held-out table could say how logs of it would score; leave it out of --range-for");
    }
  }
}

// Classes the development logs cannot assess: a single class (nothing to
// tell apart: every verdict reads "told apart"), a class of one log (each
// fold holding it out fits that class's modes on nothing and scores the
// starting values), or, where tune fits (`fits`), a class of none (its
// modes compete unfitted in every search and fold). Said before the work,
// on stderr.
void warn_of_classes_with_too_few_logs(const BankConfig& config, const std::vector<fitting::TuningLog>& logs,
                                       std::size_t development, bool assessed, bool fits) {
  const std::vector<std::string> classes = config.class_names();
  std::vector<int> logs_of(classes.size(), 0);
  for (std::size_t i = 0; i < development; ++i) {
    const std::vector<bool> shown = classes_shown(config, logs[i]);
    for (std::size_t c = 0; c < classes.size(); ++c) logs_of[c] += shown[c] ? 1 : 0;
  }
  std::vector<std::string> present, single, none;
  for (std::size_t c = 0; c < classes.size(); ++c) {
    if (logs_of[c] > 0) present.push_back(classes[c]);
    if (logs_of[c] == 1) single.push_back(classes[c]);
    if (logs_of[c] == 0) none.push_back(classes[c]);
  }
  const auto join = [](const std::vector<std::string>& names) {
    std::string out;
    for (const std::string& n : names) out += (out.empty() ? "" : ", ") + n;
    return out;
  };
  if (present.size() == 1) {
    std::cerr << "skidimm tune: warning: the development logs show one class only (" << present.front()
              << "): there is nothing to tell apart, the settings are chosen on that class alone, and a verdict "
                 "that the classes are told apart means nothing here; give logs of two classes or more\n";
  }
  if (fits && !none.empty() && !present.empty()) {
    std::cerr << "skidimm tune: warning: "
              << (none.size() == 1 ? "class " + none.front() + " has no development log"
                                   : "classes " + join(none) + " have no development log")
              << ": no fit gives " << (none.size() == 1 ? "its" : "their")
              << " modes anything to learn, so they keep the bank's starting values and compete so in every search "
                 "and fold, which can take the probability from the fitted classes and ruin every score (a lockbox "
                 "log of such a class is scored by modes never fitted); give each class logs, or remove it from the "
                 "bank\n";
  }
  if (assessed && !single.empty()) {
    std::cerr << "skidimm tune: warning: "
              << (single.size() == 1 ? "class " + single.front() + " has one development log"
                                     : "classes " + join(single) + " have one development log each")
              << ": a fold that holds such a log out has no log to fit its class's modes on, and scores it with "
                 "their starting values; give each class two logs or more\n";
  }
}

}  // namespace

int tune(const TuneCommandOptions& options) {
  fitting::capture_solver_messages();  // Ceres' glog output, summarised at the end
  const int code = report_errors("skidimm tune", [&] {
    // The names of --objective, --tune and --assess are the command line's:
    // a typo is a bad command line (exit 2), found before any log is read.
    const auto named = [](const char* option, const auto& parse) { given_on_the_command_line(option, parse); };
    const std::vector<std::string> objectives = split_list(options.objectives);
    named("--objective", [&] {
      for (const std::string& name : objectives) {
        if (name == "none") continue;  // tune's own: the bank's models as they are
        try {
          fitting::objective_from_string(name);
        } catch (const Error& e) {
          throw Error(std::string(e.what()) + ", or none (no fit)");
        }
      }
    });
    std::vector<fitting::Knob> knobs;
    named("--tune", [&] {
      for (const std::string& k : split_list(options.knobs)) knobs.push_back(fitting::knob_from_string(k));
    });
    std::vector<fitting::Protocol> protocols;
    named("--assess", [&] {
      for (const std::string& p : split_list(options.protocols)) protocols.push_back(fitting::protocol_from_string(p));
    });
    // Fit options the objectives cannot give would be ignored without a word.
    if (options.fit_r && std::find(objectives.begin(), objectives.end(), "likelihood") == objectives.end()) {
      throw UsageError("--fit-r is an option of the likelihood objective, which --objective does not name");
    }
    const bool fits =
        std::any_of(objectives.begin(), objectives.end(), [](const std::string& n) { return n != "none"; });
    for (const auto& [given, option] :
         {std::make_pair(options.full_q, "--full-q"), std::make_pair(options.hold_unexcited, "--hold-unexcited")}) {
      if (given && !fits) {
        throw UsageError(std::string(option) + " is an option of the fits, and --objective (" + options.objectives +
                         ") names none that fits (none tunes the bank's models as they are); leave it out or name an "
                         "objective that fits");
      }
    }
    for (const auto& [given, option] : {std::make_pair(options.parameter_uncertainty, "--parameter-uncertainty"),
                                        std::make_pair(options.residual_correlation, "--residual-correlation"),
                                        std::make_pair(options.pooled_q, "--pooled-q")}) {
      for (const std::string& name : objectives) {
        if (given && name != "window") {
          throw UsageError(std::string(option) +
                           " is estimated by the window objective; every objective of --objective must be window "
                           "(got '" +
                           options.objectives + "')");
        }
      }
    }
    // Checked before the bank and the logs are read. Their tables, table rows and estimate folders are named by the
    // slug.
    for (std::size_t later = 1; later < protocols.size(); ++later) {
      for (std::size_t k = 0; k < later; ++k) {
        if (protocols[k].slug() == protocols[later].slug()) {
          throw Error("--assess: two protocols named '" + protocols[later].name() +
                      "': their tables and estimates would be mixed; give each its own name");
        }
      }
    }
    if (protocols.empty()) throw Error("--assess: expected at least one protocol");
    const bool by_session = std::any_of(protocols.begin(), protocols.end(), [](const fitting::Protocol& p) {
      return p.kind == fitting::Protocol::Kind::kSessions;
    });
    if (by_session && options.sessions.empty()) throw UsageError("--assess sessions needs --sessions FILE");
    // Read by the sessions protocol alone: without it the file would be
    // checked against the logs and then ignored.
    if (!options.sessions.empty() && (options.no_assess || !by_session)) {
      throw UsageError("--sessions " + options.sessions.string() +
                       ": the sessions are used only by --assess sessions, which this command does not run" +
                       (options.no_assess ? " (--no-assess)" : "") + "; add the protocol or leave --sessions out");
    }
    // The arguments' files, found before the bank and any log are read: a
    // command with fewer than two development logs cannot cross-validate.
    const auto expand = [&](const std::vector<std::string>& arguments) {
      std::vector<LogSpec> specs;
      for (const std::string& argument : arguments) {
        for (LogSpec& spec : expand_log_argument(argument, unpaired_runs("skidimm tune", options.skip_unpaired))) {
          specs.push_back(std::move(spec));
        }
      }
      return specs;
    };
    std::vector<LogSpec> development_specs = expand(options.logs);
    std::vector<LogSpec> lockbox_specs = expand(options.lockbox);
    if (development_specs.size() < 2) {
      throw UsageError("tune needs at least two logs to cross-validate (--log): " +
                       std::string(development_specs.empty() ? "none" : "one") + " given");
    }
    const Bank start = Bank::load(options.bank, options.plugin_paths);
    {
      FatalSignalWording wording;
      wording.lost = "nothing is written (the tables and the bank come at the end)";
      wording.every_model_call_marked = false;  // the fits call the models themselves
      wording.several_threads = true;
      name_plugins_in_fatal_signals("skidimm tune", start, wording);
    }
    const BankConfig& config = start.config;
    for (const std::string& name : objectives) {
      if (!options.hold_unexcited || name == "none") continue;
      const std::string ignored = fitting::hold_unexcited_ignored(config, fitting::objective_from_string(name));
      if (!ignored.empty()) {
        throw UsageError("--hold-unexcited would do nothing in the " + name + " objective's fits: " + ignored +
                         "; leave it out");
      }
    }
    if (!options.range_for.empty() && options.no_assess && options.lockbox.empty()) {
      throw UsageError(
          "--range-for gives a range under the held-out tables (the nested assessment's, the "
          "lockbox's), and --no-assess without --lockbox prints none");
    }
    if (!options.range_for.empty()) {
      const std::vector<std::string> classes = config.class_names();
      std::string names;
      for (const std::string& c : classes) names += (names.empty() ? "" : ", ") + c;
      for (const auto& [name, count] : options.range_for) {
        if (std::find(classes.begin(), classes.end(), name) == classes.end()) {
          throw UsageError("--range-for: '" + name + "' is not a class of the bank " + options.bank.string() +
                           " (its classes: " + names + ")");
        }
      }
    }
    const SamplingConfig sampling = sampling_of(config, options.rate);
    // Where the results go, checked before the work: a mistyped directory
    // found at the end would lose every fit and search.
    if (!options.output_bank.empty()) check_output_path(options.output_bank, "--output-bank");
    if (!options.table.empty()) check_output_path(options.table, "--table");
    if (!options.estimates.empty()) {
      std::error_code ec;
      fs::create_directories(options.estimates, ec);
      if (ec || !fs::is_directory(options.estimates)) {
        throw Error("--estimates " + options.estimates.string() + ": cannot make this directory" +
                    (ec ? ": " + ec.message() : std::string(": a file of that name exists")));
      }
    }

    std::vector<fitting::TuningLog> logs;
    auto add_logs = [&](std::vector<LogSpec>& specs, bool lockbox) {
      for (LogSpec& spec : specs) {
        require_rereadable(spec, "tune reads each log more than once");
        fitting::TuningLog log;
        log.fit_data = fitting::mode_segments(config, spec, options.mode, sampling, lockbox ? "--lockbox" : "--log");
        if (spec.label.empty() && !options.mode.empty()) spec.label = options.mode;
        log.spec = spec;
        log.lockbox = lockbox;
        logs.push_back(std::move(log));
      }
    };
    add_logs(development_specs, false);
    const std::size_t development = logs.size();
    add_logs(lockbox_specs, true);
    std::vector<LogSpec> read;
    for (const fitting::TuningLog& log : logs) read.push_back(log.spec);
    refuse_output_over_logs(options.table, "--table", read);
    refuse_output_over_logs(options.output_bank, "--output-bank", read);
    // The tuned bank written over its start (--bank) is an update in place; the table would replace it.
    refuse_clashing_files({{"--table", options.table}, {"--output-bank", options.output_bank}},
                          {{"--sessions", options.sessions}});
    refuse_clashing_files({{"--table", options.table}}, {{"--bank", options.bank}});
    refuse_repeated_logs(logs);
    for (const fitting::TuningLog& log : logs) {
      for (const std::string& skipped : fitting::skipped_by_sampling(log.fit_data)) {
        std::cerr << "skidimm tune: " << printable(skipped) << "\n";
      }
      for (const std::string& short_log : fitting::logs_spanning_under_a_second(config, log.fit_data)) {
        std::cerr << "skidimm tune: warning: " << printable(short_log) << "\n";
      }
    }
    warn_of_classes_with_too_few_logs(
        config, logs, development, !options.no_assess,
        std::any_of(objectives.begin(), objectives.end(), [](const std::string& n) { return n != "none"; }));
    refuse_ranges_of_classes_not_held(config, logs, development, options.range_for);

    // Logs that each hold one class say nothing of how often a class
    // changes: a dwell time tuned on them only grows. Said before the work.
    // The default settings leave the dwell time to the bank there; one
    // asked for by name is searched, with a warning.
    std::vector<fitting::Knob> searched = options.knobs.empty() ? fitting::TuneOptions{}.knobs : knobs;
    const auto dwell = std::find(searched.begin(), searched.end(), fitting::Knob::kDwell);
    if (dwell != searched.end() && !options.splice) {
      bool any_change = false;
      for (std::size_t i = 0; i < development && !any_change; ++i) {
        const std::vector<bool> shown = classes_shown(config, logs[i]);
        any_change = std::count(shown.begin(), shown.end(), true) > 1;
      }
      if (!any_change && options.knobs.empty()) {
        searched.erase(dwell);
        std::cerr << "skidimm tune: the development logs each hold one class, so none shows a change: the dwell "
                     "time is left out of the default settings (a stickier filter is never wrong on such logs, and "
                     "tuned on them the dwell time only grows) and stays the bank's; --tune names the settings to "
                     "search (docs/tuning.md, \"Which settings to tune\")\n";
      } else if (!any_change) {
        std::cerr << "skidimm tune: warning: --tune dwell on logs that each hold one class: none shows a change, "
                     "so a stickier filter is never wrong on them and the dwell time grows until real changes are "
                     "followed late or never; state it in the bank and leave dwell out of --tune, or give logs with "
                     "changes (or --splice) (docs/tuning.md, \"Which settings to tune\")\n";
      }
    }

    if (!options.estimates.empty()) {
      // A folder of an earlier run's files would be scored with this run's
      // by `eval --estimates`, as if one run had written them all.
      std::vector<std::string> folders;
      if (!options.no_assess) {
        for (const fitting::Protocol& p : protocols) folders.push_back(p.slug());
      }
      if (!options.lockbox.empty()) folders.push_back("lockbox");
      for (const std::string& folder : folders) {
        const fs::path path = options.estimates / folder;
        std::error_code ec;
        if (!fs::is_directory(path, ec)) continue;
        const long files = std::distance(fs::directory_iterator(path, ec), fs::directory_iterator());
        if (files > 0) {
          throw Error("--estimates " + options.estimates.string() + ": " + path.string() + " already holds " +
                      std::to_string(files) + " file(s), from an earlier run: `eval --estimates " + path.string() +
                      "` would score them with this run's; give a new or empty directory, or remove " + path.string());
        }
      }
    }
    if (!options.sessions.empty()) {
      std::vector<std::string> first_files;
      for (const fitting::TuningLog& l : logs) first_files.push_back(l.spec.files.front().path.string());
      const std::vector<std::string> sessions =
          fitting::sessions_of(first_files, fitting::read_sessions_file(options.sessions), options.sessions);
      for (std::size_t i = 0; i < logs.size(); ++i) logs[i].session = sessions[i];
    }

    fitting::TuneOptions tune_options;
    tune_options.objectives = objectives;
    tune_options.knobs = searched;
    tune_options.folds = options.folds;
    tune_options.inner_folds = options.inner_folds;
    tune_options.assess = !options.no_assess;
    tune_options.protocols = protocols;
    tune_options.splice = options.splice;
    if (options.walk) tune_options.line_search = fitting::TuneOptions::LineSearch::kWalk;
    tune_options.threads = options.threads;
    tune_options.sampling = sampling;
    tune_options.assessment_estimates = options.estimates;
    std::mutex print;
    tune_options.progress_rates = !options.quiet && stderr_is_terminal();
    tune_options.progress = [&](const std::string& line) {
      if (options.quiet) return;
      std::lock_guard<std::mutex> lock(print);
      std::cerr << "skidimm tune: " << line << "\n";
    };

    std::map<std::string, fitting::BankFitter> fitters;
    std::string fit_work;  // what one fit on every development log faces, for the first line
    std::vector<const fitting::ModeLogs*> development_data;
    for (std::size_t i = 0; i < development; ++i) {
      for (const fitting::ModeLogs& d : logs[i].fit_data) development_data.push_back(&d);
    }
    for (const std::string& name : tune_options.objectives) {
      if (name == "none") {  // the bank's models as they are: tune the settings only
        fitters[name] = [](Bank*, const std::vector<fitting::ModeLogs>&) {};
        tune_options.separable.insert(name);
        tune_options.fit_nothing.insert(name);
        continue;
      }
      fitting::BankFitOptions fit_options;
      fit_options.objective = fitting::objective_from_string(name);
      fit_options.window.window = options.window;
      fit_options.window.hold_unexcited = options.hold_unexcited;
      fit_options.fit_measurement_noise = options.fit_r;
      fit_options.full_process_noise = options.full_q;
      fit_options.parameter_uncertainty = options.parameter_uncertainty;
      fit_options.uncertainty_per_log = options.uncertainty_per_log;
      fit_options.residual_correlation = options.residual_correlation;
      fit_options.pooled_process_noise = options.pooled_q;
      if (options.pooled_q) tune_options.pooled_process_noise.insert(name);
      fit_options.partial_pooling = options.partial_pooling;
      if (options.partial_pooling) tune_options.partial_pooling.insert(name);
      fit_options.window.standard_deviations = false;  // the folds' reports are not kept
      // Without a joint R each mode's fit depends on its own logs alone.
      if (!options.fit_r) tune_options.separable.insert(name);
      const fitting::FitWork work = fitting::fit_work(start, development_data, fit_options);
      fit_work += "; a fit on every log (" + name + "): " + std::to_string(work.modes) + " modes, " +
                  std::to_string(work.rows) + " rows, " + std::to_string(work.parameters) + " parameters";
      fitters[name] = [fit_options](Bank* bank, const std::vector<fitting::ModeLogs>& data) {
        fitting::fit_bank(bank, data, fit_options);
      };
    }
    tune_options.progress(
        std::to_string(development) + " logs" +
        (logs.size() > development
             ? " (and " + std::to_string(logs.size() - development) + " kept aside in the lockbox)"
             : std::string()) +
        ", " +
        // As many folds as logs or more is one log per fold (grouped_folds()).
        (options.folds > 0 && options.folds < static_cast<int>(development) ? std::to_string(options.folds) + "-fold"
                                                                            : "leave-one-log-out") +
        " cross-validation" +
        (tune_options.assess
             ? (options.inner_folds > 0 ? ", nested " + std::to_string(options.inner_folds) + "-fold assessment"
                                        : ", nested leave-one-log-out assessment")
             : "") +
        fit_work);
    const fitting::TuneResult result = fitting::tune(
        [&] { return Bank::load(options.bank, options.plugin_paths); }, logs, fitters, tune_options);

    std::ostream& out = std::cout;
    const std::string decision = evaluation::decision_settings_text(config.decision);
    out << "chosen: " << result.settings.describe(config) << "\n";
    print_scores(out,
                 "cross-validation with the chosen settings (optimistic: the settings were chosen on these scores)",
                 result.selection_scores, result.selection, decision, false, false);
    for (const fitting::Assessment& a : result.assessments) {
      print_scores(out,
                   "nested assessment, protocol " + a.protocol.name() + " (" + question_of(a.protocol, options.folds) +
                       "; each scored by models fitted and settings tuned without it)",
                   a.scores, a.summary, decision, true, true, options.range_for);
      print_switches(out, a);
      print_extrapolation(out, a.scores);
      out << "  " << evaluation::separability(a.scores, static_cast<int>(config.class_names().size())).describe() << "\n";
    }
    if (!result.lockbox.scores.empty()) {
      print_scores(out, "lockbox (kept aside, scored once by the bank tuned on the other logs)", result.lockbox.scores,
                   result.lockbox.summary, decision, false, true, options.range_for);
      print_switches(out, result.lockbox);
      print_extrapolation(out, result.lockbox.scores);
      out << "  " << evaluation::separability(result.lockbox.scores, static_cast<int>(config.class_names().size())).describe()
          << "\n";
    }
    for (const std::string& w : result.warnings) std::cerr << "skidimm tune: warning: " << w << "\n";
    warn_of_rejected_modes(start, result.start_scores,
                           "at the bank's starting settings (the search's first candidate, which the chosen settings "
                           "may have been chosen to avoid)");
    warn_of_rejected_modes(start, result.selection_scores, "with the chosen settings");
    // tune chooses by the probabilities, and a likelihood weight that keeps
    // them honest keeps them below a high decision.enter: the decision a
    // user's robot acts on can then be withheld most of the time, which the
    // accuracy of the most likely class does not show.
    if (const double unknown = result.selection.decision_unknown; unknown > 0.25) {
      std::cerr << "skidimm tune: warning: with the chosen settings the bank's decision (" << decision
                << ") is `unknown` " << number(100.0 * unknown, "%.0f") << "% of the held-out time: no class's "
                << "probability reaches decision.enter then. "
                << (config.decision.enter > 0.5
                        ? "A lower enter decides more often (the bundled BorealTC bank takes 0.5); `skidimm eval "
                          "--estimates DIR --decision-enter 0.5,0.7,0.9` on this tune's --estimates compares them\n"
                        : "These logs do not tell the classes apart with that confidence (the accuracy and mean log "
                          "p(truth) above say how well they are told apart)\n");
    }
    if (!options.table.empty()) write_table(options.table, result);

    if (!options.output_bank.empty()) {
      Bank tuned = Bank::load(options.bank, options.plugin_paths);
      fitting::apply(result.fitted, result.settings, &tuned);
      const BankConfig& c = tuned.config;
      std::string modes_block = "modes:\n";
      for (int j = 0; j < c.num_modes(); ++j) {
        const ModeConfig& mode = c.modes[static_cast<std::size_t>(j)];
        modes_block +=
            fitting::format_mode_entry(mode, *tuned.models[static_cast<std::size_t>(j)], {},
                                       tuned.model_sources[static_cast<std::size_t>(j)].parameter_keys, c.input_names);
      }
      std::vector<std::pair<std::string, std::string>> blocks{
          {"measurement", fitting::format_measurement_block(c)},
          {"transition", fitting::format_transition_block(c)},
          {"mode_probability_floor", fitting::format_floor_block(c)},
          {"likelihood_weight", fitting::format_likelihood_weight_block(c)},
          {"likelihood_dof", fitting::format_likelihood_dof_block(c)},
          {"extrapolation_scale", fitting::format_extrapolation_scale_block(c)},
          {"unknown", fitting::format_unknown_block(c)}};
      // A bank runs at the rate it was fitted and tuned at (--rate).
      if (sampling.rate != c.sampling.rate) blocks.emplace_back("sampling", fitting::format_sampling_block(sampling));
      bool bank_parameters = false;
      for (const auto& info : tuned.models[0]->parameter_info()) {
        bank_parameters = bank_parameters || info.scope == sdk::ParameterScope::kBank;
      }
      if (bank_parameters) {
        blocks.emplace_back(
            "shared", "shared: " +
                          fitting::format_parameters(*tuned.models[0], sdk::ParameterScope::kBank, c.shared,
                                                     tuned.model_sources[0].parameter_keys) +
                          "\n");
      }
      blocks.emplace_back("modes", modes_block);
      std::vector<std::string> header{"Written by skidimm tune; reproduce with:", "  " + options.command_line,
                                      "Chosen: " + result.settings.describe(config)};
      // A bank read alone must not read better than its scores are: each
      // line says how its log probability stands against a uniform guess.
      const int classes = static_cast<int>(config.class_names().size());
      const auto against_guess = [&](const std::vector<evaluation::LogScore>& scores) {
        const evaluation::Separability s = evaluation::separability(scores, classes);
        using Verdict = evaluation::Separability::Verdict;
        return "; each log's mean, averaged, " + number(s.mean) + " against a uniform guess over " +
               std::to_string(classes) + " classes, " + number(s.uniform) + ": " +
               (s.verdict == Verdict::kSeparated      ? "the classes are told apart"
                : s.verdict == Verdict::kUnclear      ? "unclear whether the classes are told apart"
                : s.verdict == Verdict::kNotSeparated ? "the classes are not told apart"
                                                      : "worse than the guess, sure of wrong classes");
      };
      // ... and where the same accuracy of as many other logs like them would fall.
      const auto range = [&](const std::vector<evaluation::LogScore>& scores) {
        const RangeOrProblem r = range_or_problem(scores, options.range_for);
        if (!r.problem.empty()) return "; no range for --range-for: " + r.problem;
        if (!r.range.known()) return std::string("; too few logs for a range of what others would score");
        const std::string other =
            options.range_for.empty()
                ? std::string("as many other logs like these")
                : std::to_string(r.range.other_logs()) + " other logs like these (" + r.range.other_counts() + ")";
        return "; " + other + ", 90% range " + number(r.range.low) + " to " + number(r.range.high);
      };
      for (const fitting::Assessment& a : result.assessments) {
        const bool logs = a.protocol.kind == fitting::Protocol::Kind::kLogs;
        header.push_back("Nested cross-validated accuracy " + (logs ? "" : "(" + a.protocol.name() + ") ") +
                         number(a.summary.accuracy) + ", mean log p(truth) " + number(a.summary.mean_log_probability) +
                         " (mean over classes of the mean over their logs" + range(a.scores) + against_guess(a.scores) +
                         ")");
      }
      if (!result.lockbox.scores.empty()) {
        header.push_back("Lockbox accuracy " + number(result.lockbox.summary.accuracy) + ", mean log p(truth) " +
                         number(result.lockbox.summary.mean_log_probability) + " (" +
                         range(result.lockbox.scores).substr(2) + against_guess(result.lockbox.scores) + ")");
      }
      fitting::write_bank_from_template(options.bank, options.output_bank, header, blocks);
      std::cerr << "skidimm tune: wrote " << options.output_bank.string() << "\n";
    }
    return kExitOk;
  });
  const std::string solver = fitting::take_solver_messages("");
  if (!solver.empty()) std::cerr << "skidimm tune: " << solver;
  return code;
}

}  // namespace cli
}  // namespace skidimm
