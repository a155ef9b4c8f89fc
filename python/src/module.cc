// The extension module skidimm._skidimm. The public API is the package
// skidimm (python/skidimm/__init__.py), which re-exports these and adds the
// pandas conveniences; docs/python.md is its guide. Each bound concept is
// added by its own file (bindings.h).
//
// Every function that runs C++ for long (loading plugins, steps, runs,
// evaluation, fitting, simulation) releases the GIL; Python motion models
// take it back for each of their calls (python_model.h). Array sizes are
// checked in the bindings, before the engine's own checks (which abort) can
// see them.
#include <pybind11/pybind11.h>

#include "bindings.h"
#include "errors.h"

PYBIND11_MODULE(_skidimm, m) {
  m.doc() = "skidimm's C++ engine (see the package skidimm and docs/python.md)";
  m.attr("__version__") = SKIDIMM_VERSION;
  skidimm::python::register_errors(m);
  skidimm::python::bind_bank(m);
  skidimm::python::bind_checkpoint(m);
  skidimm::python::bind_imm(m);
  skidimm::python::bind_logs(m);
  skidimm::python::bind_live_log(m);
  skidimm::python::bind_evaluation(m);
  skidimm::python::bind_simulation(m);
  skidimm::python::bind_fit(m);
}
