#include "skidimm/io/log_arguments.h"

#include <algorithm>
#include <filesystem>
#include <map>
#include <set>
#include <system_error>

#include "skidimm/errors.h"
#include "skidimm/io/csv.h"
#include "skidimm/io/ros/bag_reader.h"

namespace skidimm {

namespace fs = std::filesystem;

namespace {

// One file of a pattern argument, as given: its path around the '*' of its
// name (no '*': the same file for every run).
struct FilePattern {
  std::string before, after;  // the path as given, before and after the '*'
  bool has_star = false;
  std::set<std::string> keys;  // what the '*' stands for in the files that exist
};

FilePattern file_pattern(const std::string& argument, const fs::path& path) {
  FilePattern p;
  const std::string text = path.string();
  const std::string name = path.filename().string();
  const auto star = name.find('*');
  if (star == std::string::npos) {
    if (text.find('*') != std::string::npos) throw Error(argument + ": a '*' may stand only in a file's name");
    p.before = text;
    return p;
  }
  if (name.find('*', star + 1) != std::string::npos) throw Error(argument + ": at most one '*' per file name");
  const auto at = text.size() - name.size() + star;
  if (text.find('*') != at) throw Error(argument + ": a '*' may stand only in a file's name");
  p.has_star = true;
  p.before = text.substr(0, at);
  p.after = text.substr(at + 1);
  fs::path directory = path.parent_path();
  if (directory.empty()) directory = ".";
  std::error_code ec;
  if (!fs::is_directory(directory, ec)) throw Error(argument + ": no directory " + directory.string());
  const std::string prefix = name.substr(0, star), suffix = name.substr(star + 1);
  for (const auto& entry : fs::directory_iterator(directory)) {
    const std::string found = entry.path().filename().string();
    if (found.size() >= prefix.size() + suffix.size() && found.compare(0, prefix.size(), prefix) == 0 &&
        found.compare(found.size() - suffix.size(), suffix.size(), suffix) == 0) {
      p.keys.insert(found.substr(prefix.size(), found.size() - prefix.size() - suffix.size()));
    }
  }
  return p;
}

std::string path_of(const FilePattern& p, const std::string& key) {
  return p.has_star ? p.before + key + p.after : p.before;
}

// At most this many unpaired runs are named in an error, the rest counted.
constexpr std::size_t kUnpairedNamed = 10;

// A directory or a pattern expands to files that can be read whole (and
// again, where a command reads a log more than once): a pipe or a device
// among them would wait for a writer that never comes, or give other bytes
// each time. Given alone, a pipe is read as a log (`--input -`, a FIFO).
void refuse_unless_a_file(const std::string& argument, const fs::path& path) {
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (ec || fs::is_regular_file(status) || fs::is_directory(status)) return;  // a missing file is said when read
  throw Error(argument + ": " + path.string() + " is not a regular file (" +
              (fs::is_fifo(status)     ? "a pipe"
               : fs::is_socket(status) ? "a socket"
                                       : "a device or special file") +
              "), and a directory or a pattern names logs to read whole; give it alone as a log, or move it out");
}

}  // namespace

std::vector<LogSpec> expand_log_argument(const std::string& argument, const LogArgumentOptions& options) {
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
    if (files.empty()) {
      const std::string unfinished = ros::BagReader::unfinished_recording(spec.files[0].path);
      throw Error(argument + ": no logs in this directory (.csv or .mcap files, bag directories)" +
                  (unfinished.empty() ? std::string() : "; " + unfinished));
    }
    for (const fs::path& f : files) refuse_unless_a_file(argument, f);
    std::vector<LogSpec> logs;
    for (const fs::path& f : files) {
      LogSpec one = spec;
      one.files = {LogFile(f, spec.files[0].time_offset)};
      one.text = (spec.label.empty() ? "" : spec.label + "=") + f.string();
      logs.push_back(one);
    }
    return logs;
  }
  if (spec.files[0].path.filename().string().find('*') == std::string::npos) return {spec};

