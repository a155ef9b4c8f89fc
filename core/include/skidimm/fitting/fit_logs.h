// The logs a fit trains each mode on, read the same way by every front end
// (`skidimm fit` and `tune`, Python's skidimm.fit, skidimm.dask).
//
// Which mode a log shows: its MODE= label, else the default mode (`fit
// --mode`), else the bank's truth column, whose runs of one label become
// segments of their own. A label may name a class: its steps go to the
// class's modes by their fit_when (the first whose condition holds, else the
// one without).
#ifndef SKIDIMM_FITTING_FIT_LOGS_H_
#define SKIDIMM_FITTING_FIT_LOGS_H_

#include <map>
#include <string>
#include <vector>

#include "skidimm/config/bank.h"
#include "skidimm/fitting/model_fitter.h"
#include "skidimm/io/log_arguments.h"
#include "skidimm/io/log_reader.h"

namespace skidimm {
namespace fitting {

// The segments one log gives each mode, by mode index. Throws Error; its
// messages name the log as `option` gave it ("--log", "--held-out").
std::vector<ModeLogs> mode_segments(const BankConfig& config, const LogSpec& log, const std::string& default_mode,
                                    const SamplingConfig& sampling, const std::string& option = "--log");

// The segments of every log that `arguments` stand for (log_arguments.h:
// files, directories, patterns), merged by mode in argument order. Each log
// is read on its own thread (parallel.h): the same segments, in the same
// order, and the same first error as one thread gives.
std::vector<ModeLogs> load_mode_logs(const BankConfig& config, const std::vector<std::string>& arguments,
                                     const std::string& default_mode, const SamplingConfig& sampling,
                                     const std::string& option = "--log", const LogArgumentOptions& expansion = {});

// Each input's range over the steps of mode `mode` in `data`, every entry of
// it (a fit pools them), by the bank's input names (ModeConfig::fitted_inputs);
// an input with no finite value has none.
std::map<std::string, InputRange> fitted_input_ranges(const BankConfig& config, const std::vector<ModeLogs>& data,
                                                      int mode);

// For each log in `data` fitted as one mode by a label (--mode, or its own
// MODE=) whose truth column names other modes of the bank at some of its
// steps (not the mode, nor one of its class; a name the bank does not know
// is a new terrain's, which a fit from a starting mode is for): "<log>:
// fitted as mode 'a' by a label, though its truth column 'mode' names b, c
// at some of its steps". A label overrides the truth column, as documented;
// mixing terrains into one mode that way is rarely meant. Text from the
// files as it is (print it with printable()).
std::vector<std::string> labels_overriding_truth(const BankConfig& config, const std::vector<ModeLogs>& data);

// What the bank's sampling.skip_gaps and skip_out_of_order left out of the
// logs in `data`, and their measurement values that were not finite
// (Trajectory::skipped): "<log>: <what>", once per log, in the order of `data`.
// The fit runs without those rows and spans, so it is said, as run and eval
// say it.
std::vector<std::string> skipped_by_sampling(const std::vector<ModeLogs>& data);
// Each log in `data` that spans less than a second, stamps in another unit
// than `config`'s columns.time_unit reads (seconds read as ms make a run of
// minutes a fraction of a second, one step long at a fixed rate): "<log>:
// 761 step(s) in 0.117 s ...", with the question of the unit. Once per log,
// in the order of `data`; the whole log's span (Trajectory::log_seconds),
// however few of its steps a mode fits.
std::vector<std::string> logs_spanning_under_a_second(const BankConfig& config, const std::vector<ModeLogs>& data);
// One message per class whose every mode has a fit_when: a step of the
// class that none of them holds for is fitted by no mode (split among a
// class's modes, the steps no fit_when takes go to its mode without one).
std::vector<std::string> classes_leaving_steps_unfitted(const BankConfig& config);

}  // namespace fitting
}  // namespace skidimm

#endif  // SKIDIMM_FITTING_FIT_LOGS_H_
