// Running a bank over whole arrays (or over a log file, as `skidimm run`
// reads it) in C++, with no Python per step, into the columns `skidimm run`
// writes (estimates_writer.h): t, mu_<mode>, the combined state, var_<state>,
// mode, decision, truth_mode (when there is a truth), status.
#ifndef SKIDIMM_PYTHON_ARRAY_RUN_H_
#define SKIDIMM_PYTHON_ARRAY_RUN_H_

#include <cstdint>
#include <string>
#include <vector>

#include "skidimm/bank.h"
#include "skidimm/decision.h"
#include "skidimm/imm.h"
#include "skidimm/log_reader.h"
#include "skidimm/log_run.h"

namespace skidimm {
namespace python {

// One column per output, row-major in time. Text columns are codes: mode
// indexes the bank's modes, decision the decision's names (-1 unknown),
// status the StepStatus.
struct RunColumns {
  std::vector<double> t;
  std::vector<std::vector<double>> mu;     // per mode
  std::vector<std::vector<double>> state;  // per state
  std::vector<std::vector<double>> var;    // per state
  std::vector<std::int32_t> mode;
  std::vector<std::int32_t> decision;
  std::vector<std::int8_t> status;
  std::vector<std::string> reason;  // the CLI's reason column (estimates_writer.h)
  std::vector<std::string> truth;   // when with_truth
  std::vector<std::string> mode_names;
  bool with_truth = false;

  void reserve(const BankConfig& config, std::size_t rows);
  long rows() const { return static_cast<long>(t.size()); }
};

// The rows of arrays: t (n), u (n x input_dim) and z (n x measurement_dim),
// C order; NaN in z = not measured.
struct ArrayLog {
  long rows = 0;
  const double* t = nullptr;
  const double* u = nullptr;
  const double* z = nullptr;
};

// Runs `imm` over the rows. The filter continues from the imm's current
// state and `decision`'s (a fresh or reset Imm starts from the prior, as
// `skidimm run` does); the smoothers reset both first. Does not touch Python
// (call it with the GIL released; Python models take it themselves).
void run_arrays(Imm* imm, const ArrayLog& log, const EstimatorOptions& estimator, ModeDecision* decision,
                RunColumns* out);

// The bare loop the target is measured against: imm->step() over the rows,
// nothing stored. Returns the sum of the first mode's probabilities (so the
// loop cannot be optimised away).
double step_loop(Imm* imm, const ArrayLog& log);

// `skidimm run`'s loop over a log (log_run.h's run_log, the library's own),
// into columns; `label` overrides the log's truth column.
void run_log_file(const Bank& bank, LogReader* reader, const EstimatorOptions& estimator,
                  const DecisionConfig& decision, const std::string& label, bool with_truth, RunColumns* out);

}  // namespace python
}  // namespace skidimm

#endif  // SKIDIMM_PYTHON_ARRAY_RUN_H_
