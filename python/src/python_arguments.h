// Arguments the bindings take as Python values: decision settings as a dict,
// logs as text or as the dicts expand_log_argument gives, and the runs a
// pattern leaves out, as warnings.
#ifndef SKIDIMM_PYTHON_PYTHON_ARGUMENTS_H_
#define SKIDIMM_PYTHON_PYTHON_ARGUMENTS_H_

#include <pybind11/pybind11.h>

#include <filesystem>
#include <string>
#include <vector>

#include "skidimm/config/bank.h"
#include "skidimm/engine/decision.h"
#include "skidimm/io/log_arguments.h"
#include "skidimm/io/log_reader.h"

namespace skidimm {
namespace python {

// The bank's decision settings with those of a `decision=` dict ({"enter":
// 0.9, "leave": 0.05, "min_hold": 1.0}, any of them), checked.
DecisionConfig decision_of(const BankConfig& config, const pybind11::object& given);

// A log given as text ("[LABEL=]FILE[@OFFSET][+...]") or as a dict from expand_log_argument.
LogSpec log_spec_of(const pybind11::object& log);
// The dict expand_log_argument gives for a log (label, files, text, name).
pybind11::dict log_spec_to_dict(const LogSpec& spec);

// Log arguments' patterns skip runs some of their files lack when `skip`,
// noting each in *skipped (from whichever thread expands them; no GIL needed).
LogArgumentOptions unpaired_runs(bool skip, std::vector<std::string>* skipped);
// The runs a pattern left out, as Python warnings (GIL held).
void warn_skipped(const std::vector<std::string>& skipped);

// `paths` when each exists; else throws Error naming the first that does
// not, as --plugin-path refuses it (a typo would search nothing, silently).
std::vector<std::filesystem::path> existing_plugin_paths(const std::vector<std::filesystem::path>& paths);

}  // namespace python
}  // namespace skidimm

#endif  // SKIDIMM_PYTHON_PYTHON_ARGUMENTS_H_
