#include "errors.h"

#include <exception>
#include <string>
#include <vector>

#include "python_model.h"
#include "skidimm/config/expression.h"
#include "skidimm/errors.h"
#include "skidimm/fitting/model_fitter.h"

namespace skidimm {
namespace python {

namespace py = pybind11;

namespace {

// Owned by the module for the interpreter's lifetime (never decremented:
// the translator may run until the very end).
PyObject* error_class = nullptr;
PyObject* config_error_class = nullptr;
PyObject* log_error_class = nullptr;
PyObject* plugin_error_class = nullptr;
PyObject* fit_error_class = nullptr;

PyObject* new_class(py::module_& m, const char* name, std::initializer_list<PyObject*> bases, const char* doc) {
  py::tuple base_tuple(bases.size());
  std::size_t i = 0;
  for (PyObject* base : bases) base_tuple[i++] = py::reinterpret_borrow<py::object>(base);
  const std::string qualified = std::string("skidimm.") + name;
  PyObject* cls = PyErr_NewExceptionWithDoc(qualified.c_str(), doc, base_tuple.ptr(), nullptr);
  if (cls == nullptr) throw py::error_already_set();
  m.add_object(name, py::reinterpret_borrow<py::object>(cls));
  return cls;
}

// Raises `cls(message)` with the given attributes set on the instance.
void raise(PyObject* cls, const char* message, const std::vector<std::pair<const char*, py::object>>& attributes) {
  py::object instance = py::reinterpret_borrow<py::object>(cls)(py::str(message));
  for (const auto& [name, value] : attributes) instance.attr(name) = value;
  PyErr_SetObject(cls, instance.ptr());
}

// Sets the Python error for the skidimm error `p`, with `extra` attributes
// besides the class's own; false if `p` is not one of skidimm's.
bool set_error(std::exception_ptr p, std::initializer_list<std::pair<const char*, py::object>> extra) {
  const auto with = [&](std::initializer_list<std::pair<const char*, py::object>> own) {
    std::vector<std::pair<const char*, py::object>> all(own);
    all.insert(all.end(), extra.begin(), extra.end());
    return all;
  };
  try {
    if (p) std::rethrow_exception(p);
  } catch (const PythonModelRaised& e) {
    e.restore();  // the model's own exception, as it raised it
  } catch (const ConfigError& e) {
    raise(config_error_class, e.what(),
          with({{"file", py::str(e.file())}, {"line", py::int_(e.line())}, {"field", py::str(e.field())}}));
  } catch (const LogError& e) {
    raise(log_error_class, e.what(), with({{"file", py::str(e.file())}, {"line", py::int_(e.line())}}));
  } catch (const PluginError& e) {
    raise(plugin_error_class, e.what(), with({}));
  } catch (const fitting::FitError& e) {
    raise(fit_error_class, e.what(), with({}));
  } catch (const Error& e) {
    raise(error_class, e.what(), with({}));
  } catch (const ExpressionError& e) {
    raise(config_error_class, e.what(), with({{"file", py::str("")}, {"line", py::int_(0)}, {"field", py::str("")}}));
  } catch (...) {
    return false;
  }
  return true;
}

}  // namespace

void raise_with(std::exception_ptr p, const char* name, py::object value) {
  if (set_error(p, {{name, std::move(value)}})) throw py::error_already_set();
  std::rethrow_exception(p);
}

void register_errors(py::module_& m) {
  error_class = new_class(m, "Error", {PyExc_RuntimeError}, "Base of every skidimm error.");
  config_error_class = new_class(m, "ConfigError", {error_class, PyExc_ValueError},
                                 "A bank or scenario file is malformed or inconsistent: "
                                 "'<file>:<line>: <field>: <message>', with .file, .line and .field.");
  log_error_class = new_class(m, "LogError", {error_class, PyExc_ValueError},
                              "A log (CSV) or an array given as a log is malformed: '<file>:<line>: <message>', "
                              "with .file and .line.");
  plugin_error_class =
      new_class(m, "PluginError", {error_class}, "A plugin could not be found, loaded or instantiated.");
  fit_error_class = new_class(m, "FitError", {error_class},
                              "The logs cannot determine the parameters (too short, not exciting them...).");

  py::register_exception_translator([](std::exception_ptr p) {
    // Not one of skidimm's: pybind11's own translators take it.
    if (!set_error(p, {})) std::rethrow_exception(p);
  });
}

}  // namespace python
}  // namespace skidimm
