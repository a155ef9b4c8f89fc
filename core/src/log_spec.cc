#include "skidimm/io/log_spec.h"

#include <charconv>
#include <cmath>
#include <system_error>

#include "skidimm/errors.h"

namespace skidimm {

namespace fs = std::filesystem;

std::string LogSpec::name() const {
  std::string out;
  for (const LogFile& f : files) out += (out.empty() ? "" : "+") + f.path.filename().string();
  return out;
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
      file = LogFile(part.substr(0, at), value);
    }
    spec.files.push_back(file);
  }
  if (spec.files.empty()) throw Error("log '" + text + "': no file given");
  return spec;
}

}  // namespace skidimm
