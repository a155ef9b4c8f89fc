#include "skidimm/io/log_spec.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <iterator>
#include <map>
#include <system_error>

#include "skidimm/errors.h"

namespace skidimm {

namespace fs = std::filesystem;

std::string LogSpec::name() const {
  std::string out;
  for (const LogFile& f : files) out += (out.empty() ? "" : "+") + f.path.filename().string();
  return out;
}

namespace {

// The files' paths joined with '+', each from its last `depth` parts.
std::string name_from_depth(const LogSpec& log, std::size_t depth) {
  std::string out;
  for (const LogFile& f : log.files) {
    const std::vector<fs::path> parts(f.path.begin(), f.path.end());
    fs::path tail;
    for (std::size_t k = parts.size() > depth ? parts.size() - depth : 0; k < parts.size(); ++k) tail /= parts[k];
    out += (out.empty() ? "" : "+") + tail.string();
  }
  return out;
}

std::size_t deepest_path(const LogSpec& log) {
  std::size_t deepest = 0;
  for (const LogFile& f : log.files) {
    deepest = std::max(deepest, static_cast<std::size_t>(std::distance(f.path.begin(), f.path.end())));
  }
  return deepest;
}

}  // namespace

std::vector<std::string> distinct_names(const std::vector<const LogSpec*>& logs) {
  std::vector<std::string> names;
  std::map<std::string, std::vector<std::size_t>> sharing;  // name() -> the logs that have it
  for (std::size_t i = 0; i < logs.size(); ++i) {
    names.push_back(logs[i]->name());
    sharing[names.back()].push_back(i);
  }
  for (const auto& [name, group] : sharing) {
    if (group.size() < 2) continue;
    // Deeper a folder at a time, every log of the group's tail counted once
    // a depth: a log is named at the first depth where its tail is its own,
    // or by its whole path.
    std::vector<std::size_t> unnamed = group;
    for (std::size_t depth = 2; !unnamed.empty(); ++depth) {
      std::map<std::string, int> count;
      for (std::size_t i : group) ++count[name_from_depth(*logs[i], depth)];
      std::vector<std::size_t> still;
      for (std::size_t i : unnamed) {
        std::string tail = name_from_depth(*logs[i], depth);
        if (count[tail] == 1 || depth >= deepest_path(*logs[i])) {
          names[i] = std::move(tail);
        } else {
          still.push_back(i);
        }
      }
      unnamed = std::move(still);
    }
  }
  return names;
}

std::string joined_paths(const std::vector<LogFile>& files) {
  std::string out;
  for (const LogFile& f : files) out += (out.empty() ? "" : "+") + f.path.string();
  return out;
}

LogSpec parse_log_spec(const std::string& text) {
  LogSpec spec;
  spec.text = text;
  std::string files = text;
  std::error_code ec;
  // "MODE=a.csv": a label, unless the whole text (or its first part) is a file with '=' in its name.
  const auto equals = text.find('=');
  const std::string first = text.substr(0, text.find('+'));
  if (equals != std::string::npos && !fs::exists(first, ec)) {
    spec.label = text.substr(0, equals);
    files = text.substr(equals + 1);
    if (spec.label.empty()) throw Error("log '" + text + "': empty label before '='");
  }
  std::size_t begin = 0;
  while (begin <= files.size()) {
    // '+' joins files, except right after '@', where it is an offset's sign.
    std::size_t end = files.find('+', begin);
    while (end != std::string::npos && end > 0 && files[end - 1] == '@') end = files.find('+', end + 1);
    if (end == std::string::npos) end = files.size();
    std::string part = files.substr(begin, end - begin);
    begin = end + 1;
    if (part.empty()) continue;
    // "a.csv+b.csv=ice": a label after the files reads as part of the last
    // file's name; said where that name is no file and the part before '='
    // is one, with the order that works.
    const auto label_after = part.rfind('=');
    if (spec.label.empty() && label_after != std::string::npos && label_after + 1 < part.size() &&
        part.find('/', label_after) == std::string::npos && !fs::exists(part, ec) &&
        fs::is_regular_file(part.substr(0, label_after), ec)) {
      std::string files_alone = text;
      files_alone.replace(text.find(part), part.size(), part.substr(0, label_after));
      throw Error("log '" + text + "': '" + part + "' is no file; a label goes before the files: '" +
                  part.substr(label_after + 1) + "=" + files_alone + "'");
    }
    LogFile file(part);
    const auto at = part.rfind('@');
    if (at != std::string::npos && !fs::exists(part, ec)) {
      const std::string offset = part.substr(at + 1);
      double value = 0.0;
      const char* b = offset.data();
      if (!offset.empty() && *b == '+') ++b;
      const auto parsed = std::from_chars(b, offset.data() + offset.size(), value);
      if (offset.empty() || parsed.ec != std::errc() || parsed.ptr != offset.data() + offset.size() ||
          !std::isfinite(value)) {
        throw Error("log '" + text + "': '" + offset + "' after '@' is not a time offset in seconds");
      }
      if (std::abs(value) > kLargestTimeOffset) {
        throw Error("log '" + text + "': the time offset " + offset +
                    " s is larger in size than 1e11 s, where times lose the precision to keep rows apart");
      }
      file = LogFile(part.substr(0, at), value);
    }
    spec.files.push_back(file);
  }
  if (spec.files.empty()) throw Error("log '" + text + "': no file given");
  return spec;
}

}  // namespace skidimm
