// Log arguments, read the same way by every front end (the CLI's run, fit,
// tune, eval and plot; Python; Dask): "[LABEL=]FILE[@OFFSET][+FILE[@OFFSET]...]"
// (parse_log_spec, log_reader.h), where
//  * a directory stands for each of its *.csv and *.mcap files and ROS 2 bag
//    directories, one log each; a bag's own directory (with metadata.yaml)
//    is one log;
//  * a '*' in the first file's name matches several runs, and the other
//    files' '*' take the same text: 'ice=data/ICE/pro_*.csv+data/ICE/imu_*.csv'
//    pairs pro_02.csv with imu_02.csv by their run key, "02". (Quote it so
//    the shell leaves it.) A run that some of the files lack is an error
//    that lists every such run, unless the caller skips them.
#ifndef SKIDIMM_IO_LOG_ARGUMENTS_H_
#define SKIDIMM_IO_LOG_ARGUMENTS_H_

#include <functional>
#include <string>
#include <vector>

#include "skidimm/io/log_reader.h"

namespace skidimm {

// What to do with a run that a pattern's files do not all have
// ('pro_*.csv+imu_*.csv' finds pro_03.csv but no imu_03.csv).
struct LogArgumentOptions {
  // Leave such runs out (`skip-unpaired`), telling `skipped` of each,
  // instead of an error that lists them.
  bool skip_unpaired = false;
  std::function<void(const std::string& message)> skipped;  // may be empty
};

// The logs one argument stands for, sorted by name (a pattern's by run key).
// Throws Error when a pattern or directory matches nothing, or (unless
// `options` skips them) when some runs lack a file.
std::vector<LogSpec> expand_log_argument(const std::string& argument, const LogArgumentOptions& options = {});

// The name of the group of logs one argument stands for (a table of its own
// in `skidimm eval`): its label, else the directory's name or the (first)
// file's stem.
std::string log_group_name(const std::string& argument);

// The group names of several arguments, as `skidimm eval` tables them:
// log_group_name() of each (`names`, in the order of `given`, their parsed
// specs), then unlabelled arguments that would be named alike ('x/ICE/*.csv'
// and 'y/ICE/*.csv') named by the folders that tell them apart
// (distinct_names(), log_spec.h). Arguments still of one name (one label
// given twice) are one group.
std::vector<std::string> distinct_group_names(const std::vector<LogSpec>& given, std::vector<std::string> names);
std::vector<std::string> log_group_names(const std::vector<std::string>& arguments);

// The parts of one log given as several arguments (`run --input` repeated)
// joined into one: their files in order, one label. Throws Error when none
// is given or two labels differ.
LogSpec join_log_arguments(const std::vector<std::string>& arguments);

// Throws Error unless every file of `log` can be read again (a regular file,
// not standard input, a pipe or a FIFO: csv.h, is_rereadable); `who` says
// which command and why, e.g. "tune reads each log more than once".
void require_rereadable(const LogSpec& log, const std::string& who);

}  // namespace skidimm

#endif  // SKIDIMM_IO_LOG_ARGUMENTS_H_