  // Every file's pattern lists its runs; a log is a run every pattern has.
  std::vector<FilePattern> patterns;
  for (const LogFile& file : spec.files) patterns.push_back(file_pattern(argument, file.path));
  for (const FilePattern& p : patterns) {
    if (!p.has_star && !fs::exists(p.before, ec)) throw Error(argument + ": " + p.before + " does not exist");
  }
  std::set<std::string> runs;
  for (const FilePattern& p : patterns) runs.insert(p.keys.begin(), p.keys.end());
  if (runs.empty()) throw Error(argument + ": no file matches " + spec.files[0].path.string());
  std::vector<std::string> paired, unpaired;
  for (const std::string& run : runs) {
    std::string found, missing;
    for (const FilePattern& p : patterns) {
      if (!p.has_star) continue;
      std::string& list = p.keys.count(run) ? found : missing;
      list += (list.empty() ? "" : ", ") + path_of(p, run);
    }
    if (missing.empty()) {
      paired.push_back(run);
    } else {
      unpaired.push_back(found + " has no partner " + missing);
    }
  }
  if (!unpaired.empty() && !options.skip_unpaired) {
    std::string list;
    for (std::size_t i = 0; i < unpaired.size() && i < kUnpairedNamed; ++i) list += "\n  " + unpaired[i];
    if (unpaired.size() > kUnpairedNamed) {
      list += "\n  and " + std::to_string(unpaired.size() - kUnpairedNamed) + " more";
    }
    throw Error(argument + ": " + std::to_string(unpaired.size()) + " of " + std::to_string(runs.size()) +
                " run(s) are not in every file of the pattern:" + list +
                "\nLeave them out with --skip-unpaired (Python: skip_unpaired=True), or add the missing files");
  }
  for (const std::string& message : unpaired) {
    if (options.skipped) options.skipped(argument + ": left out: " + message);
  }
  if (paired.empty()) throw Error(argument + ": no run is in every file of the pattern");
  std::vector<LogSpec> logs;
  for (const std::string& run : paired) {
    LogSpec one = spec;
    one.text = spec.label.empty() ? "" : spec.label + "=";
    for (std::size_t i = 0; i < one.files.size(); ++i) {
      one.files[i].path = path_of(patterns[i], run);
      refuse_unless_a_file(argument, one.files[i].path);
      one.text += (i ? "+" : "") + one.files[i].path.string();
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
  // 'ests/*.csv' matches a folder's runs: named '*', its group would say
  // nothing; named 'ests', it would join a group labelled so.
  if (p.stem() == "*" && !p.parent_path().filename().empty() && p.parent_path().filename() != "..") {
    return p.parent_path().filename().string() + "/*";
  }
  return p.stem().string();
}

std::vector<std::string> distinct_group_names(const std::vector<LogSpec>& given, std::vector<std::string> names) {
  std::map<std::string, std::vector<std::size_t>> unlabelled;
  for (std::size_t g = 0; g < given.size(); ++g) {
    if (given[g].label.empty()) unlabelled[names[g]].push_back(g);
  }
  for (const auto& [name, sharing] : unlabelled) {
    if (sharing.size() < 2) continue;
    std::vector<const LogSpec*> specs;
    for (std::size_t g : sharing) specs.push_back(&given[g]);
    const std::vector<std::string> apart = distinct_names(specs);
    for (std::size_t k = 0; k < sharing.size(); ++k) names[sharing[k]] = apart[k];
  }
  return names;
}

std::vector<std::string> log_group_names(const std::vector<std::string>& arguments) {
  std::vector<LogSpec> given;
  std::vector<std::string> names;
  for (const std::string& argument : arguments) {
    given.push_back(parse_log_spec(argument));
    names.push_back(log_group_name(argument));
  }
  return distinct_group_names(given, std::move(names));
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
    // A missing file is not a pipe: say what it is, as reading it would.
    std::error_code ec;
    if (!is_standard_input(file.path) && !std::filesystem::exists(file.path, ec)) {
      throw LogError(file.path.string(), 0, "no such log file");
    }
    if (!is_rereadable(file.path)) {
      throw Error(log.text + ": " + (is_standard_input(file.path) ? std::string("standard input") : file.path.string()) +
                  " can be read only once (standard input, a pipe or a FIFO), but " + who +
                  ": save it to a file first");
    }
  }
}

}  // namespace skidimm
