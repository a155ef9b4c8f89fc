// Writing fitted models back as bank YAML: a mode entry, a mode appended to
// an existing bank (its comments and layout kept), or a whole bank written
// from a template bank with fitted `shared:` and `modes:`. Every file written
// is validated as a bank before it replaces anything (written to a temporary
// file, then renamed).
#ifndef SKIDIMM_FITTING_BANK_WRITER_H_
#define SKIDIMM_FITTING_BANK_WRITER_H_

#include <Eigen/Core>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "skidimm/config/bank.h"

namespace skidimm {
namespace fitting {

// The `params:` of a model's parameters of one scope, as YAML flow text:
// "{A: [[-5, 0], [0, -4]], B: [[...]]}" or "{k: 0.85, m: 0.68}".
// `original` is what the bank gave (the mode's `params:` or the bank's
// `shared:`): its keys that are not the model's parameters of this scope
// (text such as expressions, or entries the model holds fixed) are written
// back unchanged, so a fitted entry keeps everything that was not fitted.
// Keys are written in the order of `table`, the keys the model's plugin
// documents (ModelSource::parameter_keys), then the model's other
// parameters in their order (parameter_info), then the rest by name.
std::string format_parameters(const sdk::MotionModel& model, sdk::ParameterScope scope,
                              const sdk::ParameterSet& original = {}, const std::vector<std::string>& table = {});

// A list of text as YAML flow text, each entry double-quoted: ["abs(v)", "x"].
std::string format_text(const std::vector<std::string>& values);

// A matrix as YAML flow text, 7 significant digits.
std::string format_matrix(const Eigen::MatrixXd& m);

// One `modes:` list item (two-space indented), with comment lines above it:
// `mode` as the bank says it (its name, model, Q, `params:` as the bank gave
// them (see format_parameters), fit_when, own R, residual correlation and
// fitted input ranges, each written where it says something), with the
// parameter values of `model`; `table`: the order of its parameters (see
// format_parameters); `input_names`: the order of its fitted input ranges
// (the bank's inputs).
std::string format_mode_entry(const ModeConfig& mode, const sdk::MotionModel& model,
                              const std::vector<std::string>& comments = {}, const std::vector<std::string>& table = {},
                              const std::vector<std::string>& input_names = {});

// Appends a mode entry at the end of the bank file's `modes:` list. Throws
// ConfigError if the result is not a valid bank (e.g. a mode of that name
// exists, or the transition matrix lists every mode) and leaves the file as
// it was.
void append_mode_to_bank(const std::filesystem::path& bank_file, const std::string& entry);

// Throws what append_mode_to_bank() would, without changing the bank: before
// a fit, with the entry of its starting values, so that a bank the fitted
// mode cannot join (per-mode dwell times without one for it, a transition
// matrix, a floor too high for one more mode, another state size) is found
// before the fit rather than after it. Its ConfigError names `bank_file`, at
// the line and field of the complaint.
void check_mode_appends(const std::filesystem::path& bank_file, const std::string& entry);

// Writes `output`: the template's text with its leading comment replaced by
// `header` (lines, without '#') and each listed top-level block (key, text
// starting with "key:") replaced, or inserted before `modes:` when the
// template has none. The rest, comments included, is kept.
void write_bank_from_template(const std::filesystem::path& template_file, const std::filesystem::path& output,
                              const std::vector<std::string>& header,
                              const std::vector<std::pair<std::string, std::string>>& blocks);

// Top-level blocks of a bank, as YAML text that loads back to the same values.
std::string format_columns_block(const BankConfig& config);      // "columns:\n  time: ...\n  inputs: ..."
// "sampling:\n  rate: ...", every setting that is not the default; nothing
// when all are (a step at every time stamp, time-joined files).
std::string format_sampling_block(const SamplingConfig& sampling);
std::string format_measurement_block(const BankConfig& config);  // "measurement:\n  observe: ...\n  R: ..."
std::string format_transition_block(const BankConfig& config);   // "transition:\n  ..."
std::string format_floor_block(const BankConfig& config);        // "mode_probability_floor: ..."
// "likelihood_weight: ...", or nothing when it is 1 (the default: no key).
std::string format_likelihood_weight_block(const BankConfig& config);
// "likelihood_dof: ...", or nothing for the Gaussian likelihood (no key).
std::string format_likelihood_dof_block(const BankConfig& config);
// "extrapolation_scale: ...", or nothing without an extrapolation discount (no key).
std::string format_extrapolation_scale_block(const BankConfig& config);
// "unknown: {inflation: ..., enter: ..., leave: ...}", or nothing without an
// unknown hypothesis (no key).
std::string format_unknown_block(const BankConfig& config);

}  // namespace fitting
}  // namespace skidimm

#endif  // SKIDIMM_FITTING_BANK_WRITER_H_
