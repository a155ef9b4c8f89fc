#include "skidimm/evaluation/evaluation_report.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <sstream>
#include <stdexcept>

#include "evaluation_summary.h"
#include "not_a_number.h"
#include "skidimm/evaluation/accuracy_range.h"
#include "skidimm/io/csv.h"
#include "skidimm/printable.h"

namespace skidimm {
namespace evaluation {

namespace {

using ::skidimm::internal::kNaN;

std::vector<const LogResult*> pointers(const LogGroup& group) {
  std::vector<const LogResult*> out;
  for (const LogResult& l : group.logs) out.push_back(&l);
  return out;
}

std::vector<const LogResult*> pointers(const std::vector<LogGroup>& groups) {
  std::vector<const LogResult*> out;
  for (const LogGroup& g : groups) {
    for (const LogResult& l : g.logs) out.push_back(&l);
  }
  return out;
}

// The entries of `by_name` in `order`, then any other by name: a confusion
// row's cells, the consistency of each true mode, in the bank's order.
template <typename Value>
std::vector<std::pair<std::string, Value>> in_order(const std::map<std::string, Value>& by_name,
                                                    const std::vector<std::string>& order) {
  std::vector<std::pair<std::string, Value>> out;
  for (const std::string& name : order) {
    const auto it = by_name.find(name);
    if (it != by_name.end()) out.emplace_back(*it);
  }
  for (const auto& entry : by_name) {
    if (std::find(order.begin(), order.end(), entry.first) == order.end()) out.emplace_back(entry);
  }
  return out;
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

// How well an estimate's probability says how often it is right: the time
// it was at least 0.9 and how often right there, the expected calibration
// error, and the tenths of probability that held any time ("0.6-0.7: 12%
// of the time, right 58%").
void print_calibration(std::ostream& out, const std::string& indent, const ModeMetrics& m) {
  double binned = 0.0;
  for (const CalibrationBin& b : m.calibration) binned += b.seconds;
  if (binned <= 0.0) return;
  out << indent << "at probability >= 0.9 (" << fmt(100.0 * m.confident_fraction(), "%.0f")
      << "% of the time): right " << fmt(100.0 * m.confident_accuracy(), "%.1f") << "%; expected calibration error "
      << fmt(m.expected_calibration_error()) << "\n";
  out << indent << "  by probability (share of the time, right):";
  for (int b = 0; b < kCalibrationBins; ++b) {
    const CalibrationBin& bin = m.calibration[static_cast<std::size_t>(b)];
    if (bin.seconds <= 0.0) continue;
    out << " " << fmt(0.1 * b, "%.1f") << "-" << fmt(0.1 * (b + 1), "%.1f") << " " << fmt(100.0 * bin.seconds / binned, "%.0f")
        << "%, " << fmt(100.0 * bin.accuracy(), "%.0f") << "%;";
  }
  out << "\n";
}

std::string json_calibration(const ModeMetrics& m) {
  std::ostringstream o;
  o << "{\"expected_calibration_error\": " << json_number(m.expected_calibration_error())
    << ", \"confident_fraction\": " << json_number(m.confident_fraction())
    << ", \"confident_accuracy\": " << json_number(m.confident_accuracy()) << ", \"bins\": [";
  for (int b = 0; b < kCalibrationBins; ++b) {
    const CalibrationBin& bin = m.calibration[static_cast<std::size_t>(b)];
    o << (b ? ", " : "") << "{\"lower\": " << json_number(0.1 * b) << ", \"upper\": " << json_number(0.1 * (b + 1))
      << ", \"seconds\": " << json_number(bin.seconds) << ", \"accuracy\": "
      << json_number(bin.seconds > 0.0 ? bin.accuracy() : kNaN) << ", \"mean_probability\": "
      << json_number(bin.seconds > 0.0 ? bin.mean_confidence() : kNaN) << "}";
  }
  o << "]}";
  return o.str();
}

// `decision_made`: how the scored decision was made, e.g. "enter 0.9, leave
// 0.05, hold 1 s".
// Whether the logs' scores tell `classes` classes apart at all (log_scores.h).
// Where the steps were outside the input ranges the classes were fitted on
// (input_envelope.h): shares of the steps, and the estimate's accuracy
// outside and inside the true class's ranges.
void print_extrapolation(std::ostream& out, const ExtrapolationCounts& e) {
  const auto share = [](long part, long whole) { return whole > 0 ? static_cast<double>(part) / whole : kNaN; };
  out << "  inputs outside the ranges the classes were fitted on: "
      << fmt(100.0 * share(e.outside_estimate, e.steps), "%.1f") << "% of the steps for the most likely class";
  if (e.labelled > 0) {
    out << "; " << fmt(100.0 * share(e.outside_truth, e.labelled), "%.1f")
        << "% for the true class, the most likely right on " << e.accuracy_by_truth_side();
  }
  out << "\n";
  if (!e.farthest.empty()) out << "    farthest: " << e.farthest << "\n";
}

std::string json_extrapolation(const ExtrapolationCounts& e) {
  const auto share = [](long part, long whole) { return whole > 0 ? static_cast<double>(part) / whole : kNaN; };
  std::ostringstream o;
  o << "{\"steps\": " << e.steps << ", \"outside_estimate\": " << json_number(share(e.outside_estimate, e.steps))
    << ", \"outside_truth\": " << json_number(share(e.outside_truth, e.labelled))
    << ", \"accuracy_outside_truth\": " << json_number(share(e.outside_truth_right, e.outside_truth))
    << ", \"accuracy_inside_truth\": " << json_number(share(e.inside_truth_right, e.labelled - e.outside_truth))
    << ", \"farthest\": " << json_string(e.farthest) << "}";
  return o.str();
}

// The state errors against true_<state> columns, where the log has them.
void print_state_rmse(std::ostream& out, const EvaluationSummary& s, const std::vector<std::string>& states) {
  bool any_rmse = false;
  for (double r : s.state_rmse) any_rmse = any_rmse || std::isfinite(r);
  if (!any_rmse) return;
  out << "  state RMSE vs true_<state>:";
  for (std::size_t i = 0; i < states.size(); ++i) out << " " << states[i] << " " << fmt(s.state_rmse[i], "%.4f");
  out << "\n";
}

Separability separability_of(const std::vector<const LogResult*>& logs, std::size_t classes) {
  std::vector<LogScore> scores;
  for (const LogResult* l : logs) {
    if (l->metrics.duration > 0.0) scores.push_back(score_of(*l));
  }
  return separability(scores, static_cast<int>(classes));
}

// The range of another set's mean over classes (accuracy_range.h), or why there
// is none for the set asked for: a report keeps what was scored either way.
struct RangeReport {
  AccuracyRange range;
  std::string problem;
};

// `another`: logs per class of the other set; empty, as many as `s` scored.
RangeReport range_of(const EvaluationSummary& s, const std::map<std::string, int>& another) {
  RangeReport report;
  try {
    report.range = accuracy_range(s.log_scores, another);
  } catch (const std::invalid_argument& e) {
    report.problem = e.what();
  }
  return report;
}

void print_table(std::ostream& out, const std::string& title, const EvaluationSummary& s,
                 const std::vector<std::string>& modes, const std::vector<std::string>& states, bool list_switches,
                 const std::string& decision_made, const Separability& separated,
                 const std::map<std::string, int>& another) {
  const ModeMetrics& m = s.metrics;
  out << "\n" << title << ": " << s.logs << " log(s), " << fmt(m.duration, "%.1f") << " s labelled";
  if (m.unlabelled > 0.0) out << ", " << fmt(m.unlabelled, "%.1f") << " s unlabelled (blank truth: not scored)";
  if (s.logs > s.accuracies.size())
    out << "; " << (s.logs - s.accuracies.size()) << " without labelled time, not scored";
  out << "\n";
  if (!(m.duration > 0.0)) {
    // Every figure below would read 0, which is no score at all.
    out << "  nothing to score: no labelled time (a truth column, or LABEL= before the log, gives the truth; "
           "a step stands for the time to the next, so a log needs two steps or more)\n";
    print_state_rmse(out, s, states);
    return;
  }
  out << "  accuracy (time fraction)        " << fmt(m.accuracy());
  if (s.accuracies.size() > 1) {
    out << "   per log: mean " << fmt(s.accuracy_per_log.mean) << " +- " << fmt(s.accuracy_per_log.standard_deviation)
        << ", min " << fmt(s.accuracy_per_log.min);
  }
  // Truth labels the bank lacks are listed, in the table and the confusion,
  // up to kMostAbsentTruthsListed: a truth column of the wrong values (the
  // time, a counter) would list a row per step.
  constexpr std::size_t kMostAbsentTruthsListed = 10;
  std::vector<std::string> truths = truths_in_order(m, modes);
  {
    std::vector<std::string> listed;
    std::size_t absent = 0;
    for (const std::string& truth : truths) {
      const bool in_bank = std::find(modes.begin(), modes.end(), truth) != modes.end();
      if (!in_bank && ++absent > kMostAbsentTruthsListed) continue;
      listed.push_back(truth);
    }
    truths = listed;
  }
  if (truths.size() > 1) {
    out << "\n  per class, over its own true time: ";
    for (const std::string& truth : truths) out << " " << truth << " " << fmt(m.truth_accuracy(truth));
    out << "; mean over classes " << fmt(s.mean_class_accuracy);
  }
  out << "\n  mean probability of the true mode " << fmt(m.mean_truth_probability()) << "\n";
  out << "  mean log probability of the truth " << fmt(m.mean_truth_log_probability())
      << (separated.logs > 1 ? " (over all labelled time)" : "") << "\n";
  out << "  Brier score " << fmt(m.mean_brier()) << " (0: sure and right; 2: sure and wrong)\n";
  if (modes.size() >= 2) out << "  " << separated.describe() << "\n";
  if (separated.logs > 1) {
    const RangeReport range = range_of(s, another);
    out << "  mean over classes of each class's logs' accuracies " << fmt(s.by_log_class.accuracy) << "; "
        << (range.problem.empty() ? range.range.describe() : "no range for another set: " + range.problem) << "\n";
  }
  if (s.extrapolation.steps > 0) print_extrapolation(out, s.extrapolation);
  out << "  calibration of the most likely mode's probability:\n";
  print_calibration(out, "    ", m);
  std::size_t absent_said = 0;
  for (const auto& absent : m.truth_absent) {
    if (absent_said++ == kMostAbsentTruthsListed) {
      out << "  ... and " << m.truth_absent.size() - kMostAbsentTruthsListed
          << " more truth labels not in the bank, left out of the tables here (--json lists every one): is the "
             "truth column the right one?\n";
      break;
    }
    // Named, not a structured binding: a lambda cannot capture one in C++17 (clang refuses it).
    const std::string& mode = absent.first;
    const double seconds = absent.second;
    out << "  truth mode '" << mode << "' is not in the bank (" << fmt(seconds, "%.1f") << " s, always wrong)";
    // A truth column written in another case (ASPHALT for asphalt) scores 0 for a name's case.
    const auto same_but_case = [&mode](const std::string& name) {
      return name.size() == mode.size() && std::equal(name.begin(), name.end(), mode.begin(), [](char a, char b) {
               return std::tolower(static_cast<unsigned char>(a)) == std::tolower(static_cast<unsigned char>(b));
             });
    };
    const auto like = std::find_if(modes.begin(), modes.end(), same_but_case);
    if (like != modes.end()) out << "; names are case-sensitive: '" << *like << "'?";
    out << "\n";
  }
  // Confusion: rows truth, columns estimate, fraction of the truth's time;
  // rows in the columns' order (the bank's), then truths the bank lacks.
  std::size_t label = 8;
  for (const std::string& truth : truths) label = std::max(label, truth.size());
  auto cell = [](const std::string& text, std::size_t width) {
    return std::string(width > text.size() ? width - text.size() : 0, ' ') + text;
  };
  out << "  confusion (rows: truth, columns: estimate, fraction of the truth's time)\n  " << std::string(label, ' ');
  for (const auto& name : modes) out << " " << cell(name, std::max<std::size_t>(name.size(), 5));
  out << "\n";
  for (const std::string& truth : truths) {
    const std::map<std::string, double>& row = m.confusion.at(truth);
    const double total = m.truth_seconds(truth);
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
      // A truth column that changes at every row (the wrong column, or
      // labels of one step each) would list a line per row.
      constexpr std::size_t kMostSwitchesListed = 50;
      for (std::size_t k = 0; k < m.switches.size() && k < kMostSwitchesListed; ++k) {
        const auto& d = m.switches[k];
        out << "    " << fmt(d.time, "%8.2f") << " s  " << d.from << " -> " << d.to << ": first "
            << (d.first_latency == d.first_latency ? fmt(d.first_latency, "%.2f") + " s" : std::string("never"))
            << ", settled " << (d.detected() ? fmt(d.latency, "%.2f") + " s" : std::string("never")) << "\n";
      }
      if (m.switches.size() > kMostSwitchesListed) {
        out << "    ... and " << m.switches.size() - kMostSwitchesListed << " more switches (--json lists every one)\n";
      }
    }
  }
  if (s.decisions.duration > 0.0) {
    const ModeMetrics& d = s.decisions;
    const LatencyStats dl = latency_stats(d);
    const LatencyStats df = latency_stats(d, true);
    // Estimates files without a decision column leave their logs out of it.
    const std::string of_logs = s.decision_accuracies.size() < s.accuracies.size()
                                    ? "; " + std::to_string(s.decision_accuracies.size()) + " of " +
                                          std::to_string(s.accuracies.size()) + " logs, the others have none"
                                    : std::string();
    out << "  decision (" << decision_made << of_logs << "): accuracy " << fmt(d.accuracy()) << ", unknown "
        << fmt(d.duration > 0 ? d.unknown_seconds / d.duration : 0.0) << " of the time\n";
    out << "    calibration of the decided class's probability (time decided):\n";
    print_calibration(out, "      ", d);
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
  print_state_rmse(out, s, states);
  if (!s.nis.empty()) {
    out << "  consistency of the true mode's filter (mean NIS per measured component, 95% bounds):\n";
    // Keyed by true mode, whose names (ICE_turning) may be longer than the classes' of the table above.
    std::size_t width = label;
    for (const auto& [mode, acc] : s.nis) width = std::max(width, mode.size());
    for (const auto& [mode, acc] : in_order(s.nis, modes)) {
      out << "    " << mode << std::string(width + 2 - std::min(width + 2, mode.size()), ' ')
          << fmt(acc.mean_per_dof(), "%.2f") << " [" << fmt(acc.lower_bound(), "%.2f") << ", "
          << fmt(acc.upper_bound(), "%.2f") << "] " << acc.verdict() << "\n";
    }
  }
}

std::string json_range(const RangeReport& r) {
  std::ostringstream o;
  if (!r.problem.empty()) {
    o << "{\"problem\": " << json_string(r.problem) << "}";
    return o.str();
  }
  const AccuracyRange& a = r.range;
  o << "{\"level\": " << json_number(a.level) << ", \"low\": " << json_number(a.low)
    << ", \"high\": " << json_number(a.high) << ", \"half_width\": " << json_number(a.half_width)
    << ", \"standard_error\": " << json_number(a.standard_error) << ", \"logs_per_class\": {";
  bool listed = false;
  for (const auto& [name, count] : a.logs_per_class) {
    o << (listed ? ", " : "") << json_string(name) << ": " << count;
    listed = true;
  }
  o << "}, \"degrees_of_freedom\": " << a.degrees_of_freedom << "}";
  return o.str();
}

// `another`: the other set's logs per class for the range of its mean over
// classes (range_of()); none (a log's own summary): the range is null.
std::string json_summary(const EvaluationSummary& s, const std::vector<std::string>& classes,
                         const std::vector<std::string>& states, const std::map<std::string, int>* another) {
  const ModeMetrics& m = s.metrics;
  const ScoreSummary& by_class = s.by_log_class;
  const std::vector<std::string> truths = truths_in_order(m, classes);
  std::ostringstream o;
  // Without labelled time there is nothing to score: null, not a 0 that reads as a score.
  const auto scored = [&](double value) { return json_number(m.duration > 0.0 ? value : kNaN); };
  o << "{\"logs\": " << s.logs << ", \"duration\": " << json_number(m.duration)
    << ", \"unlabelled_seconds\": " << json_number(m.unlabelled) << ", \"extrapolation\": "
    << (s.extrapolation.steps > 0 ? json_extrapolation(s.extrapolation) : std::string("null"))
    << ", \"accuracy\": " << scored(m.accuracy())
    << ", \"accuracy_per_log\": {\"mean\": " << json_number(s.accuracy_per_log.mean)
    << ", \"std\": " << json_number(s.accuracy_per_log.standard_deviation)
    << ", \"min\": " << json_number(s.accuracy_per_log.min)
    << "}, \"mean_over_classes\": {\"accuracy\": " << scored(by_class.accuracy)
    << ", \"mean_truth_log_probability\": " << scored(by_class.mean_log_probability)
    << ", \"range\": " << (another != nullptr ? json_range(range_of(s, *another)) : std::string("null"))
    << ", \"per_class\": {";
  bool listed = false;
  for (const auto& [name, accuracy] : by_class.class_accuracy) {
    o << (listed ? ", " : "") << json_string(name) << ": {\"accuracy\": " << json_number(accuracy)
      << ", \"mean_truth_log_probability\": " << json_number(by_class.class_log_probability.at(name)) << "}";
    listed = true;
  }
  o << "}}, \"per_class\": {";
  for (std::size_t i = 0; i < truths.size(); ++i) {
    o << (i ? ", " : "") << json_string(truths[i]) << ": {\"seconds\": " << json_number(m.truth_seconds(truths[i]))
      << ", \"accuracy\": " << json_number(m.truth_accuracy(truths[i]))
      << ", \"mean_truth_log_probability\": " << json_number(m.truth_mean_log_probability(truths[i])) << "}";
  }
  o << "}, \"mean_over_classes_by_time\": {\"accuracy\": " << json_number(s.mean_class_accuracy)
    << ", \"mean_truth_log_probability\": " << json_number(s.mean_class_log_probability)
    << "}, \"mean_truth_probability\": " << scored(m.mean_truth_probability())
    << ", \"mean_truth_log_probability\": " << scored(m.mean_truth_log_probability())
    << ", \"brier\": " << scored(m.mean_brier()) << ", \"calibration\": " << json_calibration(m)
    << ", \"confusion_seconds\": {";
  bool first = true;
  for (const std::string& truth : truths) {
    const std::map<std::string, double>& row = m.confusion.at(truth);
    o << (first ? "" : ", ") << json_string(truth) << ": {";
    bool inner = true;
    for (const auto& [estimate, seconds] : in_order(row, classes)) {
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
    << ", \"accuracy_per_log\": {\"mean\": " << json_number(s.decision_accuracy_per_log.mean)
    << ", \"std\": " << json_number(s.decision_accuracy_per_log.standard_deviation)
    << ", \"min\": " << json_number(s.decision_accuracy_per_log.min)
    << "}, \"unknown_fraction\": " << json_number(d.duration > 0 ? d.unknown_seconds / d.duration : kNaN)
    << ", \"switches\": " << dl.switches << ", \"first_detected\": " << df.detected
    << ", \"first_median\": " << json_number(df.median) << ", \"settled\": " << dl.detected
    << ", \"settled_median\": " << json_number(dl.median) << ", \"settled_max\": " << json_number(dl.max)
    << ", \"median_changes_per_switch\": " << json_number(dl.median_changes) << ", \"lost\": " << s.decision_lost
    << ", \"calibration\": " << json_calibration(d) << ", \"logs\": " << s.decision_accuracies.size();
  o << "}, \"nis\": {";
  first = true;
  for (const auto& [mode, acc] : in_order(s.nis, classes)) {
    o << (first ? "" : ", ") << json_string(mode) << ": {\"mean_per_dof\": " << json_number(acc.mean_per_dof())
      << ", \"lower\": " << json_number(acc.lower_bound()) << ", \"upper\": " << json_number(acc.upper_bound())
      << ", \"verdict\": " << json_string(acc.verdict()) << "}";
    first = false;
  }
  o << "}}";
  return o.str();
}

}  // namespace

std::string decision_settings_text(const DecisionConfig& d) {
  // stale_after < 0: the bank's default, said where the bank is run (docs/bank-format.md).
  const std::string stale = d.stale_after == 0.0  ? ", never stale"
                            : d.stale_after > 0.0 ? ", stale after " + CsvWriter::format(d.stale_after) + " s"
                                                  : "";
  return "enter " + CsvWriter::format(d.enter) + ", leave " + CsvWriter::format(d.leave) + ", hold " +
         CsvWriter::format(d.min_hold) + " s" + stale;
}

std::string report_json(const std::vector<LogGroup>& groups, const std::vector<std::string>& classes,
                        const std::vector<std::string>& states, const std::map<std::string, int>& another) {
  const std::vector<const LogResult*> all = pointers(groups);
  std::ostringstream out;
  const std::map<std::string, int> own_counts;  // a group's range: for as many of each class as it has
  out << "{\"overall\": " << json_summary(summarize(all, states.size()), classes, states, &another)
      << ", \"groups\": {";
  for (std::size_t i = 0; i < groups.size(); ++i) {
    out << (i ? ", " : "") << json_string(groups[i].name) << ": "
        << json_summary(summarize(pointers(groups[i]), states.size()), classes, states, &own_counts);
  }
  // Each log under the path it was given by (its files' joined by '+'), made
  // unique by a count when one is given twice: logs of several directories
  // often share their files' names.
  out << "}, \"logs\": {";
  std::map<std::string, int> uses;
  for (std::size_t i = 0; i < all.size(); ++i) {
    const int use = ++uses[all[i]->source];
    const std::string key = use == 1 ? all[i]->source : all[i]->source + " (" + std::to_string(use) + ")";
    out << (i ? ", " : "") << json_string(key) << ": "
        << json_summary(summarize({all[i]}, states.size()), classes, states, nullptr);
  }
  out << "}}\n";
  return out.str();
}

std::string logs_per_class_problem(const std::vector<LogGroup>& groups, const std::map<std::string, int>& another) {
  try {
    check_logs_per_class(summarize(pointers(groups), 0).log_scores, another);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

std::string report_tables(const std::vector<LogGroup>& groups, const std::vector<std::string>& classes,
                          const std::vector<std::string>& states, const std::string& decision_made,
                          const std::map<std::string, int>& another) {
  std::ostringstream out;
  if (groups.size() > 1) {
    for (const LogGroup& g : groups) {
      const std::vector<const LogResult*> logs = pointers(g);
      print_table(out, g.name, summarize(logs, states.size()), classes, states, logs.size() == 1, decision_made,
                  separability_of(logs, classes.size()), {});
    }
  }
  if (!groups.empty()) {
    const std::vector<const LogResult*> all = pointers(groups);
    print_table(out, groups.size() > 1 ? "all" : groups[0].name, summarize(all, states.size()), classes, states,
                all.size() <= 3, decision_made, separability_of(all, classes.size()), another);
  }
  return out.str();
}

std::string report_decision_settings(const std::vector<DecisionConfig>& settings,
                                     const std::vector<std::vector<LogGroup>>& scored,
                                     const std::vector<std::string>& classes, const std::vector<std::string>& states,
                                     bool json) {
  std::ostringstream out;
  if (json) {
    out << "{\"decision_settings\": [";
    for (std::size_t k = 0; k < settings.size(); ++k) {
      std::string report = report_json(scored[k], classes, states);
      if (!report.empty() && report.back() == '\n') report.pop_back();
      // Every digit, as the table gives them: settings that %.6g would print alike stay apart.
      out << (k ? ", " : "") << "{\"enter\": " << CsvWriter::format(settings[k].enter)
          << ", \"leave\": " << CsvWriter::format(settings[k].leave)
          << ", \"hold\": " << CsvWriter::format(settings[k].min_hold) << ", \"report\": " << report << "}";
    }
    out << "]}\n";
    return out.str();
  }
  // The most likely class is the files' whatever the decision: said once.
  std::vector<const LogResult*> logs;
  if (!scored.empty()) logs = pointers(scored.front());
  const EvaluationSummary first = summarize(logs, states.size());
  out << "decision settings compared on " << logs.size() << " log(s); the most likely class, the same for each: "
      << "accuracy " << fmt(first.metrics.duration > 0 ? first.metrics.accuracy() : kNaN) << "\n";
  out << "  enter    leave    hold (s)  accuracy  unknown  settled  settled median (s) changes per switch  lost\n";
  for (std::size_t k = 0; k < settings.size(); ++k) {
    const EvaluationSummary s = summarize(pointers(scored[k]), states.size());
    const ModeMetrics& d = s.decisions;
    const LatencyStats settled = latency_stats(d);
    char row[256];
    std::snprintf(row, sizeof(row), "  %-8s %-8s %-9s %-9s %-8s %-8s %-18s %-19s %ld\n",
                  CsvWriter::format(settings[k].enter).c_str(), CsvWriter::format(settings[k].leave).c_str(),
                  CsvWriter::format(settings[k].min_hold).c_str(), fmt(d.duration > 0 ? d.accuracy() : kNaN).c_str(),
                  fmt(d.duration > 0 ? d.unknown_seconds / d.duration : kNaN).c_str(),
                  (std::to_string(settled.detected) + "/" + std::to_string(settled.switches)).c_str(),
                  fmt(settled.median, "%.2f").c_str(), fmt(settled.median_changes, "%.1f").c_str(), s.decision_lost);
    out << row;
  }
  return out.str();
}

std::vector<std::string> classes_of(const std::vector<LogGroup>& groups) {
  std::vector<std::string> names;
  for (const LogGroup& g : groups) {
    for (const LogResult& l : g.logs) {
      for (const std::string& c : l.classes) {
        if (std::find(names.begin(), names.end(), c) == names.end()) names.push_back(c);
      }
    }
  }
  return names;
}

}  // namespace evaluation
}  // namespace skidimm
