#include "log_arguments.h"

#include <algorithm>
#include <filesystem>
#include <map>
#include <system_error>

#include "skidimm/errors.h"
#include "skidimm/fitting/trajectory.h"

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

SamplingConfig sampling_of(const BankConfig& bank, double rate) {
  SamplingConfig sampling = bank.sampling;
  if (rate > 0.0) sampling.rate = rate;
  return sampling;
}

std::vector<fitting::ModeLogs> mode_segments(const BankConfig& config, const LogSpec& log,
                                             const std::string& default_mode, const SamplingConfig& sampling) {
  auto mode_of = [&config](const std::string& label, const std::string& where) {
    int j = config.mode_index(label);
    for (const ClassConfig& c : config.classes) {
      if (j < 0 && c.name == label && c.modes.size() == 1) j = c.modes[0];
    }
    if (j < 0) {
      throw Error(where + ": the bank has no mode '" + label + "'" +
                  (config.class_index(label) >= 0 ? " ('" + label + "' is a class of several modes; fitting needs a mode)"
                                                  : ""));
    }
    return j;
  };
  const std::string label = !log.label.empty() ? log.label : default_mode;
  const int labelled_mode = label.empty() ? -1 : mode_of(label, "--log '" + log.text + "'");
  if (label.empty() && config.columns.truth_mode.empty()) {
    throw Error("--log '" + log.text +
                "': say which mode it shows (MODE=FILE) or give --mode (or give the bank a truth column, "
                "columns.truth_mode)");
  }
  fitting::Trajectory trajectory = fitting::load_trajectory(config, log.files, sampling);
  if (trajectory.size() == 0) throw Error(log.text + ": the log gives no step");
  std::map<int, fitting::ModeLogs> by_mode;
  if (labelled_mode >= 0) {
    by_mode[labelled_mode].mode = labelled_mode;
    by_mode[labelled_mode].logs.push_back(std::move(trajectory));
  } else {
    const auto parts = fitting::split_by_truth(trajectory);
    if (parts.empty()) {
      throw Error("--log '" + log.text + "': say which mode it shows (MODE=FILE) or give --mode; its truth column '" +
                  config.columns.truth_mode + "' is absent or empty");
    }
    for (const auto& [part_label, part] : parts) {
      const int j = mode_of(part_label, "--log '" + log.text + "', truth column '" + config.columns.truth_mode + "'");
      by_mode[j].mode = j;
      by_mode[j].logs.push_back(part);
    }
  }
  std::vector<fitting::ModeLogs> out;
  for (auto& [j, d] : by_mode) out.push_back(std::move(d));
  return out;
}

}  // namespace cli
}  // namespace skidimm
