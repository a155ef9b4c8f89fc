// Sessions: which logs were recorded together (`skidimm tune --sessions`).
//
// Runs recorded in one session (one day, one place, one set-up of the robot)
// share what changes between sessions: the ground's moisture, the tyres'
// pressure, the payload, how the operator drives. Cross-validation that
// holds out one log at a time keeps the other logs of its session in
// training, and so scores a run as if its session were known. Holding out
// whole sessions (Protocol::kSessions, tuning.h) asks what a user gets on a
// session nobody has seen.
//
// A sessions file names them, one line per pattern:
//
//   # glob of a log's first file    session
//   SNOW/pro_0[0-2].csv               snow-a
//   SNOW/pro_0[3-5].csv               snow-b
//
// A log belongs to the session of the first line whose glob (fnmatch, `*`
// not crossing `/`) matches its first file's path as given on the command
// line, or the end of that path after a `/`. Blank lines and text after `#`
// are ignored.
#ifndef SKIDIMM_FITTING_SESSIONS_H_
#define SKIDIMM_FITTING_SESSIONS_H_

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace skidimm {
namespace fitting {

struct SessionPattern {
  std::string glob;
  std::string session;
  int line = 0;
};

// Reads a sessions file. Throws Error naming the file and line of a line that
// is not `GLOB SESSION`.
std::vector<SessionPattern> read_sessions_file(const std::filesystem::path& file);

// The session of each path (a log's first file, as given), in order. Throws
// Error listing the paths no pattern matches, with the file's name.
std::vector<std::string> sessions_of(const std::vector<std::string>& paths, const std::vector<SessionPattern>& patterns,
                                     const std::filesystem::path& file);

}  // namespace fitting
}  // namespace skidimm

#endif  // SKIDIMM_FITTING_SESSIONS_H_
