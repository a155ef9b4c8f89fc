// skidimm eval: identification metrics over one or many logs.
#include <algorithm>
#include <charconv>
#include <exception>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <limits>
#include <map>
#include <optional>
#include <sstream>

#include "commands.h"
#include "log_arguments.h"
#include "skidimm/errors.h"
#include "skidimm/evaluation/consistency.h"
#include "skidimm/evaluation/estimates_reader.h"
#include "skidimm/evaluation/log_evaluation.h"
#include "skidimm/evaluation/mode_metrics.h"
#include "skidimm/fitting/tuning.h"
#include "skidimm/imm.h"
#include "skidimm/log_io.h"
#include "skidimm/parallel.h"
#include "skidimm/sdk/angles.h"

namespace skidimm {
namespace cli {

namespace fs = std::filesystem;
using evaluation::LabelledStep;
using evaluation::ModeMetrics;
using evaluation::NisAccumulator;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

using evaluation::LogResult;

struct Group {
  std::string name;
  std::vector<LogResult> logs;
};

// A group's name: the label, else the directory's name or the (first) file's stem.
std::string group_name(const std::string& argument) {
  const LogSpec spec = parse_log_spec(argument);
  if (!spec.label.empty()) return spec.label;
  const fs::path p = spec.files.front().path.lexically_normal();
  std::error_code ec;
  if (fs::is_directory(p, ec)) return (p.filename().empty() ? p.parent_path() : p).filename().string();
  return p.stem().string();
}

struct Summary {
  ModeMetrics metrics;
  ModeMetrics decisions;
  std::map<std::string, NisAccumulator> nis;
  std::vector<double> state_rmse;
  std::vector<double> accuracies;
  std::vector<double> decision_accuracies;
  long decision_lost = 0;  // switches the most likely mode detected and the decision never did
};

// One log to evaluate, in the order one thread would: the group it belongs
// to, or the error expanding its argument gave (which one thread would have
// met after evaluating every log before it).
struct LogJob {
  std::size_t group = 0;
  LogSpec log;
  std::exception_ptr error;
};

std::vector<LogJob> log_jobs(const std::vector<std::string>& arguments, std::vector<Group>* groups) {
  std::vector<LogJob> jobs;
  for (const std::string& argument : arguments) {
    try {
      Group g{group_name(argument), {}};
      const std::vector<LogSpec> logs = expand_log_argument(argument);
      groups->push_back(std::move(g));
      for (const LogSpec& log : logs) jobs.push_back(LogJob{groups->size() - 1, log, nullptr});
    } catch (...) {
      jobs.push_back(LogJob{0, LogSpec{}, std::current_exception()});
      break;
    }
  }
  return jobs;
}

Summary summarize(const std::vector<const LogResult*>& logs, std::size_t states) {
  Summary s;
  std::vector<double> squared(states, 0.0);
  std::vector<long> counts(states, 0);
  for (const LogResult* log : logs) {
    s.metrics.merge(log->metrics);
    s.decisions.merge(log->decision_metrics);
    if (log->decision_metrics.duration > 0.0) s.decision_lost += switches_lost(log->metrics, log->decision_metrics);
    for (const auto& [mode, acc] : log->nis) s.nis[mode].merge(acc);
    for (std::size_t i = 0; i < log->squared_state_error.size() && i < states; ++i) {
      squared[i] += log->squared_state_error[i];
      counts[i] += log->state_error_count[i];
    }
    s.accuracies.push_back(log->metrics.accuracy());
    if (log->decision_metrics.duration > 0.0) s.decision_accuracies.push_back(log->decision_metrics.accuracy());
  }
  for (std::size_t i = 0; i < states; ++i)
    s.state_rmse.push_back(counts[i] > 0 ? std::sqrt(squared[i] / counts[i]) : kNaN);
  return s;
}

double mean(const std::vector<double>& v) {
  double sum = 0.0;
  for (double x : v) sum += x;
  return v.empty() ? kNaN : sum / v.size();
}
double standard_deviation(const std::vector<double>& v) {
  if (v.size() < 2) return 0.0;
  const double m = mean(v);
  double sum = 0.0;
  for (double x : v) sum += (x - m) * (x - m);
  return std::sqrt(sum / (v.size() - 1));
}

struct LatencyStats {
  long switches = 0, detected = 0;
  double median = kNaN, mean = kNaN, max = kNaN;
  double median_changes = kNaN;  // estimate changes per switch, the median over switches
};
// Over the switches' settled latencies, or their first-detection ones.
LatencyStats latency_stats(const ModeMetrics& m, bool first = false) {
  LatencyStats s;
  std::vector<double> values;
  for (const auto& d : m.switches) {
    ++s.switches;
    const double latency = first ? d.first_latency : d.latency;
    if (latency == latency) values.push_back(latency);
  }
  s.detected = static_cast<long>(values.size());
  std::vector<double> changes;
  for (const auto& d : m.switches) changes.push_back(static_cast<double>(d.changes));
  if (!changes.empty()) {
    std::sort(changes.begin(), changes.end());
    s.median_changes = changes.size() % 2 ? changes[changes.size() / 2]
                                          : 0.5 * (changes[changes.size() / 2 - 1] + changes[changes.size() / 2]);
  }
  if (!values.empty()) {
    std::sort(values.begin(), values.end());
    s.median = values.size() % 2 ? values[values.size() / 2]
                                 : 0.5 * (values[values.size() / 2 - 1] + values[values.size() / 2]);
    s.mean = mean(values);
    s.max = values.back();
  }
  return s;
}

std::string fmt(double v, const char* format = "%.3f") {
  if (!std::isfinite(v)) return "-";
  char b[64];
  std::snprintf(b, sizeof(b), format, v);
  return b;
}

std::string json_number(double v) { return std::isfinite(v) ? fmt(v, "%.6g") : "null"; }
std::string json_string(const std::string& s) {
  std::string out = "\"";
  for (char c : printable(s)) {
    if (c == '"' || c == '\\') out += '\\';
    if (static_cast<unsigned char>(c) < 0x20) {  // tab and newline: JSON escapes
      out += c == '\t' ? "\\t" : "\\n";
      continue;
    }
    out += c;
  }
  return out + "\"";
}

// Per class, the mean over its logs; then the mean over classes (a log's
// class is its main truth): the figure `skidimm tune` reports.
fitting::Summary class_summary(const std::vector<const LogResult*>& logs) {
  std::vector<fitting::LogScore> scores;
  for (const LogResult* log : logs) {
    fitting::LogScore s;
    s.log = log->name;
    s.truth = evaluation::main_truth(log->metrics);
    s.accuracy = log->metrics.accuracy();
    s.mean_log_probability = log->metrics.mean_truth_log_probability();
    s.seconds = log->metrics.duration;
    if (!s.truth.empty()) scores.push_back(s);
  }
  return fitting::summarize(scores);
}

// Decision settings as the eval table names them.
std::string decision_settings_text(const DecisionConfig& d) {
  return "enter " + CsvWriter::format(d.enter) + ", leave " + CsvWriter::format(d.leave) + ", hold " +
         CsvWriter::format(d.min_hold) + " s";
}

// `decision_made`: how the scored decision was made, e.g. "enter 0.9, leave
// 0.05, hold 1 s".
void print_table(std::ostream& out, const std::string& title, const Summary& s, const std::vector<std::string>& modes,
                 const std::vector<std::string>& states, bool list_switches, const std::vector<const LogResult*>& logs,
                 const std::string& decision_made) {
  const ModeMetrics& m = s.metrics;
  out << "\n" << title << ": " << s.accuracies.size() << " log(s), " << fmt(m.duration, "%.1f") << " s labelled\n";
  out << "  accuracy (time fraction)        " << fmt(m.accuracy());
  if (s.accuracies.size() > 1) {
    out << "   per log: mean " << fmt(mean(s.accuracies)) << " +- " << fmt(standard_deviation(s.accuracies)) << ", min "
        << fmt(*std::min_element(s.accuracies.begin(), s.accuracies.end()));
  }
  if (logs.size() > 1) {
    const fitting::Summary c = class_summary(logs);
    if (c.class_accuracy.size() > 1) {
      out << "\n  per class, mean over its logs:  ";
      for (const auto& [name, accuracy] : c.class_accuracy) out << " " << name << " " << fmt(accuracy);
      out << "; mean over classes " << fmt(c.accuracy);
    }
  }
  out << "\n  mean probability of the true mode " << fmt(m.mean_truth_probability()) << "\n";
  out << "  mean log probability of the truth " << fmt(m.mean_truth_log_probability()) << "\n";
  for (const auto& [mode, seconds] : m.truth_absent) {
    out << "  truth mode '" << mode << "' is not in the bank (" << fmt(seconds, "%.1f") << " s, always wrong)\n";
  }
  // Confusion: rows truth, columns estimate, fraction of the truth's time.
  std::size_t label = 8;
  for (const auto& [truth, row] : m.confusion) label = std::max(label, truth.size());
  auto cell = [](const std::string& text, std::size_t width) {
    return std::string(width > text.size() ? width - text.size() : 0, ' ') + text;
  };
  out << "  confusion (rows: truth, columns: estimate, fraction of the truth's time)\n  " << std::string(label, ' ');
  for (const auto& name : modes) out << " " << cell(name, std::max<std::size_t>(name.size(), 5));
  out << "\n";
  for (const auto& [truth, row] : m.confusion) {
    double total = 0.0;
    for (const auto& [estimate, seconds] : row) total += seconds;
    out << "  " << truth << std::string(label - truth.size(), ' ');
    for (const auto& name : modes) {
      const auto it = row.find(name);
      const double fraction = it == row.end() || total <= 0 ? 0.0 : it->second / total;
      out << " " << cell(fmt(fraction, "%.2f"), std::max<std::size_t>(name.size(), 5));
    }
    out << "\n";
  }
  const LatencyStats l = latency_stats(m);
  const LatencyStats f = latency_stats(m, true);
  if (l.switches > 0) {
    out << "  switches " << l.switches << "; new mode first most likely after: median " << fmt(f.median, "%.2f")
        << " s, max " << fmt(f.max, "%.2f") << " s, never " << (f.switches - f.detected) << "\n";
    out << "    ... and most likely from then on until the next switch: median " << fmt(l.median, "%.2f") << " s, max "
        << fmt(l.max, "%.2f") << " s, never " << (l.switches - l.detected) << "\n";
    if (list_switches) {
      for (const auto& d : m.switches) {
        out << "    " << fmt(d.time, "%8.2f") << " s  " << d.from << " -> " << d.to << ": first "
            << (d.first_latency == d.first_latency ? fmt(d.first_latency, "%.2f") + " s" : std::string("never"))
            << ", settled " << (d.detected() ? fmt(d.latency, "%.2f") + " s" : std::string("never")) << "\n";
      }
    }
  }
  if (s.decisions.duration > 0.0) {
    const ModeMetrics& d = s.decisions;
    const LatencyStats dl = latency_stats(d);
    const LatencyStats df = latency_stats(d, true);
    out << "  decision (" << decision_made << "): accuracy " << fmt(d.accuracy()) << ", unknown "
        << fmt(d.duration > 0 ? d.unknown_seconds / d.duration : 0.0) << " of the time\n";
    out << "    changes per minute: decision " << fmt(d.estimate_changes_per_minute(), "%.2f") << ", most likely "
        << fmt(m.estimate_changes_per_minute(), "%.2f") << ", truth " << fmt(m.truth_changes_per_minute(), "%.2f")
        << "\n";
    if (dl.switches > 0) {
      out << "    switches " << dl.switches << ": first decided after median " << fmt(df.median, "%.2f") << " s, never "
          << (df.switches - df.detected) << "; settled after median " << fmt(dl.median, "%.2f") << " s, max "
          << fmt(dl.max, "%.2f") << " s, never " << (dl.switches - dl.detected) << "; changes per switch: median "
          << fmt(dl.median_changes, "%.1f") << " (most likely " << fmt(latency_stats(m).median_changes, "%.1f")
          << "); lost against the most likely " << s.decision_lost << "\n";
    }
  }
  bool any_rmse = false;
  for (double r : s.state_rmse) any_rmse = any_rmse || std::isfinite(r);
  if (any_rmse) {
    out << "  state RMSE vs true_<state>:";
    for (std::size_t i = 0; i < states.size(); ++i) out << " " << states[i] << " " << fmt(s.state_rmse[i], "%.4f");
    out << "\n";
  }
  if (!s.nis.empty()) {
    out << "  consistency of the true mode's filter (mean NIS per measured component, 95% bounds):\n";
    for (const auto& [mode, acc] : s.nis) {
      out << "    " << mode << std::string(label + 2 - std::min(label + 2, mode.size()), ' ')
          << fmt(acc.mean_per_dof(), "%.2f") << " [" << fmt(acc.lower_bound(), "%.2f") << ", "
          << fmt(acc.upper_bound(), "%.2f") << "] " << acc.verdict() << "\n";
    }
  }
}

std::string json_summary(const Summary& s, const std::vector<std::string>& states,
                         const std::vector<const LogResult*>& logs) {
  const ModeMetrics& m = s.metrics;
  const fitting::Summary by_class = class_summary(logs);
  std::ostringstream o;
  o << "{\"logs\": " << s.accuracies.size() << ", \"duration\": " << json_number(m.duration)
    << ", \"accuracy\": " << json_number(m.accuracy())
    << ", \"accuracy_per_log\": {\"mean\": " << json_number(mean(s.accuracies))
    << ", \"std\": " << json_number(standard_deviation(s.accuracies)) << ", \"min\": "
    << json_number(s.accuracies.empty() ? kNaN : *std::min_element(s.accuracies.begin(), s.accuracies.end()))
    << "}, \"mean_over_classes\": {\"accuracy\": " << json_number(by_class.accuracy)
    << ", \"mean_truth_log_probability\": " << json_number(by_class.mean_log_probability) << ", \"per_class\": {";
  bool listed = false;
  for (const auto& [name, accuracy] : by_class.class_accuracy) {
    o << (listed ? ", " : "") << json_string(name) << ": {\"accuracy\": " << json_number(accuracy)
      << ", \"mean_truth_log_probability\": " << json_number(by_class.class_log_probability.at(name)) << "}";
    listed = true;
  }
  o << "}}, \"mean_truth_probability\": " << json_number(m.mean_truth_probability())
    << ", \"mean_truth_log_probability\": " << json_number(m.mean_truth_log_probability()) << ", \"confusion_seconds\": {";
  bool first = true;
  for (const auto& [truth, row] : m.confusion) {
    o << (first ? "" : ", ") << json_string(truth) << ": {";
    bool inner = true;
    for (const auto& [estimate, seconds] : row) {
      o << (inner ? "" : ", ") << json_string(estimate) << ": " << json_number(seconds);
      inner = false;
    }
    o << "}";
    first = false;
  }
  o << "}, \"truth_absent_seconds\": {";
  first = true;
  for (const auto& [mode, seconds] : m.truth_absent) {
    o << (first ? "" : ", ") << json_string(mode) << ": " << json_number(seconds);
    first = false;
  }
  const LatencyStats l = latency_stats(m);
  o << "}, \"switches\": [";
  first = true;
  for (const auto& d : m.switches) {
    o << (first ? "" : ", ") << "{\"time\": " << json_number(d.time) << ", \"from\": " << json_string(d.from)
      << ", \"to\": " << json_string(d.to) << ", \"latency\": " << json_number(d.latency)
      << ", \"first_latency\": " << json_number(d.first_latency) << "}";
    first = false;
  }
  const LatencyStats f = latency_stats(m, true);
  o << "], \"latency\": {\"switches\": " << l.switches << ", \"followed\": " << l.detected
    << ", \"median_changes_per_switch\": " << json_number(l.median_changes)
    << ", \"median\": " << json_number(l.median) << ", \"mean\": " << json_number(l.mean)
    << ", \"max\": " << json_number(l.max) << "}, \"first_latency\": {\"detected\": " << f.detected
    << ", \"median\": " << json_number(f.median) << ", \"mean\": " << json_number(f.mean)
    << ", \"max\": " << json_number(f.max) << "}, \"state_rmse\": {";
  for (std::size_t i = 0; i < states.size() && i < s.state_rmse.size(); ++i) {
    o << (i ? ", " : "") << json_string(states[i]) << ": " << json_number(s.state_rmse[i]);
  }
  const ModeMetrics& d = s.decisions;
  const LatencyStats dl = latency_stats(d);
  const LatencyStats df = latency_stats(d, true);
  o << "}, \"changes_per_minute\": {\"most_likely\": " << json_number(m.estimate_changes_per_minute())
    << ", \"decision\": " << json_number(d.estimate_changes_per_minute())
    << ", \"truth\": " << json_number(m.truth_changes_per_minute())
    << "}, \"decision\": {\"accuracy\": " << json_number(d.duration > 0 ? d.accuracy() : kNaN)
    << ", \"accuracy_per_log\": {\"mean\": " << json_number(mean(s.decision_accuracies))
    << ", \"std\": " << json_number(standard_deviation(s.decision_accuracies)) << ", \"min\": "
    << json_number(s.decision_accuracies.empty()
                       ? kNaN
                       : *std::min_element(s.decision_accuracies.begin(), s.decision_accuracies.end()))
    << "}, \"unknown_fraction\": " << json_number(d.duration > 0 ? d.unknown_seconds / d.duration : kNaN)
    << ", \"switches\": " << dl.switches << ", \"first_detected\": " << df.detected
    << ", \"first_median\": " << json_number(df.median) << ", \"settled\": " << dl.detected
    << ", \"settled_median\": " << json_number(dl.median) << ", \"settled_max\": " << json_number(dl.max)
    << ", \"median_changes_per_switch\": " << json_number(dl.median_changes) << ", \"lost\": " << s.decision_lost;
  o << "}, \"nis\": {";
  first = true;
  for (const auto& [mode, acc] : s.nis) {
    o << (first ? "" : ", ") << json_string(mode) << ": {\"mean_per_dof\": " << json_number(acc.mean_per_dof())
      << ", \"lower\": " << json_number(acc.lower_bound()) << ", \"upper\": " << json_number(acc.upper_bound())
      << ", \"verdict\": " << json_string(acc.verdict()) << "}";
    first = false;
  }
  o << "}}";
  return o.str();
}

}  // namespace

int eval(const EvalOptions& options) {
  return report_errors("skidimm eval", [&] {
    std::vector<Group> groups;
    std::vector<std::string> modes, states;
    std::string decision_made;
    if (!options.estimates.empty()) {
      std::optional<BankConfig> bank;
      if (!options.bank.empty()) bank = load_bank_config(options.bank);
      // Given on the command line, the decision is made again from each
      // file's probabilities (from the bank's settings, or the defaults).
      std::optional<DecisionConfig> decide;
      if (options.decision_enter >= 0.0 || options.decision_leave >= 0.0 || options.decision_hold >= 0.0) {
        decide = decision_settings_of(bank ? bank->decision : DecisionConfig{}, options.decision_enter,
                                      options.decision_leave, options.decision_hold);
      }
      decision_made =
          decide ? "made again: " + decision_settings_text(*decide) : std::string("the files' decision column");
      // Every file on its own thread (parallel.h): the results, and any
      // error, are those of one thread.
      const std::vector<LogJob> jobs = log_jobs(options.estimates, &groups);
      std::vector<LogResult> results(jobs.size());
      parallel_for(static_cast<int>(jobs.size()), worker_count(), [&](int i, int) {
        const LogJob& job = jobs[static_cast<std::size_t>(i)];
        if (job.error) std::rethrow_exception(job.error);
        results[static_cast<std::size_t>(i)] = evaluation::evaluate_estimates(
            job.log.files.front().path, bank ? &*bank : nullptr, decide ? &*decide : nullptr);
      });
      for (std::size_t i = 0; i < jobs.size(); ++i) groups[jobs[i].group].logs.push_back(std::move(results[i]));
      std::map<std::string, bool> seen;
      for (const Group& g : groups) {
        for (const LogResult& l : g.logs) {
          for (const auto& [truth, row] : l.metrics.confusion) {
            for (const auto& [estimate, seconds] : row) {
              if (!seen[estimate]) modes.push_back(estimate);
              seen[estimate] = true;
            }
          }
        }
      }
    } else {
      if (options.bank.empty()) throw Error("give --bank with --input, or --estimates");
      Bank bank = Bank::load(options.bank, options.plugin_paths);
      bank.config.decision = decision_settings_of(bank.config.decision, options.decision_enter, options.decision_leave,
                                                  options.decision_hold);
      decision_made = decision_settings_text(bank.config.decision);
      modes = bank.config.class_names();
      states = bank.config.state_names;
      const SamplingConfig sampling = sampling_of(bank.config, options.rate);
      EstimatorOptions estimator;
      if (options.smooth) estimator.kind = EstimatorOptions::Kind::kFixedInterval;
      if (options.lag >= 0.0) {
        if (options.smooth) throw Error("give --smooth or --lag, not both");
        estimator.kind = EstimatorOptions::Kind::kFixedLag;
        estimator.lag = options.lag;
      }
      // Every log on its own thread (parallel.h), each with its own filter
      // over the shared, read-only bank: the results, and any error, are
      // those of one thread (SKIDIMM_THREADS=1).
      const std::vector<LogJob> jobs = log_jobs(options.inputs, &groups);
      std::vector<LogResult> results(jobs.size());
      parallel_for(static_cast<int>(jobs.size()), worker_count(), [&](int i, int) {
        const LogJob& job = jobs[static_cast<std::size_t>(i)];
        if (job.error) std::rethrow_exception(job.error);
        results[static_cast<std::size_t>(i)] = evaluation::evaluate_log(bank, job.log, sampling, {}, estimator);
      });
      for (std::size_t i = 0; i < jobs.size(); ++i) groups[jobs[i].group].logs.push_back(std::move(results[i]));
    }
    if (groups.empty()) throw Error("nothing to evaluate: give --input (with --bank) or --estimates");

    std::vector<const LogResult*> all;
    for (const Group& g : groups) {
      for (const LogResult& l : g.logs) all.push_back(&l);
    }
    const Summary overall = summarize(all, states.size());
    if (options.json) {
      std::cout << "{\"overall\": " << json_summary(overall, states, all) << ", \"groups\": {";
      for (std::size_t i = 0; i < groups.size(); ++i) {
        std::vector<const LogResult*> logs;
        for (const LogResult& l : groups[i].logs) logs.push_back(&l);
        std::cout << (i ? ", " : "") << json_string(groups[i].name) << ": "
                  << json_summary(summarize(logs, states.size()), states, logs);
      }
      std::cout << "}, \"logs\": {";
      for (std::size_t i = 0; i < all.size(); ++i) {
        std::cout << (i ? ", " : "") << json_string(all[i]->name) << ": "
                  << json_summary(summarize({all[i]}, states.size()), states, {all[i]});
      }
      std::cout << "}}\n";
      return kExitOk;
    }
    if (groups.size() > 1) {
      for (const Group& g : groups) {
        std::vector<const LogResult*> logs;
        for (const LogResult& l : g.logs) logs.push_back(&l);
        print_table(std::cout, g.name, summarize(logs, states.size()), modes, states, logs.size() == 1, logs,
                    decision_made);
      }
    }
    print_table(std::cout, groups.size() > 1 ? "all" : groups[0].name, overall, modes, states, all.size() <= 3, all,
                decision_made);
    return kExitOk;
  });
}

}  // namespace cli
}  // namespace skidimm
