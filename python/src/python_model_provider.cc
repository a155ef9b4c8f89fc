#include "python_model_provider.h"

#include <pybind11/stl.h>

#include <memory>

#include "plugin_location.h"
#include "python_model.h"
#include "skidimm/engine/plugin_registry.h"
#include "skidimm/errors.h"

namespace skidimm {
namespace python {

namespace py = pybind11;
namespace fs = std::filesystem;

bool PythonModelProvider::provides(const std::string& model) const { return models_.count(model) != 0; }

std::vector<std::string> PythonModelProvider::shared_parameter_keys(const std::string& model) const {
  py::gil_scoped_acquire gil;
  const py::object& cls = models_.at(model);
  std::vector<std::string> keys;
  if (!py::hasattr(cls, "shared_parameters") || cls.attr("shared_parameters").is_none()) return keys;
  for (const py::handle item : cls.attr("shared_parameters")) keys.push_back(py::str(item));
  return keys;
}

ModelHandle PythonModelProvider::create(const std::string& model, const sdk::ParameterSet& params) const {
  py::gil_scoped_acquire gil;
  try {
    return std::make_shared<PythonMotionModel>(models_.at(model), model, params, params.bank_states(),
                                               params.bank_angles(), params.bank_inputs());
  } catch (py::error_already_set& e) {
    throw PluginError("the Python model raised " + std::string(e.what()));
  }
}

ModelSource PythonModelProvider::source(const std::string& model) const {
  py::gil_scoped_acquire gil;
  ModelSource source;
  source.plugin = model;
  source.origin = "Python model";
  try {
    source.file = py::module_::import("inspect").attr("getfile")(models_.at(model)).cast<std::string>();
  } catch (py::error_already_set&) {  // a class defined where no file is (the interpreter's prompt)
  }
  return source;
}

std::string PythonModelProvider::describe() const {
  std::string names;
  for (const auto& [name, cls] : models_) names += (names.empty() ? "" : ", ") + name;
  return "nor a Python model: registered are [" + names + "]";
}

Bank load_bank(const fs::path& file, const std::vector<fs::path>& plugin_paths, const PythonModels& models) {
  const PythonModelProvider provider(models);
  py::gil_scoped_release release;
  BankConfig config = load_bank_config(file);
  PluginRegistry registry(plugin_search_path(plugin_paths, config.plugin_paths));
  return Bank::instantiate(std::move(config), registry, &provider);
}

}  // namespace python
}  // namespace skidimm
