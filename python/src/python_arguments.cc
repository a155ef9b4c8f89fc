#include "python_arguments.h"

#include <pybind11/stl.h>

#include <filesystem>

#include "skidimm/config/run_overrides.h"
#include "skidimm/errors.h"

namespace skidimm {
namespace python {

namespace py = pybind11;
namespace fs = std::filesystem;

DecisionConfig decision_of(const BankConfig& config, const py::object& given) {
  RunOverrides overrides;
  if (!given.is_none()) {
    for (const auto& [key, value] : given.cast<py::dict>()) {
      const std::string k = key.cast<std::string>();
      if (k == "enter") {
        overrides.decision_enter = value.cast<double>();
      } else if (k == "leave") {
        overrides.decision_leave = value.cast<double>();
      } else if (k == "min_hold") {
        overrides.decision_hold = value.cast<double>();
      } else if (k == "stale_after") {
        overrides.decision_stale = value.cast<double>();
      } else {
        throw py::key_error("decision: unknown key '" + k + "' (expected enter, leave, min_hold, stale_after)");
      }
    }
  }
  return decision_settings_of(config.decision, overrides);
}

py::dict log_spec_to_dict(const LogSpec& spec) {
  py::dict d;
  d["label"] = spec.label;
  py::list files;
  for (const LogFile& f : spec.files) files.append(py::make_tuple(f.path.string(), f.time_offset));
  d["files"] = files;
  d["text"] = spec.text;
  d["name"] = spec.name();
  return d;
}

LogArgumentOptions unpaired_runs(bool skip, std::vector<std::string>* skipped) {
  LogArgumentOptions options;
  options.skip_unpaired = skip;
  options.skipped = [skipped](const std::string& message) { skipped->push_back(message); };
  return options;
}

std::vector<std::filesystem::path> existing_plugin_paths(const std::vector<std::filesystem::path>& paths) {
  for (const std::filesystem::path& path : paths) {
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) {
      throw Error("plugin_paths: '" + path.string() + "': no such directory or plugin file");
    }
  }
  return paths;
}

void warn_skipped(const std::vector<std::string>& skipped) {
  for (const std::string& message : skipped) py::module_::import("warnings").attr("warn")(message);
}

LogSpec log_spec_of(const py::object& log) {
  if (py::isinstance<py::str>(log) || py::isinstance(log, py::module_::import("os").attr("PathLike"))) {
    return parse_log_spec(py::str(log));
  }
  const py::dict d = log.cast<py::dict>();
  LogSpec spec;
  spec.label = d["label"].cast<std::string>();
  for (const py::handle f : d["files"]) {
    const py::tuple t = py::reinterpret_borrow<py::tuple>(f);
    spec.files.emplace_back(fs::path(t[0].cast<std::string>()), t[1].cast<double>());
  }
  spec.text = d["text"].cast<std::string>();
  return spec;
}

}  // namespace python
}  // namespace skidimm
