#include "skidimm/log_arguments.h"

#include <algorithm>
#include <filesystem>
#include <system_error>

#include "skidimm/errors.h"
#include "skidimm/log_io.h"
#include "skidimm/ros/bag_reader.h"

namespace skidimm {

namespace fs = std::filesystem;

std::vector<LogSpec> expand_log_argument(const std::string& argument) {
  const LogSpec spec = parse_log_spec(argument);
  std::error_code ec;
  // A ROS 2 bag's directory is one log.
  if (spec.files.size() == 1 && fs::is_directory(spec.files[0].path, ec) && !ros::BagReader::is_bag(spec.files[0].path)) {
    std::vector<fs::path> files;
    for (const auto& entry : fs::directory_iterator(spec.files[0].path)) {
      const fs::path& p = entry.path();
      if (p.extension() == ".csv" || p.extension() == ".mcap" || (entry.is_directory() && ros::BagReader::is_bag(p))) {
        files.push_back(p);
      }
    }
    std::sort(files.begin(), files.end());
    if (files.empty()) throw Error(argument + ": no logs in this directory (.csv or .mcap files, bag directories)");
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

std::string log_group_name(const std::string& argument) {
  const LogSpec spec = parse_log_spec(argument);
  if (!spec.label.empty()) return spec.label;
  const fs::path p = spec.files.front().path.lexically_normal();
  std::error_code ec;
  if (fs::is_directory(p, ec)) return (p.filename().empty() ? p.parent_path() : p).filename().string();
  return p.stem().string();
}

LogSpec join_log_arguments(const std::vector<std::string>& arguments) {
  LogSpec log;
  for (const std::string& argument : arguments) {
    const LogSpec part = parse_log_spec(argument);
    if (!part.label.empty()) {
      if (!log.label.empty() && log.label != part.label) {
        throw Error("two labels for one log ('" + log.label + "' and '" + part.label + "')");
      }
      log.label = part.label;
    }
    log.files.insert(log.files.end(), part.files.begin(), part.files.end());
    log.text += (log.text.empty() ? "" : "+") + argument;
  }
  if (log.files.empty()) throw Error("no input log given");
  return log;
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

}  // namespace skidimm
