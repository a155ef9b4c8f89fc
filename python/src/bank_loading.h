// Loading a bank from Python: its plugins found as the CLI finds them
// (plugin_location.h), and modes whose `model:` names a Python class
// (python_model.h) created from that class instead of a plugin.
#ifndef SKIDIMM_PYTHON_BANK_LOADING_H_
#define SKIDIMM_PYTHON_BANK_LOADING_H_

#include <pybind11/pybind11.h>

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "skidimm/bank.h"

namespace skidimm {
namespace python {

// Python model classes by the name a bank's `model:` gives.
using PythonModels = std::map<std::string, pybind11::object>;

// Loads `file` (GIL held: Python models are instantiated here). A bank with
// no Python mode is loaded by the library's Bank::instantiate itself; with
// some, every mode is made and checked as Bank::instantiate does (names,
// angles, inputs against the bank; shared parameters: a Python class takes
// the keys in its `shared_parameters`). Throws ConfigError with file, line
// and field, like the library.
Bank load_bank(const std::filesystem::path& file, const std::vector<std::filesystem::path>& plugin_paths,
               const PythonModels& python_models);

}  // namespace python
}  // namespace skidimm

#endif  // SKIDIMM_PYTHON_BANK_LOADING_H_
