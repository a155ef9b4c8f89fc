// Reading back a `skidimm run` output (`skidimm eval --estimates`): the
// columns t, mu_<mode>... and truth_mode (and decision, if present), scored
// as eval scores a run.
#ifndef SKIDIMM_CORE_SRC_EVALUATION_ESTIMATES_READER_H_
#define SKIDIMM_CORE_SRC_EVALUATION_ESTIMATES_READER_H_

#include <filesystem>
#include <string>
#include <vector>

#include "skidimm/config/bank.h"
#include "skidimm/evaluation/log_evaluation.h"

namespace skidimm {
namespace evaluation {

// Scores the estimates in `file` ("-": standard input). With a bank, its
// classes are scored (its modes must be the file's mu_ columns, in order);
// without one, every mode is a class. Throws LogError naming the file, line
// and column (number and name) and what was expected for: a t or mu cell that
// is not a finite number (read as the log reader reads cells: subnormals are
// numbers, csv.h parse_finite_number), a probability outside [0, 1] or
// probabilities of a row not summing to 1 (both within 1e-6), time that does
// not increase strictly, missing columns, or a file with a header but no rows.
// With `decide`, the decision is made again from the file's probabilities
// with those settings (over the bank's classes, or the file's modes) instead
// of read from its decision column: choosing thresholds needs no new run.
LogResult evaluate_estimates(const std::filesystem::path& file, const BankConfig* bank,
                             const DecisionConfig* decide = nullptr);

// evaluate_estimates() with each of `decisions` in turn, the file read once:
// a result per setting, in their order (none given: one, from the file's
// decision column). Comparing decision settings costs one reading of the
// files, not one per setting. A `label` (`LABEL=` of the argument: a mode
// of the file or a class of the bank) is every step's truth, as a log's
// label is for `eval --input`: its truth_mode column, if any, is not read.
std::vector<LogResult> evaluate_estimates(const std::filesystem::path& file, const BankConfig* bank,
                                          const std::vector<DecisionConfig>& decisions,
                                          const std::string& label = std::string());

}  // namespace evaluation
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_EVALUATION_ESTIMATES_READER_H_
