// Python exceptions for skidimm's typed errors (errors.h), so that nothing a
// user gets wrong terminates the interpreter:
//
//   skidimm.Error        (RuntimeError)        skidimm::Error
//   skidimm.ConfigError  (Error, ValueError)   skidimm::ConfigError: .file, .line, .field
//   skidimm.LogError     (Error, ValueError)   skidimm::LogError: .file, .line
//   skidimm.PluginError  (Error)               skidimm::PluginError
//   skidimm.FitError     (Error)               skidimm::fitting::FitError
//
// The message is the C++ what(), unchanged ("<file>:<line>: <field>: ...").
// An exception a Python motion model raised inside a step is re-raised as
// itself (python_model.h).
#ifndef SKIDIMM_PYTHON_ERRORS_H_
#define SKIDIMM_PYTHON_ERRORS_H_

#include <pybind11/pybind11.h>

#include <exception>

namespace skidimm {
namespace python {

// Creates the exception classes in `m` and registers the translator.
void register_errors(pybind11::module_& m);

// Raises the Python exception the translator gives the C++ exception `p`,
// with the attribute `name` = `value` besides its own (a run's rows computed
// before the error, say). An exception not of skidimm's is rethrown as is.
[[noreturn]] void raise_with(std::exception_ptr p, const char* name, pybind11::object value);

}  // namespace python
}  // namespace skidimm

#endif  // SKIDIMM_PYTHON_ERRORS_H_
