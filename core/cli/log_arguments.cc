#include "log_arguments.h"

#include <algorithm>
#include <filesystem>
#include <map>
#include <memory>
#include <system_error>

#include "skidimm/errors.h"
#include "skidimm/expression.h"
#include "skidimm/fitting/trajectory.h"
#include "skidimm/log_io.h"

namespace skidimm {
namespace cli {

namespace fs = std::filesystem;

std::vector<LogSpec> expand_log_argument(const std::string& argument) {
  const LogSpec spec = parse_log_spec(argument);
  std::error_code ec;
  if (spec.files.size() == 1 && fs::is_directory(spec.files[0].path, ec)) {
    std::vector<fs::path> files;
    for (const auto& entry : fs::directory_iterator(spec.files[0].path)) {
      if (entry.path().extension() == ".csv") files.push_back(entry.path());
    }
    std::sort(files.begin(), files.end());
    if (files.empty()) throw Error(argument + ": no .csv logs in this directory");
    std::vector<LogSpec> logs;
    for (const fs::path& f : files) {
      LogSpec one = spec;
      one.files = {LogFile(f, spec.files[0].time_offset)};
      one.text = (spec.label.empty() ? "" : spec.label + "=") + f.string();
      logs.push_back(one);
    }
    return logs;
  }
  const std::string first = spec.files[0].path.filename().string();
  const auto star = first.find('*');
  if (star == std::string::npos) return {spec};
  if (first.find('*', star + 1) != std::string::npos) throw Error(argument + ": at most one '*' per file name");
  const std::string prefix = first.substr(0, star), suffix = first.substr(star + 1);
  fs::path directory = spec.files[0].path.parent_path();
  if (directory.empty()) directory = ".";
  if (!fs::is_directory(directory, ec)) throw Error(argument + ": no directory " + directory.string());
  std::vector<std::string> matches;
  for (const auto& entry : fs::directory_iterator(directory)) {
    const std::string name = entry.path().filename().string();
    if (name.size() >= prefix.size() + suffix.size() && name.compare(0, prefix.size(), prefix) == 0 &&
        name.compare(name.size() - suffix.size(), suffix.size(), suffix) == 0) {
      matches.push_back(name.substr(prefix.size(), name.size() - prefix.size() - suffix.size()));
    }
  }
  std::sort(matches.begin(), matches.end());
  if (matches.empty()) throw Error(argument + ": no file matches " + spec.files[0].path.string());
  std::vector<LogSpec> logs;
  for (const std::string& match : matches) {
    LogSpec one = spec;
    one.text = spec.label.empty() ? "" : spec.label + "=";
    for (std::size_t i = 0; i < one.files.size(); ++i) {
      std::string path = one.files[i].path.string();
      const auto at = path.find('*');
      if (at != std::string::npos) path.replace(at, 1, match);
      if (!fs::exists(path, ec)) {
        throw Error(argument + ": " + path + " (paired with " + (directory / (prefix + match + suffix)).string() +
                    ") does not exist");
      }
      one.files[i].path = path;
      one.text += (i ? "+" : "") + path;
    }
    logs.push_back(one);
  }
  return logs;
}

void require_rereadable(const LogSpec& log, const std::string& who) {
  for (const LogFile& file : log.files) {
    if (!is_rereadable(file.path)) {
      throw Error(log.text + ": " + (is_standard_input(file.path) ? std::string("standard input") : file.path.string()) +
                  " can be read only once (standard input, a pipe or a FIFO), but " + who +
                  ": save it to a file first");
    }
  }
}

void check_decision_settings(const DecisionConfig& d) {
  if (!(d.enter > 0.0 && d.enter <= 1.0 && d.leave >= 0.0 && d.leave < d.enter)) {
    throw Error("decision thresholds: need 0 <= leave < enter <= 1, got enter " + CsvWriter::format(d.enter) +
                ", leave " + CsvWriter::format(d.leave));
  }
  if (!(d.min_hold >= 0.0)) throw Error("decision hold: need min_hold >= 0 s, got " + CsvWriter::format(d.min_hold));
}

DecisionConfig decision_settings_of(const DecisionConfig& bank, double enter, double leave, double hold) {
  DecisionConfig d = bank;
  if (enter >= 0.0) d.enter = enter;
  if (leave >= 0.0) d.leave = leave;
  if (hold >= 0.0) d.min_hold = hold;
  check_decision_settings(d);
  return d;
}

SamplingConfig sampling_of(const BankConfig& bank, double rate) {
  SamplingConfig sampling = bank.sampling;
  if (rate > 0.0) sampling.rate = rate;
  return sampling;
}

namespace {

// Splits a segment labelled with a class of several modes among them: each
// step goes to the first mode whose fit_when holds for its inputs, else to
// the mode without one; steps no mode takes are left out.
void split_class(const BankConfig& config, const ClassConfig& c, const fitting::Trajectory& t,
                 std::map<int, fitting::ModeLogs>* by_mode) {
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
      if (cond.expression->evaluate(cond.values.data()) != 0.0) {
        owner[static_cast<std::size_t>(k)] = cond.mode;
        break;
      }
    }
  }
  fitting::Trajectory labelled = t;
  for (int k = 0; k < t.size(); ++k) {
    const int j = owner[static_cast<std::size_t>(k)];
    labelled.truth[static_cast<std::size_t>(k)] = j < 0 ? "" : config.modes[static_cast<std::size_t>(j)].name;
  }
  for (auto& [name, part] : fitting::split_by_truth(labelled)) {
    const int j = config.mode_index(name);
    (*by_mode)[j].mode = j;
    (*by_mode)[j].logs.push_back(std::move(part));
  }
}

}  // namespace

std::vector<fitting::ModeLogs> mode_segments(const BankConfig& config, const LogSpec& log,
                                             const std::string& default_mode, const SamplingConfig& sampling,
                                             const std::string& option) {
  // A label names a mode, or a class (whose modes share its steps by fit_when).
  auto check_label = [&config](const std::string& label, const std::string& where) {
    if (config.mode_index(label) < 0 && config.class_index(label) < 0) {
      throw Error(where + ": the bank has no mode or class '" + label + "'");
    }
  };
  std::map<int, fitting::ModeLogs> by_mode;
  auto add = [&](const std::string& label, fitting::Trajectory part) {
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
  fitting::Trajectory trajectory = fitting::load_trajectory(config, log.files, sampling);
  if (trajectory.size() == 0) throw Error(option + " '" + log.text + "': the log gives no step");
  if (!label.empty()) {
    add(label, std::move(trajectory));
  } else {
    const auto parts = fitting::split_by_truth(trajectory);
    if (parts.empty()) {
      throw Error(option + " '" + log.text + "': say which mode it shows (MODE=FILE) or give --mode; its truth column '" +
                  config.columns.truth_mode + "' is absent or empty");
    }
    for (const auto& [part_label, part] : parts) {
      check_label(part_label, option + " '" + log.text + "', truth column '" + config.columns.truth_mode + "'");
      add(part_label, part);
    }
  }
  std::vector<fitting::ModeLogs> out;
  for (auto& [j, d] : by_mode) out.push_back(std::move(d));
  return out;
}

}  // namespace cli
}  // namespace skidimm
