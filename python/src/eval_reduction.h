// `skidimm eval`'s reduction of per-log results into its report, for Python
// and for Dask, where the logs are evaluated elsewhere and only their
// LogResults come back.
//
// The metrics, the merge over logs and the formatting are the CLI's own code
// (core/cli/eval_command.cc, compiled into eval_reduction.cc), not a copy:
// the figures are those `skidimm eval` prints, to the last digit, as long as
// the logs are reduced in the CLI's order (groups in argument order, each
// group's logs sorted as the CLI expands them).
#ifndef SKIDIMM_PYTHON_EVAL_REDUCTION_H_
#define SKIDIMM_PYTHON_EVAL_REDUCTION_H_

#include <string>
#include <vector>

#include "skidimm/evaluation/log_evaluation.h"

namespace skidimm {
namespace python {

struct EvalGroup {
  std::string name;
  std::vector<evaluation::LogResult> logs;
};

// A group's name as `skidimm eval` gives it: the label, else the directory's
// name or the first file's stem.
std::string eval_group_name(const std::string& argument);

// What `skidimm eval --json` prints: {"overall": ..., "groups": {...}, "logs": {...}}.
std::string eval_json(const std::vector<EvalGroup>& groups, const std::vector<std::string>& states);

// What `skidimm eval` prints: a table per group when there are several, then
// the overall one. `classes`: the bank's class names (columns of the confusion);
// `decision`: the settings the scored decision was made with.
std::string eval_table(const std::vector<EvalGroup>& groups, const std::vector<std::string>& classes,
                       const std::vector<std::string>& states, const DecisionConfig& decision);

}  // namespace python
}  // namespace skidimm

#endif  // SKIDIMM_PYTHON_EVAL_REDUCTION_H_
