#include "skidimm/fitting/sessions.h"

#include <fnmatch.h>

#include <fstream>
#include <sstream>

#include "skidimm/errors.h"

namespace skidimm {
namespace fitting {

namespace {

// Whether `glob` matches the whole path or its end after a '/', so that
// `SNOW/pro_0[0-2].csv` matches `../data/borealtc/SNOW/pro_01.csv`.
bool matches(const std::string& glob, const std::string& path) {
  if (fnmatch(glob.c_str(), path.c_str(), FNM_PATHNAME) == 0) return true;
  for (std::size_t slash = path.find('/'); slash != std::string::npos; slash = path.find('/', slash + 1)) {
    if (fnmatch(glob.c_str(), path.c_str() + slash + 1, FNM_PATHNAME) == 0) return true;
  }
  return false;
}

}  // namespace

std::vector<SessionPattern> read_sessions_file(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) throw Error(file.string() + ": cannot read the sessions file");
  std::vector<SessionPattern> out;
  std::string text;
  int line = 0;
  while (std::getline(in, text)) {
    ++line;
    const std::size_t comment = text.find('#');
    if (comment != std::string::npos) text.resize(comment);
    std::istringstream fields(text);
    SessionPattern p;
    p.line = line;
    if (!(fields >> p.glob)) continue;  // blank
    std::string extra;
    if (!(fields >> p.session) || (fields >> extra)) {
      throw Error(file.string() + ":" + std::to_string(line) +
                  ": expected 'GLOB SESSION' (a pattern of log paths and a session name, no spaces in either)");
    }
    out.push_back(p);
  }
  if (out.empty()) throw Error(file.string() + ": no 'GLOB SESSION' line");
  return out;
}

std::vector<std::string> sessions_of(const std::vector<std::string>& paths, const std::vector<SessionPattern>& patterns,
                                     const std::filesystem::path& file) {
  std::vector<std::string> out;
  std::string unmatched;
  int missing = 0;
  for (const std::string& path : paths) {
    std::string session;
    for (const SessionPattern& p : patterns) {
      if (matches(p.glob, path)) {
        session = p.session;
        break;
      }
    }
    if (session.empty() && ++missing <= 5) unmatched += "\n  " + path;
    out.push_back(session);
  }
  if (missing > 0) {
    throw Error(file.string() + ": no line gives the session of " + std::to_string(missing) + " log(s):" + unmatched +
                (missing > 5 ? "\n  ..." : ""));
  }
  return out;
}

}  // namespace fitting
}  // namespace skidimm
