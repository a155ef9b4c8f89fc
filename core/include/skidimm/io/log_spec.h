// How a log is named where a command takes one: "[LABEL=]FILE[@OFFSET][+FILE...]".
// A log is one recording in one or several files that share a clock
// (log_reader.h reads them); the label names the mode the whole log shows,
// the offset aligns a file's clock with the others'.
#ifndef SKIDIMM_IO_LOG_SPEC_H_
#define SKIDIMM_IO_LOG_SPEC_H_

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace skidimm {

// The largest time offset a file may be given, in size (s): Unix times
// (1.7e9 s) keep a tenth of a microsecond, while far past this bound a
// double's times could no longer tell rows 10 ms apart.
inline constexpr double kLargestTimeOffset = 1e11;

// One file of a log and the offset added to its times (s).
struct LogFile {
  LogFile() = default;
  LogFile(std::filesystem::path file, double offset = 0.0) : path(std::move(file)), time_offset(offset) {}  // NOLINT
  LogFile(const std::string& file) : path(file) {}                                                          // NOLINT
  LogFile(const char* file) : path(file) {}                                                                 // NOLINT

  std::filesystem::path path;
  double time_offset = 0.0;
};

// The files' paths joined with '+': how eval --json keys a log and fit
// reports name it.
std::string joined_paths(const std::vector<LogFile>& files);

// A log as given on the command line: "[LABEL=]FILE[@OFFSET][+FILE[@OFFSET]...]".
// LABEL names the mode (or class) the whole log shows; OFFSET is in seconds.
struct LogSpec {
  std::string label;
  std::vector<LogFile> files;
  std::string text;          // as given, for messages
  std::string name() const;  // the files' names joined with '+', for tables
};

// Each log's name() for tables, except where two logs' names would be the
// same (runs of two folders that share file names, as BorealTC's terrains
// do): those are named by their files' paths from as many of the last
// folders as tell them apart ("ICE/pro_04.csv+ICE/imu_04.csv").
std::vector<std::string> distinct_names(const std::vector<const LogSpec*>& logs);

// Parses one log argument. A '=' or '@' that is part of an existing file's
// name is kept in the name. Throws Error on an empty file list or a bad offset.
LogSpec parse_log_spec(const std::string& text);

}  // namespace skidimm

#endif  // SKIDIMM_IO_LOG_SPEC_H_
