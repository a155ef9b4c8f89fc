// Log arguments, read the same way by every command (run, fit, tune, eval,
// plot): "[LABEL=]FILE[@OFFSET][+FILE[@OFFSET]...]" (log_reader.h), where
//  * a directory stands for each of its *.csv files, one log each;
//  * a '*' in the first file's name matches several runs, and the other
//    files' '*' take the same text: 'ice=data/ICE/pro_*.csv+data/ICE/imu_*.csv'
//    pairs pro_02.csv with imu_02.csv. (Quote it so the shell leaves it.)
#ifndef SKIDIMM_CLI_LOG_ARGUMENTS_H_
#define SKIDIMM_CLI_LOG_ARGUMENTS_H_

#include <string>
#include <vector>

#include "skidimm/bank.h"
#include "skidimm/fitting/model_fitter.h"
#include "skidimm/log_reader.h"

namespace skidimm {
namespace cli {

// The logs one argument stands for, sorted by name. Throws Error when a
// pattern or directory matches nothing, or a paired file is missing.
std::vector<LogSpec> expand_log_argument(const std::string& argument);

// Throws Error unless every file of `log` can be read again (a regular file,
// not standard input, a pipe or a FIFO: log_io.h, is_rereadable); `who` says
// which command and why, e.g. "tune reads each log more than once".
void require_rereadable(const LogSpec& log, const std::string& who);

// The bank's sampling, with the command line's --rate when it is > 0.
SamplingConfig sampling_of(const BankConfig& bank, double rate);

// Throws Error naming the values unless 0 <= leave < enter <= 1 and
// min_hold >= 0: decision settings given on a command line or from Python
// (the bank loader checks its own, naming the file and line).
void check_decision_settings(const DecisionConfig& settings);

// `bank`'s decision settings with the command line's --decision-enter,
// --decision-leave and --decision-hold where they are >= 0, checked
// (check_decision_settings).
DecisionConfig decision_settings_of(const DecisionConfig& bank, double enter, double leave, double hold);

// The segments one log gives each mode for fitting. Which mode a log shows:
// its MODE= label, else `default_mode` (--mode), else the bank's truth
// column, whose runs of one label become segments of their own. A label may
// name a class: its steps go to the class's modes by their fit_when (the
// first whose condition holds, else the one without). Throws Error; its
// messages name the log as `option` gave it ("--log", "--held-out").
std::vector<fitting::ModeLogs> mode_segments(const BankConfig& config, const LogSpec& log,
                                             const std::string& default_mode, const SamplingConfig& sampling,
                                             const std::string& option = "--log");

}  // namespace cli
}  // namespace skidimm

#endif  // SKIDIMM_CLI_LOG_ARGUMENTS_H_
