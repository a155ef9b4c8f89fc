// The parts of the extension module skidimm._skidimm, one per bound concept,
// each adding its functions and classes to the module (module.cc calls them
// in this order: a part may use the classes of the parts before it).
#ifndef SKIDIMM_PYTHON_BINDINGS_H_
#define SKIDIMM_PYTHON_BINDINGS_H_

#include <pybind11/pybind11.h>

namespace skidimm {
namespace python {

// The plugin search path and listing, and Bank (bank_binding.cc).
void bind_bank(pybind11::module_& m);
// Checkpoint: a filter's state after a step, its files and pickling (checkpoint_binding.cc).
void bind_checkpoint(pybind11::module_& m);
// Estimate and Imm: step and run over arrays, checkpoint and restore (imm_binding.cc).
void bind_imm(pybind11::module_& m);
// Log arguments, run_log, column expressions and read_csv (log_binding.cc).
void bind_logs(pybind11::module_& m);
// LiveLog: rows pushed while the log is read, the steps they complete (live_log_binding.cc).
void bind_live_log(pybind11::module_& m);
// LogResult, evaluate_log and eval_report (evaluation_binding.cc).
void bind_evaluation(pybind11::module_& m);
// simulate_scenario and simulate_models (simulation_binding.cc).
void bind_simulation(pybind11::module_& m);
// Fitting: options, logs by mode, fit in place, the texts `fit` writes (fit_binding.cc).
void bind_fit(pybind11::module_& m);

}  // namespace python
}  // namespace skidimm

#endif  // SKIDIMM_PYTHON_BINDINGS_H_
