#include "bank_loading.h"

#include <pybind11/stl.h>

#include <set>

#include "plugin_location.h"
#include "python_model.h"
#include "skidimm/errors.h"
#include "skidimm/plugin_registry.h"

namespace skidimm {
namespace python {

namespace py = pybind11;
namespace fs = std::filesystem;

namespace {

std::string join(const std::vector<std::string>& items) {
  std::string out;
  for (const std::string& s : items) out += (out.empty() ? "" : ", ") + s;
  return out;
}

std::vector<std::string> keys_of(const py::object& cls, const char* attribute) {
  std::vector<std::string> out;
  if (!py::hasattr(cls, attribute) || cls.attr(attribute).is_none()) return out;
  for (const py::handle item : cls.attr(attribute)) out.push_back(py::str(item));
  return out;
}

}  // namespace

// The checks and the parameter merging below are those of Bank::instantiate
// (core/src/bank_loader.cc), which creates models only through a
// PluginRegistry. (A hook there for other model sources would remove this
// copy; see the report of issue 14.)
Bank load_bank(const fs::path& file, const std::vector<fs::path>& plugin_paths, const PythonModels& python_models) {
  BankConfig config = load_bank_config(file);
  PluginRegistry registry(plugin_search_path(plugin_paths, config.plugin_paths));
  bool any_python = false;
  for (const ModeConfig& mode : config.modes) any_python = any_python || python_models.count(mode.model) != 0;
  if (!any_python) {
    py::gil_scoped_release release;  // plugins load without Python
    return Bank::instantiate(std::move(config), registry);
  }

  const std::string file_name = config.file.string();
  Bank bank;
  std::set<std::string> shared_keys_used;
  for (std::size_t i = 0; i < config.modes.size(); ++i) {
    const ModeConfig& mode = config.modes[i];
    const std::string field = "modes[" + std::to_string(i) + "]";
    const std::string who = "mode '" + mode.name + "' (model " + mode.model + ")";
    const auto python = python_models.find(mode.model);

    std::vector<std::string> documented;
    if (python != python_models.end()) {
      documented = keys_of(python->second, "shared_parameters");
    } else {
      try {
        documented = registry.find(mode.model).parameter_keys;
      } catch (const PluginError& e) {
        throw ConfigError(
            file_name, mode.line,
            field + ".model", std::string(e.what()) + " (nor a Python model: registered are " + [&] {
              std::vector<std::string> names;
              for (const auto& [name, cls] : python_models) names.push_back(name);
              return "[" + join(names) + "]";
            }() + ")");
      }
    }
    sdk::ParameterSet params;
    params.set_bank_names(config.state_names, config.angle_mask, config.input_names);
    auto copy = [&params](const sdk::ParameterSet& from, const std::string& key) {
      if (const Eigen::MatrixXd* value = from.find(key)) params.set(key, *value);
      if (const std::vector<std::string>* text = from.find_text(key)) params.set_text(key, *text);
    };
    for (const std::string& key : documented) {
      if (config.shared.contains(key)) {
        copy(config.shared, key);
        shared_keys_used.insert(key);
      }
    }
    for (const std::string& key : mode.params.keys()) copy(mode.params, key);

    ModelHandle model;
    if (python != python_models.end()) {
      try {
        model = std::make_shared<PythonMotionModel>(python->second, mode.model, params, config.state_names,
                                                    config.angle_mask, config.input_names);
      } catch (py::error_already_set& e) {
        throw ConfigError(file_name, mode.line, field + ".params", who + ": the Python model raised " + e.what());
      } catch (const Error& e) {
        throw ConfigError(file_name, mode.line, field + ".model", who + ": " + e.what());
      }
    } else {
      try {
        model = registry.create(mode.model, params);
      } catch (const PluginError& e) {
        throw ConfigError(file_name, mode.line, field + ".params", who + ": " + e.what());
      }
    }
    for (const sdk::ParameterInfo& info : model->parameter_info()) {
      if (info.scope == sdk::ParameterScope::kBank && mode.params.contains(info.key)) {
        const auto line = mode.param_lines.find(info.key);
        throw ConfigError(file_name, line == mode.param_lines.end() ? mode.line : line->second,
                          field + ".params." + info.key,
                          "'" + info.key + "' is one value for the whole bank in model " + mode.model +
                              ": give it once under 'shared:', not per mode");
      }
    }
    if (model->state_dim() != config.state_dim() || model->state_names() != config.state_names) {
      throw ConfigError(file_name, mode.line, field + ".model",
                        who + " has states [" + join(model->state_names()) + "] but the bank declares [" +
                            join(config.state_names) + "]");
    }
    for (int s = 0; s < config.state_dim(); ++s) {
      if (model->is_angle(s) != config.angle_mask[s]) {
        throw ConfigError(file_name, mode.line, field + ".model",
                          who + ": state '" + config.state_names[s] + "' is " + (model->is_angle(s) ? "" : "not ") +
                              "an angle in the model but " + (config.angle_mask[s] ? "" : "not ") +
                              "listed under 'angles:' in the bank");
      }
    }
    if (model->input_dim() != config.input_dim() || model->input_names() != config.input_names) {
      throw ConfigError(file_name, mode.line, field + ".model",
                        who + " takes inputs [" + join(model->input_names()) + "] but the bank declares [" +
                            join(config.input_names) + "]");
    }
    bank.models.push_back(std::move(model));
  }
  for (const std::string& key : config.shared.keys()) {
    if (shared_keys_used.count(key) == 0) {
      throw ConfigError(file_name, config.shared_lines[key], "shared." + key,
                        "not a parameter of any mode's model (a typo?)");
    }
  }
  bank.config = std::move(config);
  return bank;
}

}  // namespace python
}  // namespace skidimm
