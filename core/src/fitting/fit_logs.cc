#include "skidimm/fitting/fit_logs.h"

#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>
#include <map>
#include <memory>
#include <set>

#include "parallel.h"
#include "skidimm/config/expression.h"
#include "skidimm/errors.h"
#include "skidimm/fitting/trajectory.h"
#include "skidimm/io/csv.h"
#include "skidimm/io/log_arguments.h"

namespace skidimm {
namespace fitting {

namespace {

// Splits a segment labelled with a class of several modes among them: each
// step goes to the first mode whose fit_when holds for its inputs, else to
// the mode without one; steps no mode takes are left out.
void split_class(const BankConfig& config, const ClassConfig& c, const Trajectory& t,
                 std::map<int, ModeLogs>* by_mode) {
  struct Condition {
    int mode;
    std::unique_ptr<Expression> expression;
    std::vector<int> inputs;
    std::vector<double> values;
  };
  std::vector<Condition> conditions;
  int fallback = -1;
  for (int j : c.modes) {
    const ModeConfig& m = config.modes[static_cast<std::size_t>(j)];
    if (m.fit_when.empty()) {
      if (fallback < 0) fallback = j;
      continue;
    }
    Condition k{j, std::make_unique<Expression>(m.fit_when), {}, {}};
    for (const std::string& v : k.expression->variables()) {
      k.inputs.push_back(static_cast<int>(std::find(config.input_names.begin(), config.input_names.end(), v) -
                                          config.input_names.begin()));
    }
    k.values.resize(k.inputs.size());
    conditions.push_back(std::move(k));
  }
  std::vector<int> owner(static_cast<std::size_t>(t.size()), fallback);
  for (int k = 0; k < t.size(); ++k) {
    for (Condition& cond : conditions) {
      for (std::size_t i = 0; i < cond.inputs.size(); ++i) cond.values[i] = t.u(cond.inputs[i], k);
      const double holds = cond.expression->evaluate(cond.values.data());
      // NaN compares unequal to 0 and would read as true: an expression
      // undefined for these inputs is an error, not a condition that holds.
      if (std::isnan(holds)) {
        throw Error(t.source + ": t = " + CsvWriter::format(t.t[static_cast<std::size_t>(k)]) + " s: fit_when \"" +
                    config.modes[static_cast<std::size_t>(cond.mode)].fit_when + "\" of mode '" +
                    config.modes[static_cast<std::size_t>(cond.mode)].name +
                    "' is not a number for these inputs; a condition is true (not 0) or false (0)");
      }
      if (holds != 0.0) {
        owner[static_cast<std::size_t>(k)] = cond.mode;
        break;
      }
    }
  }
  Trajectory labelled = t;
  for (int k = 0; k < t.size(); ++k) {
    const int j = owner[static_cast<std::size_t>(k)];
    labelled.truth[static_cast<std::size_t>(k)] = j < 0 ? "" : config.modes[static_cast<std::size_t>(j)].name;
  }
  for (auto& [name, part] : split_by_truth(labelled)) {
    const int j = config.mode_index(name);
    (*by_mode)[j].mode = j;
    (*by_mode)[j].logs.push_back(std::move(part));
  }
}

}  // namespace

std::vector<ModeLogs> mode_segments(const BankConfig& config, const LogSpec& log, const std::string& default_mode,
                                    const SamplingConfig& sampling, const std::string& option) {
  // A label names a mode, or a class (whose modes share its steps by fit_when).
  auto check_label = [&config](const std::string& label, const std::string& where) {
    if (config.mode_index(label) < 0 && config.class_index(label) < 0) {
      throw Error(where + ": " + config.unknown_label(label));
    }
  };
  std::map<int, ModeLogs> by_mode;
  auto add = [&](const std::string& label, Trajectory part) {
    const int j = config.mode_index(label);
    if (j >= 0) {
      by_mode[j].mode = j;
      by_mode[j].logs.push_back(std::move(part));
      return;
    }
    for (const ClassConfig& c : config.classes) {
      if (c.name == label) split_class(config, c, part, &by_mode);
    }
  };
  const std::string label = !log.label.empty() ? log.label : default_mode;
  if (!label.empty()) check_label(label, option + " '" + log.text + "'");
  if (label.empty() && config.columns.truth_mode.empty()) {
    throw Error(option + " '" + log.text +
                "': say which mode it shows (MODE=FILE) or give --mode (or give the bank a truth column, "
                "columns.truth_mode)");
  }
  Trajectory trajectory = load_trajectory(config, log.files, sampling);
  if (trajectory.size() == 0) throw Error(option + " '" + log.text + "': the log gives no step");
  if (!label.empty()) {
    add(label, std::move(trajectory));
  } else {
    const auto parts = split_by_truth(trajectory);
    if (parts.empty()) {
      throw Error(option + " '" + log.text + "': say which mode it shows (MODE=FILE) or give --mode; its truth column '" +
                  config.columns.truth_mode + "' is absent or empty");
    }
    for (const auto& [part_label, part] : parts) {
      check_label(part_label, option + " '" + log.text + "', truth column '" + config.columns.truth_mode + "'");
      add(part_label, part);
    }
  }
  std::vector<ModeLogs> out;
  for (auto& [j, d] : by_mode) out.push_back(std::move(d));
  return out;
}

std::vector<std::string> skipped_by_sampling(const std::vector<ModeLogs>& data) {
  std::vector<std::string> messages;
  std::set<std::string> said;
  for (const ModeLogs& d : data) {
    for (const Trajectory& part : d.logs) {
      if (part.skipped.empty() || !said.insert(part.log).second) continue;
      for (const std::string& line : part.skipped) messages.push_back(part.log + ": " + line);
    }
  }
  return messages;
}

std::vector<std::string> logs_spanning_under_a_second(const BankConfig& config, const std::vector<ModeLogs>& data) {
  std::vector<std::string> messages;
  std::set<std::string> said;
  for (const ModeLogs& d : data) {
    for (const Trajectory& part : d.logs) {
      if (part.log_seconds >= 1.0 || !said.insert(part.log).second) continue;
      messages.push_back(part.log + ": " + std::to_string(part.log_steps) + " step(s) in " +
                         CsvWriter::format(part.log_seconds) + " s, under a second: are its time stamps in " +
                         config.columns.time_unit_name + " (columns.time_unit)?");
    }
  }
  return messages;
}

std::vector<std::string> classes_leaving_steps_unfitted(const BankConfig& config) {
  std::vector<std::string> messages;
  for (const ClassConfig& c : config.classes) {
    if (c.modes.size() < 2) continue;
    const bool every_mode_has_one = std::all_of(c.modes.begin(), c.modes.end(), [&config](int j) {
      return !config.modes[static_cast<std::size_t>(j)].fit_when.empty();
    });
    if (!every_mode_has_one) continue;
    messages.push_back("class '" + c.name +
                       "': every mode of it has a fit_when, so a step of the class none of them holds for is fitted "
                       "by no mode; leave one mode without fit_when to take the rest");
  }
  return messages;
}

std::vector<std::string> labels_overriding_truth(const BankConfig& config, const std::vector<ModeLogs>& data) {
  std::vector<std::string> messages;
  const std::vector<int> class_of = config.class_of_modes();
  for (const ModeLogs& d : data) {
    const std::string& fitted = config.modes[static_cast<std::size_t>(d.mode)].name;
    const int fitted_class = class_of[static_cast<std::size_t>(d.mode)];
    // The log's steps in this mode's segments, by log: a log split by its
    // truth column gives each mode only steps of that mode's label.
    std::map<std::string, std::set<std::string>> others;
    for (const Trajectory& part : d.logs) {
      const std::string* previous = nullptr;  // labels come in runs: each run looked up once
      for (const std::string& label : part.truth) {
        if (label.empty() || label == fitted || (previous != nullptr && label == *previous)) continue;
        previous = &label;
        // A label the bank does not know is a new terrain's, which a fit from
        // a starting mode (--mode asphalt --name ice) is for.
        const int label_class = config.class_index(label);
        if (label_class < 0 || label_class == fitted_class) continue;
        others[part.log].insert(label);
      }
    }
    for (const auto& [log, labels] : others) {
      std::string names;
      for (const std::string& label : labels) names += (names.empty() ? "" : ", ") + label;
      messages.push_back(log + ": fitted as mode '" + fitted +
                         "' by a label (--mode, or MODE=), though its truth column '" + config.columns.truth_mode +
                         "' names " + names +
                         " at some of its steps: leave the label out to fit each step as its truth says");
    }
  }
  return messages;
}

std::vector<ModeLogs> load_mode_logs(const BankConfig& config, const std::vector<std::string>& arguments,
                                     const std::string& default_mode, const SamplingConfig& sampling,
                                     const std::string& option, const LogArgumentOptions& expansion) {
  struct Job {
    LogSpec log;
    std::exception_ptr error;  // expanding its argument failed
  };
  std::vector<Job> jobs;
  for (const std::string& argument : arguments) {
    try {
      for (const LogSpec& log : expand_log_argument(argument, expansion)) jobs.push_back(Job{log, nullptr});
    } catch (...) {
      jobs.push_back(Job{LogSpec{}, std::current_exception()});
      break;
    }
  }
  std::vector<std::vector<ModeLogs>> segments(jobs.size());
  parallel_for(static_cast<int>(jobs.size()), worker_count(), [&](int i, int) {
    const Job& job = jobs[static_cast<std::size_t>(i)];
    if (job.error) std::rethrow_exception(job.error);
    segments[static_cast<std::size_t>(i)] = mode_segments(config, job.log, default_mode, sampling, option);
  });
  std::map<int, ModeLogs> by_mode;
  for (std::vector<ModeLogs>& log : segments) {
    for (ModeLogs& d : log) {
      by_mode[d.mode].mode = d.mode;
      for (auto& t : d.logs) by_mode[d.mode].logs.push_back(std::move(t));
    }
  }
  std::vector<ModeLogs> out;
  for (auto& [j, logs] : by_mode) out.push_back(std::move(logs));
  return out;
}

std::map<std::string, InputRange> fitted_input_ranges(const BankConfig& config, const std::vector<ModeLogs>& data,
                                                      int mode) {
  std::map<std::string, InputRange> ranges;
  for (int input = 0; input < config.input_dim(); ++input) {
    double lowest = std::numeric_limits<double>::infinity();
    double highest = -lowest;
    for (const ModeLogs& d : data) {
      if (d.mode != mode) continue;
      for (const Trajectory& t : d.logs) {
        for (Eigen::Index k = 0; k < t.u.cols(); ++k) {
          const double value = t.u(input, k);
          if (!std::isfinite(value)) continue;
          lowest = std::min(lowest, value);
          highest = std::max(highest, value);
        }
      }
    }
    if (lowest <= highest) ranges[config.input_names[static_cast<std::size_t>(input)]] = InputRange{lowest, highest};
  }
  return ranges;
}

}  // namespace fitting
}  // namespace skidimm
