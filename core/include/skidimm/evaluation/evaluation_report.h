// What `skidimm eval` prints, for every front end (the CLI; Python's
// skidimm.eval and skidimm.eval_report; skidimm.dask.eval): a table per
// group when there are several, then one over all logs; or the same as JSON;
// and, comparing decision settings, a row (or a report) per setting. Groups
// are reduced in the order given (evaluation_summary.h).
#ifndef SKIDIMM_EVALUATION_EVALUATION_REPORT_H_
#define SKIDIMM_EVALUATION_EVALUATION_REPORT_H_

#include <map>
#include <string>
#include <vector>

#include "skidimm/config/bank.h"
#include "skidimm/evaluation/log_groups.h"

namespace skidimm {
namespace evaluation {

// Decision settings as the report names them: "enter 0.9, leave 0.05, hold 1 s".
std::string decision_settings_text(const DecisionConfig& settings);

// {"overall": ..., "groups": {name: ...}, "logs": {path: ...}}, one line;
// each log under the path it was given by (LogResult::source), unique.
// `classes`: the order of the confusions and per-class figures; `states`:
// the bank's state names (state RMSE), empty when unknown. `another`: how
// many logs of each class the set holds whose range of accuracy
// (accuracy_range.h) the overall summary gives (empty: as many as were
// scored; each group's is always its own count). A count that does not
// fit the scored classes is reported in the range's place.
std::string report_json(const std::vector<LogGroup>& groups, const std::vector<std::string>& classes,
                        const std::vector<std::string>& states, const std::map<std::string, int>& another = {});

// Why `another` (report_json()'s) does not fit the classes `groups` score,
// or empty where it does.
std::string logs_per_class_problem(const std::vector<LogGroup>& groups, const std::map<std::string, int>& another);

// The tables. `classes`: the order of the confusion's columns and rows
// (truths the bank lacks come last); `decision_made`: how the scored
// decision was made (decision_settings_text, or where it came from);
// `another` as report_json()'s.
std::string report_tables(const std::vector<LogGroup>& groups, const std::vector<std::string>& classes,
                          const std::vector<std::string>& states, const std::string& decision_made,
                          const std::map<std::string, int>& another = {});

// Decision settings compared on the same scored logs (`scored[k]` made with
// `settings[k]`, evaluate_estimate_groups()): as JSON,
// {"decision_settings": [{"enter", "leave", "hold", "report": report_json()}...]};
// as a table, one row per setting of its decision's figures over all logs.
std::string report_decision_settings(const std::vector<DecisionConfig>& settings,
                                     const std::vector<std::vector<LogGroup>>& scored,
                                     const std::vector<std::string>& classes, const std::vector<std::string>& states,
                                     bool json);

// The classes the logs were scored over (LogResult::classes: the bank's, or
// an estimates file's modes), in their order, as first met.
std::vector<std::string> classes_of(const std::vector<LogGroup>& groups);

}  // namespace evaluation
}  // namespace skidimm

#endif  // SKIDIMM_EVALUATION_EVALUATION_REPORT_H_
