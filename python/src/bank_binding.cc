// Bank: a bank file loaded with its plugins (or Python models), and the
// plugin search path and listing (`skidimm plugins`).
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <Eigen/Core>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "array_run.h"
#include "bindings.h"
#include "plugin_location.h"
#include "py_bank.h"
#include "python_arguments.h"
#include "python_model_provider.h"
#include "skidimm/config/bank.h"
#include "skidimm/engine/decision.h"
#include "skidimm/engine/plugin_registry.h"

namespace skidimm {
namespace python {

namespace py = pybind11;
namespace fs = std::filesystem;

namespace {

PyBank load(const fs::path& file, const std::vector<fs::path>& plugin_paths, const py::object& models) {
  PythonModels python_models;
  if (!models.is_none()) {
    for (const auto& [name, cls] : models.cast<py::dict>()) {
      python_models[name.cast<std::string>()] = py::reinterpret_borrow<py::object>(cls);
    }
  }
  PyBank b;
  b.bank = std::make_shared<Bank>(load_bank(file, plugin_paths, python_models));
  b.file = file;
  b.plugin_paths = plugin_paths;
  b.models = python_models;
  return b;
}

}  // namespace

void bind_bank(py::module_& m) {
  m.def(
      "module_plugin_directory", [] { return module_plugin_directory(); },
      "The bundled plugins' directory next to this module (build tree or install).");
  m.def("plugin_search_path", &plugin_search_path, py::arg("plugin_paths") = std::vector<fs::path>{},
        py::arg("bank_paths") = std::vector<fs::path>{},
        "The search path a bank's plugins are looked up on (the paths as given, whether they exist or not).");
  m.def(
      "plugins",
      [](const std::vector<fs::path>& plugin_paths) {
        PluginRegistry registry(plugin_search_path(existing_plugin_paths(plugin_paths), {}));
        py::list out;
        for (const PluginDescriptor& d : registry.plugins()) {
          py::dict p;
          p["name"] = d.name;
          p["path"] = d.path.string();
          p["version"] = d.version;
          p["description"] = d.description;
          p["parameters"] = d.parameter_docs;
          p["error"] = d.error;
          p["shadowed"] = d.shadowed;
          out.append(p);
        }
        return out;
      },
      py::arg("plugin_paths") = std::vector<fs::path>{},
      "Every plugin library on the search path (`skidimm plugins`).");

  py::class_<PyBank>(m, "Bank", "A bank file's configuration and its modes' models (bank.h).")
      .def(py::init(&load), py::arg("file"), py::arg("plugin_paths") = std::vector<fs::path>{},
           py::arg("models") = py::none(),
           "Loads a bank and its plugins. `models` maps model names to Python model classes "
           "(skidimm.MotionModel subclasses) for modes whose `model:` names them.")
      .def_property_readonly("file", [](const PyBank& b) { return b.config().file; })
      .def_property_readonly("plugin_paths", [](const PyBank& b) { return b.plugin_paths; })
      .def_property_readonly("python_models", [](const PyBank& b) { return b.models; })
      .def_property_readonly("name", [](const PyBank& b) { return b.config().name; })
      .def_property_readonly("description", [](const PyBank& b) { return b.config().description; })
      .def_property_readonly("states", [](const PyBank& b) { return b.config().state_names; })
      .def_property_readonly("angles",
                             [](const PyBank& b) {
                               std::vector<std::string> out;
                               for (int s = 0; s < b.config().state_dim(); ++s) {
                                 if (b.config().angle_mask[static_cast<std::size_t>(s)]) {
                                   out.push_back(b.config().state_names[static_cast<std::size_t>(s)]);
                                 }
                               }
                               return out;
                             })
      .def_property_readonly("inputs", [](const PyBank& b) { return b.config().input_names; })
      .def_property_readonly("measurements", [](const PyBank& b) { return b.config().measurement.names; })
      .def_property_readonly("modes", [](const PyBank& b) { return mode_names(b.config()); })
      .def_property_readonly("models",
                             [](const PyBank& b) {
                               std::vector<std::string> out;
                               for (const ModeConfig& mode : b.config().modes) out.push_back(mode.model);
                               return out;
                             })
      .def_property_readonly("classes", [](const PyBank& b) { return b.config().class_names(); })
      .def_property_readonly("model_sources",
                             [](const PyBank& b) {
                               std::vector<std::string> out;
                               for (const ModelSource& source : b.bank->model_sources) {
                                 out.push_back(source.describe());
                               }
                               return out;
                             })
      .def_property_readonly("columns",
                             [](const PyBank& b) {
                               py::dict d;
                               d["time"] = b.config().columns.time;
                               d["time_units_per_second"] = b.config().columns.time_units_per_second;
                               d["inputs"] = b.config().columns.inputs;
                               d["measurements"] = b.config().columns.measurements;
                               d["truth_mode"] = b.config().columns.truth_mode;
                               return d;
                             })
      .def_property_readonly("sampling_rate", [](const PyBank& b) { return b.config().sampling.rate; })
      .def_property_readonly("decision",
                             [](const PyBank& b) {
                               py::dict d;
                               d["enter"] = b.config().decision.enter;
                               d["leave"] = b.config().decision.leave;
                               d["min_hold"] = b.config().decision.min_hold;
                               d["stale_after"] = ModeDecision(b.config()).stale_after();  // the default resolved
                               return d;
                             })
      .def(
          "parameters",
          [](const PyBank& b, const std::string& mode) {
            const int j = b.config().mode_index(mode);
            if (j < 0) throw py::key_error("no mode '" + mode + "' in bank '" + b.config().name + "'");
            const sdk::MotionModel& model = *b.bank->models[static_cast<std::size_t>(j)];
            Eigen::VectorXd values(static_cast<Eigen::Index>(model.parameter_info().size()));
            model.get_parameters(values);
            py::dict out;
            for (std::size_t i = 0; i < model.parameter_info().size(); ++i) {
              out[py::str(model.parameter_info()[i].name)] = values[static_cast<Eigen::Index>(i)];
            }
            return out;
          },
          py::arg("mode"), "A mode's model parameters by flat name ('A[0,1]', 'k').")
      .def("__repr__", [](const PyBank& b) {
        return "<skidimm.Bank '" + b.config().name + "' from " + b.config().file.string() + ": " +
               std::to_string(b.config().num_modes()) + " modes>";
      });
}

}  // namespace python
}  // namespace skidimm
