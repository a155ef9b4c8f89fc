// Evaluating the logs of several log arguments (log_arguments.h), each
// argument a group: what `skidimm eval` scores, by running a bank over logs
// or by reading `skidimm run` outputs.
#ifndef SKIDIMM_EVALUATION_LOG_GROUPS_H_
#define SKIDIMM_EVALUATION_LOG_GROUPS_H_

#include <string>
#include <vector>

#include "skidimm/config/bank.h"
#include "skidimm/engine/log_run.h"
#include "skidimm/evaluation/log_evaluation.h"
#include "skidimm/io/log_arguments.h"

namespace skidimm {
namespace evaluation {

// The logs of one argument (a scenario, a terrain), in the order it expands to.
struct LogGroup {
  std::string name;  // log_group_name(argument)
  std::vector<LogResult> logs;
};

// A log whose evaluation failed (a bad row half-way, an unreadable file),
// left out of its group.
struct LogFailure {
  std::string group;    // its argument's group name
  std::string source;   // the log as given: its files' paths joined by '+'
  std::string message;  // the error, naming one of the log's files (prefixed with them where it did not)
};

// Runs `bank` over every log of `arguments` and scores it (evaluate_log).
// Every log on its own thread (parallel.h), each with its own filter over the
// shared, read-only bank: the results, and any error, are those of one
// thread (SKIDIMM_THREADS=1). An argument that expands to no log, or to a
// file that does not exist, throws before any log is evaluated.
// Without `failures`, the first failing log's error (in the arguments'
// order) is thrown, and the other logs' results are lost with it. With
// `failures`, every other log is still scored: a log that fails goes into
// *failures, in the arguments' order, and is left out of its group, and a
// group none of whose logs was scored is left out. Throws Error, LogError.
std::vector<LogGroup> evaluate_log_groups(const Bank& bank, const std::vector<std::string>& arguments,
                                          const SamplingConfig& sampling, const EstimatorOptions& estimator,
                                          const LogArgumentOptions& expansion = {},
                                          std::vector<LogFailure>* failures = nullptr);

// The logs of `arguments` spliced end to end into one run (eval --splice):
// the groups taking turns (the first log of each argument's group in order,
// then the second of each...), each log's times shifted to follow the last,
// its truth its label or its truth column, scored by one IMM over the whole
// run (evaluate_spliced()): one group of one result, whose switches are the
// changes from one log's truth to the next. A log that cannot be read is a
// failure, left out of the splice (without `failures`, an exception).
// `spliced` (optional) gets how many logs the run joins. The result's
// `unmeasured` and `skipped` lines each start with the source of the log
// they are about.
std::vector<LogGroup> evaluate_spliced_logs(const Bank& bank, const std::vector<std::string>& arguments,
                                            const SamplingConfig& sampling, const LogArgumentOptions& expansion = {},
                                            std::vector<LogFailure>* failures = nullptr,
                                            std::size_t* spliced = nullptr);

// evaluate_spliced_logs() over logs already expanded: each group's name and
// logs, in the order they take turns.
struct SplicedGroup {
  std::string name;
  std::vector<LogSpec> logs;
};
std::vector<LogGroup> evaluate_spliced_groups(const Bank& bank, const std::vector<SplicedGroup>& groups,
                                              const SamplingConfig& sampling,
                                              std::vector<LogFailure>* failures = nullptr,
                                              std::size_t* spliced = nullptr);

// Scores the `skidimm run` outputs of `arguments` (files, directories,
// patterns) as evaluate_estimates does with `bank` and `decide` (each may be
// null), every file on its own thread, with the results of one; `failures`
// as for evaluate_log_groups().
std::vector<LogGroup> evaluate_estimate_groups(const std::vector<std::string>& arguments, const BankConfig* bank,
                                               const DecisionConfig* decide, const LogArgumentOptions& expansion = {},
                                               std::vector<LogFailure>* failures = nullptr);

// The same with each of `decisions` (the decision made again from the files'
// probabilities, each file read once): the groups once per setting, in their
// order (none given: once, from the files' decision column). A file that
// fails is one failure, left out of every setting's groups.
std::vector<std::vector<LogGroup>> evaluate_estimate_groups(const std::vector<std::string>& arguments,
                                                            const BankConfig* bank,
                                                            const std::vector<DecisionConfig>& decisions,
                                                            const LogArgumentOptions& expansion = {},
                                                            std::vector<LogFailure>* failures = nullptr);

}  // namespace evaluation
}  // namespace skidimm

#endif  // SKIDIMM_EVALUATION_LOG_GROUPS_H_
