#include "run_columns.h"

#include <string>
#include <utility>

#include "numpy_values.h"
#include "skidimm/engine/decision.h"

namespace skidimm {
namespace python {

namespace py = pybind11;

namespace {

// Takes `count` references to `object` at once, for the array entries that
// were pointed at it (the increments fold into one addition).
void add_references(PyObject* object, py::ssize_t count) {
  for (py::ssize_t r = 0; r < count; ++r) Py_INCREF(object);
}

// names[codes[k] + offset] for the n rows, as a numpy object array of str:
// one str object per name, its references taken once per name, not per row.
template <typename Code>
py::array text_column(const Code* codes, py::ssize_t n, const std::vector<std::string>& names, int offset = 0) {
  std::vector<py::str> objects(names.begin(), names.end());
  std::vector<py::ssize_t> uses(names.size(), 0);
  py::array out = object_array(n);
  PyObject** data = static_cast<PyObject**>(out.mutable_data());
  for (py::ssize_t k = 0; k < n; ++k) {
    const auto name = static_cast<std::size_t>(codes[k] + offset);
    data[k] = objects[name].ptr();
    ++uses[name];
  }
  for (std::size_t j = 0; j < objects.size(); ++j) add_references(objects[j].ptr(), uses[j]);
  return out;
}

// The reason column: "" on every row but those in `reasons` (row, text; rows in order).
py::array reason_column(py::ssize_t n, const std::vector<std::pair<long, std::string>>& reasons) {
  const py::str empty("");
  py::ssize_t uses = 0;
  py::array out = object_array(n);
  PyObject** data = static_cast<PyObject**>(out.mutable_data());
  auto next = reasons.begin();
  for (py::ssize_t k = 0; k < n; ++k) {
    if (next != reasons.end() && next->first == k) {
      data[k] = py::str((next++)->second).release().ptr();
    } else {
      data[k] = empty.ptr();
      ++uses;
    }
  }
  add_references(empty.ptr(), uses);
  return out;
}

}  // namespace

RunArrays::RunArrays(const BankConfig& config, long rows) : t(rows), mode(rows), decision(rows), status(rows) {
  for (int j = 0; j < config.num_modes(); ++j) mu.emplace_back(rows);
  if (config.unknown.enabled()) unknown.emplace_back(rows);
  for (int i = 0; i < config.state_dim(); ++i) {
    state.emplace_back(rows);
    var.emplace_back(rows);
  }
  columns.t = t.mutable_data();
  for (auto& c : mu) columns.mu.push_back(c.mutable_data());
  if (!unknown.empty()) columns.unknown = unknown[0].mutable_data();
  for (auto& c : state) columns.state.push_back(c.mutable_data());
  for (auto& c : var) columns.var.push_back(c.mutable_data());
  columns.mode = mode.mutable_data();
  columns.decision = decision.mutable_data();
  columns.status = status.mutable_data();
}

RunArrays::RunArrays(GrowingRunColumns&& grown)
    : t(adopt(std::move(grown.t))),
      mode(adopt(std::move(grown.mode))),
      decision(adopt(std::move(grown.decision))),
      status(adopt(std::move(grown.status))) {
  for (auto& c : grown.mu) mu.push_back(adopt(std::move(c)));
  for (auto& c : grown.unknown) unknown.push_back(adopt(std::move(c)));
  for (auto& c : grown.state) state.push_back(adopt(std::move(c)));
  for (auto& c : grown.var) var.push_back(adopt(std::move(c)));
  columns.reasons = std::move(grown.columns().reasons);
}

py::dict columns_to_dict(RunArrays&& c, const BankConfig& config, const py::object& truth) {
  py::dict out;
  const py::ssize_t n = c.rows();
  out["t"] = c.t;
  for (int j = 0; j < config.num_modes(); ++j) {
    out[py::str("mu_" + config.modes[static_cast<std::size_t>(j)].name)] = c.mu[static_cast<std::size_t>(j)];
  }
  if (!c.unknown.empty()) out["unknown_probability"] = c.unknown[0];
  for (int i = 0; i < config.state_dim(); ++i) {
    out[py::str(config.state_names[static_cast<std::size_t>(i)])] = c.state[static_cast<std::size_t>(i)];
  }
  for (int i = 0; i < config.state_dim(); ++i) {
    out[py::str("var_" + config.state_names[static_cast<std::size_t>(i)])] = c.var[static_cast<std::size_t>(i)];
  }
  std::vector<std::string> modes{"unknown"};  // kUnknownMode = -1
  for (const std::string& name : mode_names(config)) modes.push_back(name);
  out["mode"] = text_column(c.mode.data(), n, modes, 1);
  std::vector<std::string> decisions{"unknown"};  // ModeDecision::kUnknown = -1
  const ModeDecision decider(config);
  for (const std::string& name : decider.names()) decisions.push_back(name);
  out["decision"] = text_column(c.decision.data(), n, decisions, 1);
  if (!truth.is_none()) out["truth_mode"] = truth;
  std::vector<std::string> statuses;
  for (StepStatus s :
       {StepStatus::kUpdated, StepStatus::kPredictOnly, StepStatus::kAllModesRejected, StepStatus::kRejectedTime,
        StepStatus::kRejectedInput, StepStatus::kGated, StepStatus::kModeGated, StepStatus::kModeReset}) {
    statuses.emplace_back(to_string(s));
  }
  out["status"] = text_column(c.status.data(), n, statuses);
  out["reason"] = reason_column(n, c.columns.reasons);
  return out;
}

}  // namespace python
}  // namespace skidimm
