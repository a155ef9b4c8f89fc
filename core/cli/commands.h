// The `skidimm` subcommands. Each returns the process exit code and reports
// errors on stderr; exceptions from the library are turned into messages here.
#ifndef SKIDIMM_CLI_COMMANDS_H_
#define SKIDIMM_CLI_COMMANDS_H_

#include <exception>
#include <filesystem>
#include <iostream>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "skidimm/config/bank.h"
#include "skidimm/config/run_overrides.h"
#include "skidimm/engine/fatal_signal_report.h"
#include "skidimm/engine/log_run.h"
#include "skidimm/errors.h"
#include "skidimm/io/log_arguments.h"
#include "skidimm/printable.h"

namespace skidimm {
namespace cli {

// Exit codes.
inline constexpr int kExitOk = 0;
inline constexpr int kExitFailure = 1;  // bad bank, plugin, log, or I/O
inline constexpr int kExitUsage = 2;    // bad command line

// Options a command cannot honour together (or would ignore): a bad command
// line, exit kExitUsage, never one of them silently dropped.
class UsageError : public Error {
 public:
  using Error::Error;
};

// Runs a command's body; a library error becomes "<command>: error: ..." on
// stderr and kExitFailure (a UsageError, kExitUsage), never an uncaught
// exception. Messages are made printable (printable.h): they often quote
// file contents.
template <typename Body>
int report_errors(const char* command, Body&& body) {
  try {
    return body();
  } catch (const UsageError& e) {
    std::cerr << command << ": error: " << printable(e.what()) << "\n";
    return kExitUsage;
  } catch (const Error& e) {
    std::cerr << command << ": error: " << printable(e.what()) << "\n";
  } catch (const std::exception& e) {
    std::cerr << command << ": unexpected error: " << printable(e.what()) << "\n";
  }
  return kExitFailure;
}

// How `command`'s log patterns treat runs some of their files lack: with
// --skip-unpaired (`skip`) each is left out with a note on stderr.
LogArgumentOptions unpaired_runs(const char* command, bool skip);

// The bank's models of measurements that aggregate a step's rows (mean(),
// std(), rms(), diff_std()) were fitted at its sampling.rate: a --rate (`rate`) that
// steps it at another rate changes what those measurements measure. Warns
// on stderr, naming them, the two rates and `bank_file`; nothing otherwise.
void warn_of_rate_unlike_the_banks(const char* command, const std::filesystem::path& bank_file, const BankConfig& bank,
                                   std::optional<double> rate);

// Per mode whose filter was rejected: how often, why, and where first; and
// how often each mode gated the measurement (stderr, indented). Counts of
// several logs give, per mode, the log its first row is in (`first_logs`).
void print_rejections(const Bank& bank, const std::vector<ModeRejections>& rejections,
                      const std::vector<std::string>& first_logs = {});

// estimator_options() (run_overrides.h), its refusal of --smooth with --lag a
// UsageError, as is --decision-stale-after (`overrides`) with either: a
// smoothed decision never goes stale.
EstimatorOptions command_line_estimator(bool smooth, std::optional<double> lag, const RunOverrides& overrides);

// Throws when writing `output` (given with `option`) would replace one of
// the files of `logs`, which the command reads: a log is never overwritten.
void refuse_output_over_logs(const std::filesystem::path& output, const std::string& option,
                             const std::vector<LogSpec>& logs);

// A file a command reads or writes, and the option that names it (empty:
// not given).
struct NamedFile {
  std::string option;
  std::filesystem::path path;
};

// Throws when two of `outputs` are one file (the later write would replace
// the earlier) or an output is one of `inputs` (its write would replace
// what the command read): checked before any work, so that nothing is lost
// at the end. Devices and pipes (/dev/null) are never a clash.
void refuse_clashing_files(const std::vector<NamedFile>& outputs, const std::vector<NamedFile>& inputs = {});

struct RunOptions {
  std::filesystem::path bank;
  std::vector<std::string> inputs;  // the files of one log: [LABEL=]FILE[@OFFSET][+FILE...], repeatable
  // --rate, --decision-*, --innovation-gate, --likelihood-weight: over the bank's.
  RunOverrides overrides;
  bool smooth = false;         // fixed-interval smoothing over the whole log
  std::optional<double> lag;   // fixed-lag smoothing with this lag (s)
  std::filesystem::path output;
  std::filesystem::path plot;  // --plot: the figure drawn from the output after the run (main.cc)
  std::vector<std::filesystem::path> plugin_paths;
  bool quiet = false;
  bool progress = true;  // shown only when stderr is a terminal
  bool strict = false;            // the first rejected mode filter is an error
  bool flush = false;             // every row handed to the output as it is computed
  std::string serve;              // "[HOST:]PORT": publish each step live (Foxglove WebSocket protocol)
  double serve_speed = 1.0;       // replaying a file with --serve: times real time; 0 unpaced
  bool copy_topics = false;       // an .mcap output also holds the bag topics the bank read
  std::filesystem::path resume;   // the filter starts from this checkpoint file
  std::filesystem::path save_checkpoint;  // the filter's checkpoint after the last step, written here
  double checkpoint_every = 0.0;          // s of the log's time: also written as the run goes (0: at the end only)
};

int run(const RunOptions& options);

// `apply()`'s result; an Error it throws is what the command line gave
// refused (exit 2, as any bad option), not a failure of the work: its
// message follows `what` ("--objective: ...").
template <typename Apply>
decltype(auto) given_on_the_command_line(const std::string& what, Apply&& apply) {
  try {
    return apply();
  } catch (const UsageError&) {
    throw;
  } catch (const Error& e) {
    throw UsageError(what + ": " + e.what());
  }
}

// given_on_the_command_line() for the settings --decision-* and the like
// override a bank's with.
template <typename Apply>
decltype(auto) settings_given_on_the_command_line(Apply&& apply) {
  return given_on_the_command_line("the command line's settings", std::forward<Apply>(apply));
}

// From now on a fatal signal (a plugin that crashes the process) is named
// with the bank's mode whose model was running and its plugin
// (fatal_signal_report.h), worded as `wording` says.
void name_plugins_in_fatal_signals(const std::string& program, const Bank& bank, FatalSignalWording wording);

// `skidimm bag FILE`: a ROS 2 bag's topics, counts, rates, time span and the
// column paths a bank can name (ros/bag_info.h).
int bag_info(const std::filesystem::path& bag);

struct SimulateOptions {
  std::filesystem::path scenario;
  // Or: the bank's own models, driven by another log's inputs and truth.
  std::filesystem::path bank;
  std::string inputs_from;
  std::vector<std::filesystem::path> plugin_paths;
  double rate = 0.0;
  std::filesystem::path output;
  // With --bank: a copy of the bank whose columns read the simulated log
  // (each input and measurement under the name it was written with).
  std::filesystem::path output_bank;
  bool has_seed = false;
  unsigned long long seed = 0;
  double duration = 0.0;  // 0: the scenario's
  bool quiet = false;
};
int simulate(const SimulateOptions& options);

struct FitCommandOptions {
  std::filesystem::path bank;
  std::vector<std::string> logs;      // [MODE=]FILE[+FILE...]
  std::vector<std::string> held_out;  // same form, evaluated after the fit
  std::string mode;                   // the mode unlabelled logs belong to
  std::string name;                   // output name of that mode (a new terrain)
  bool skip_unpaired = false;         // leave out a pattern's runs that some of its files lack
  bool shared = false;                // fit the bank-level parameters jointly
  double rate = 0.0;                  // Hz; > 0 overrides the bank's sampling.rate
  std::string objective = "likelihood";  // likelihood or window
  bool fit_r = false;                 // likelihood: one R for the bank
  bool full_q = false;                // likelihood: Q with off-diagonal terms
  bool output_noise = false;          // window: each mode's own R for the outputs it predicts
  bool parameter_uncertainty = false;  // window: write each fitted mode's parameter covariance
  bool uncertainty_per_log = false;    // with it: each log's rows counted as correlated
  bool residual_correlation = false;   // window: write each fitted mode's residual correlation
  bool pooled_q = false;               // window: every fitted mode gets the mean of the modes' Q
  bool partial_pooling = false;        // with parameter_uncertainty: each regime's fits pooled partially
  bool hold_unexcited = false;        // hold parameters the logs do not excite at their starting values
  double window = 0.0;                // s; 0: one-step
  std::string loss = "huber";
  double loss_scale = 3.0;
  std::filesystem::path output_entry;
  std::filesystem::path append_to;
  std::filesystem::path output_bank;
  std::vector<std::filesystem::path> plugin_paths;
  std::string command_line;  // recorded in written files
};
int fit(const FitCommandOptions& options);

struct TuneCommandOptions {
  std::filesystem::path bank;
  std::vector<std::string> logs;  // [MODE=]FILE[@OFFSET][+FILE...], directories and patterns
  std::string mode;               // the mode logs without MODE= (and without a truth column) show
  bool skip_unpaired = false;     // leave out a pattern's runs that some of its files lack
  double rate = 0.0;
  std::string objectives = "likelihood";  // comma-separated fit objectives to compare
  std::string knobs;                      // comma-separated settings to tune; empty: the default set
  int folds = 0;                          // 0: leave one log out
  int inner_folds = 4;
  bool no_assess = false;
  std::string protocols = "logs";    // comma-separated protocols of the nested assessment (fitting/tuning.h)
  std::filesystem::path sessions;    // which logs were recorded together (fitting/sessions.h)
  std::vector<std::string> lockbox;  // logs kept aside, scored once by the tuned bank; as `logs`
  bool splice = false;               // score the logs a fold holds out as one spliced run
  bool walk = false;                 // walk each knob's line instead of running its whole grid
  int threads = 0;
  double window = 0.0;  // the window objective's window (s)
  bool fit_r = false;
  bool full_q = false;
  bool hold_unexcited = false;
  bool parameter_uncertainty = false;  // window objective: each fitted mode's parameter covariance
  bool uncertainty_per_log = false;    // with it: each log's rows counted as correlated
  bool residual_correlation = false;   // window objective: each fitted mode's residual correlation
  bool pooled_q = false;               // window objective: every fitted mode gets the mean of the modes' Q
  bool partial_pooling = false;        // with --parameter-uncertainty: each regime's fits pooled partially
  std::filesystem::path output_bank;
  std::filesystem::path table;      // per-log scores as CSV
  std::filesystem::path estimates;  // the nested assessment's per-step outputs: a folder per protocol, a file per log
  // --range-for: logs per class of the set whose range of accuracy each
  // held-out table gives (evaluation/accuracy_range.h); empty, as many as it scored.
  std::map<std::string, int> range_for;
  std::vector<std::filesystem::path> plugin_paths;
  bool quiet = false;
  std::string command_line;
};
int tune(const TuneCommandOptions& options);

struct EvalOptions {
  std::filesystem::path bank;
  // --rate and the filter's settings over the bank's.
  RunOverrides overrides;
  // --decision-*: one value each overrides the bank's decision settings
  // (with --estimates the decision is made again from the files'
  // probabilities); with --estimates, lists compare every combination.
  std::vector<double> decision_enter, decision_leave, decision_hold;
  std::vector<std::string> inputs;     // logs: FILE[+FILE...] or directories; each argument is a group
  std::vector<std::string> estimates;  // `skidimm run` outputs (files or directories) instead of running
  std::vector<std::filesystem::path> plugin_paths;
  bool skip_unpaired = false;  // leave out a pattern's runs that some of its files lack
  bool smooth = false;
  std::optional<double> lag;
  bool splice = false;  // the logs end to end as one run, the groups taking turns
  bool json = false;
  // --range-for: logs per class of the set whose range of accuracy the
  // report gives (evaluation/accuracy_range.h); empty, as many as were scored.
  std::map<std::string, int> range_for;
};
int eval(const EvalOptions& options);

struct PlotOptions {
  std::filesystem::path estimates;  // a `skidimm run` output
  std::filesystem::path output;     // .png or .svg
  // Optional: the input log, for measurements and true states. With a bank it
  // is read like `run` reads it (any log form); without, it must be one CSV
  // whose columns are named like the states.
  std::vector<std::string> log;  // the log's files, as `run --input` takes them
  std::filesystem::path bank;
  std::vector<std::filesystem::path> plugin_paths;
  double rate = 0.0;
  std::string title;
  bool states = false;  // add a panel per state
};
int plot(const PlotOptions& options);
// With `checks` (log arguments, as `fit --log` takes them), also runs the
// conformance kit's checks on each mode at operating points of those logs
// (model_conformance.h); kExitFailure when a mode fails them. `rate` (Hz,
// > 0) steps the bank as `run --rate` would, for the logs and for the
// warning of measurements that aggregate a step's rows.
int validate(const std::filesystem::path& bank, const std::vector<std::filesystem::path>& plugin_paths,
             const std::vector<std::string>& checks = {}, double rate = 0.0);
// Writes the project of a new plugin NAME into parent/NAME (which must not exist).
int new_plugin(const std::string& name, const std::filesystem::path& parent);
int plugins(const std::vector<std::filesystem::path>& plugin_paths);

}  // namespace cli
}  // namespace skidimm

#endif  // SKIDIMM_CLI_COMMANDS_H_
