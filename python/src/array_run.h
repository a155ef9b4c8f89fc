// Running a bank over whole arrays (or over a log file, as `skidimm run`
// reads it) in C++, with no Python per step, into the columns `skidimm run`
// writes (estimates_writer.h): t, mu_<mode>, the combined state, var_<state>,
// mode, decision, truth_mode (when there is a truth), status, reason.
#ifndef SKIDIMM_PYTHON_ARRAY_RUN_H_
#define SKIDIMM_PYTHON_ARRAY_RUN_H_

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "skidimm/config/bank.h"
#include "skidimm/engine/decision.h"
#include "skidimm/engine/imm.h"
#include "skidimm/engine/log_run.h"
#include "skidimm/io/log_reader.h"

namespace skidimm {
namespace python {

// The bank's mode names, in order: the values of the mode column.
std::vector<std::string> mode_names(const BankConfig& config);

// Where a run writes its rows: one array per column, each with room for
// every row, owned by the caller (numpy arrays made once for Imm.run, whose
// number of rows is known; growing vectors for a log file). Writing a row is
// stores only: no allocation, no Python. Text columns are codes: mode
// indexes the bank's modes, decision the decision's names (ModeDecision::
// kUnknown = -1), status the StepStatus. The reason column is empty on almost
// every row, so only the rows that have one are kept.
// The `mode` column's code when "none of these" outweighs every mode.
constexpr std::int32_t kUnknownMode = -1;

struct RunColumns {
  double* t = nullptr;
  std::vector<double*> mu;     // per mode
  double* unknown = nullptr;   // "none of these" (BankConfig::unknown); null without one
  std::vector<double*> state;  // per state
  std::vector<double*> var;    // per state
  std::int32_t* mode = nullptr;
  std::int32_t* decision = nullptr;
  std::int8_t* status = nullptr;
  std::vector<std::pair<long, std::string>> reasons;  // (row, the CLI's reason text), rows in order
};

// Storage for RunColumns that grows, for runs whose rows are counted only
// as they come (a log file).
class GrowingRunColumns {
 public:
  explicit GrowingRunColumns(const BankConfig& config);
  // Room for at least `rows` rows (amortised doubling); columns() changes.
  void reserve(long rows);
  // Keeps the first `rows` rows.
  void shrink(long rows);
  RunColumns& columns() { return columns_; }

  std::vector<double> t;
  std::vector<std::vector<double>> mu, state, var;
  std::vector<std::vector<double>> unknown;  // one column with an unknown hypothesis, none without
  std::vector<std::int32_t> mode, decision;
  std::vector<std::int8_t> status;

 private:
  void resize(std::size_t rows);
  void point();  // columns_ at the vectors' data
  RunColumns columns_;
};

// The rows of arrays: t (n), u (n x input_dim) and z (n x measurement_dim),
// C order; NaN in z = not measured.
struct ArrayLog {
  long rows = 0;
  const double* t = nullptr;
  const double* u = nullptr;
  const double* z = nullptr;
};

// Runs `imm` over the rows into `out` (room for log.rows rows). The filter
// continues from the imm's current state and `decision`'s (a fresh or reset
// Imm starts from the prior, as `skidimm run` does); the smoothers reset both
// first. Does not touch Python (call it with the GIL released; Python models
// take it themselves).
void run_arrays(Imm* imm, const ArrayLog& log, const EstimatorOptions& estimator, ModeDecision* decision,
                RunColumns* out);

// The bare loop the target is measured against: imm->step() over the rows,
// nothing stored. Returns the sum of the first mode's probabilities (so the
// loop cannot be optimised away).
double step_loop(Imm* imm, const ArrayLog& log);

// `skidimm run`'s loop over a log (log_run.h's run_log, the library's own),
// into growing columns; with_truth: *truth gets each row's label (`label`,
// or else the log's truth column). Returns the number of rows. On an error
// (a bag cut short, a bad row) `out` and `truth` hold the rows before it.
long run_log_file(const Bank& bank, LogReader* reader, const EstimatorOptions& estimator,
                  const DecisionConfig& decision, const std::string& label, bool with_truth, GrowingRunColumns* out,
                  std::vector<std::string>* truth);

}  // namespace python
}  // namespace skidimm

#endif  // SKIDIMM_PYTHON_ARRAY_RUN_H_
