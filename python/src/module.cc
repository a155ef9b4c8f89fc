// The extension module skidimm._skidimm. The public API is the package
// skidimm (python/skidimm/__init__.py), which re-exports these and adds the
// pandas conveniences; docs/python.md is its guide.
//
// Every function that runs C++ for long (loading plugins, steps, runs,
// evaluation, fitting, simulation) releases the GIL; Python motion models
// take it back for each of their calls (python_model.h). Array sizes are
// checked here, before the engine's own checks (which abort) can see them.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <mutex>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "array_run.h"
#include "csv_columns.h"
#include "errors.h"
#include "log_result_codec.h"
#include "plugin_location.h"
#include "python_model.h"
#include "python_model_provider.h"
#include "skidimm/decision.h"
#include "skidimm/errors.h"
#include "skidimm/evaluation/evaluation_report.h"
#include "skidimm/expression.h"
#include "skidimm/fitting/bank_fit.h"
#include "skidimm/fitting/fit_logs.h"
#include "skidimm/fitting/fit_output.h"
#include "skidimm/imm.h"
#include "skidimm/log_arguments.h"
#include "skidimm/log_reader.h"
#include "skidimm/log_run.h"
#include "skidimm/plugin_registry.h"
#include "skidimm/progress.h"
#include "skidimm/run_overrides.h"
#include "skidimm/simulation/model_simulation.h"
#include "skidimm/simulation/scenario.h"

namespace py = pybind11;
namespace fs = std::filesystem;

namespace skidimm {
namespace python {

namespace {

using DoubleArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

// ------------------------------------------------------------------ values

// A C++ vector handed to numpy without a copy: the array owns the vector.
template <typename T>
py::array_t<T> adopt(std::vector<T>&& values) {
  auto* owner = new std::vector<T>(std::move(values));
  py::capsule free_when_done(owner, [](void* p) { delete static_cast<std::vector<T>*>(p); });
  return py::array_t<T>(static_cast<py::ssize_t>(owner->size()), owner->data(), free_when_done);
}

py::array_t<double> vector_array(const Eigen::VectorXd& v) {
  py::array_t<double> a(v.size());
  std::copy(v.data(), v.data() + v.size(), a.mutable_data());
  return a;
}

py::array_t<double> matrix_array(const Eigen::MatrixXd& m) {
  py::array_t<double> a({m.rows(), m.cols()});
  auto r = a.mutable_unchecked<2>();
  for (Eigen::Index i = 0; i < m.rows(); ++i) {
    for (Eigen::Index j = 0; j < m.cols(); ++j) r(i, j) = m(i, j);
  }
  return a;
}

// A numpy object array of n entries, every one NULL (numpy zero-fills the
// memory of object arrays it allocates) until the caller sets it.
py::array object_array(py::ssize_t n) { return py::array(py::dtype("O"), std::vector<py::ssize_t>{n}); }

// A numpy object array of str.
py::array text_array(const std::vector<std::string>& values) {
  py::array out = object_array(static_cast<py::ssize_t>(values.size()));
  PyObject** data = static_cast<PyObject**>(out.mutable_data());
  for (std::size_t k = 0; k < values.size(); ++k) data[k] = py::str(values[k]).release().ptr();
  return out;
}

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

std::vector<std::string> mode_names(const BankConfig& config) {
  std::vector<std::string> names;
  for (const ModeConfig& m : config.modes) names.push_back(m.name);
  return names;
}

// A run's columns as numpy arrays, and where the run writes them
// (`columns`: into these arrays). Made for a known number of rows before the
// run (Imm.run), or from a log run's grown vectors without a copy.
struct RunArrays {
  py::array_t<double> t;
  std::vector<py::array_t<double>> mu, state, var;
  py::array_t<std::int32_t> mode, decision;
  py::array_t<std::int8_t> status;
  RunColumns columns;

  RunArrays(const BankConfig& config, long rows) : t(rows), mode(rows), decision(rows), status(rows) {
    for (int j = 0; j < config.num_modes(); ++j) mu.emplace_back(rows);
    for (int i = 0; i < config.state_dim(); ++i) {
      state.emplace_back(rows);
      var.emplace_back(rows);
    }
    columns.t = t.mutable_data();
    for (auto& c : mu) columns.mu.push_back(c.mutable_data());
    for (auto& c : state) columns.state.push_back(c.mutable_data());
    for (auto& c : var) columns.var.push_back(c.mutable_data());
    columns.mode = mode.mutable_data();
    columns.decision = decision.mutable_data();
    columns.status = status.mutable_data();
  }

  explicit RunArrays(GrowingRunColumns&& grown)
      : t(adopt(std::move(grown.t))),
        mode(adopt(std::move(grown.mode))),
        decision(adopt(std::move(grown.decision))),
        status(adopt(std::move(grown.status))) {
    for (auto& c : grown.mu) mu.push_back(adopt(std::move(c)));
    for (auto& c : grown.state) state.push_back(adopt(std::move(c)));
    for (auto& c : grown.var) var.push_back(adopt(std::move(c)));
    columns.reasons = std::move(grown.columns().reasons);
  }

  py::ssize_t rows() const { return t.shape(0); }
};

// The columns `skidimm run` writes, in its order; `truth` (an object array
// of str, or None) is the truth_mode column.
py::dict columns_to_dict(RunArrays&& c, const BankConfig& config, const py::object& truth) {
  py::dict out;
  const py::ssize_t n = c.rows();
  out["t"] = c.t;
  for (int j = 0; j < config.num_modes(); ++j) {
    out[py::str("mu_" + config.modes[static_cast<std::size_t>(j)].name)] = c.mu[static_cast<std::size_t>(j)];
  }
  for (int i = 0; i < config.state_dim(); ++i) {
    out[py::str(config.state_names[static_cast<std::size_t>(i)])] = c.state[static_cast<std::size_t>(i)];
  }
  for (int i = 0; i < config.state_dim(); ++i) {
    out[py::str("var_" + config.state_names[static_cast<std::size_t>(i)])] = c.var[static_cast<std::size_t>(i)];
  }
  out["mode"] = text_column(c.mode.data(), n, mode_names(config));
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

// The bank's decision settings with those of a `decision=` dict ({"enter":
// 0.9, "leave": 0.05, "min_hold": 1.0}, any of them), checked.
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
      } else {
        throw py::key_error("decision: unknown key '" + k + "' (expected enter, leave, min_hold)");
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

// Log arguments' patterns skip runs some of their files lack when `skip`,
// noting each in *skipped (from whichever thread expands them; no GIL needed).
LogArgumentOptions unpaired_runs(bool skip, std::vector<std::string>* skipped) {
  LogArgumentOptions options;
  options.skip_unpaired = skip;
  options.skipped = [skipped](const std::string& message) { skipped->push_back(message); };
  return options;
}

// The runs a pattern left out, as Python warnings (GIL held).
void warn_skipped(const std::vector<std::string>& skipped) {
  for (const std::string& message : skipped) py::module_::import("warnings").attr("warn")(message);
}

// A log given as text ("[LABEL=]FILE[@OFFSET][+...]") or as a dict from expand_log_argument.
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

// ------------------------------------------------------------------ Bank

struct PyBank {
  std::shared_ptr<Bank> bank;
  fs::path file;
  std::vector<fs::path> plugin_paths;
  PythonModels models;

  const BankConfig& config() const { return bank->config; }
};

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

// ------------------------------------------------------------------ Imm

struct Estimate {
  double t = 0.0;
  std::string status;
  int num_measured = 0;
  int num_rejected_modes = 0;
  py::array_t<double> mode_probabilities, log_likelihoods, nis, state, covariance, mode_states, mode_covariances;
  int most_likely_mode = 0;
  std::string mode;
  std::string decision;
};

struct PyImm {
  PyBank bank;
  std::unique_ptr<Imm> imm;
  std::unique_ptr<ModeDecision> decision;
  int last_decision = ModeDecision::kUnknown;
  // The engine's Imm is used by one thread at a time (imm.h): step, run and
  // reset hold this, so calls from several Python threads take turns
  // (ImmInUse) instead of mixing one filter's state into NaN.
  std::mutex in_use;
  std::atomic<std::thread::id> user{};

  PyImm(PyBank b, const std::string& kernel, const py::object& decision_settings) : bank(std::move(b)) {
    if (kernel != "fastest" && kernel != "dynamic") throw py::value_error("kernel must be 'fastest' or 'dynamic'");
    imm =
        std::make_unique<Imm>(*bank.bank, kernel == "dynamic" ? ImmKernelChoice::kDynamic : ImmKernelChoice::kFastest);
    decision = std::make_unique<ModeDecision>(bank.config(), decision_of(bank.config(), decision_settings));
  }
  const BankConfig& config() const { return imm->config(); }
  int input_dim() const { return config().input_dim(); }
  int measurement_dim() const { return static_cast<int>(config().measurement.h.rows()); }
};

// Holds an Imm for one call. Another thread's call waits for it, with the
// GIL released (the running call's Python models need it). A call from the
// thread already using it (a Python model of this Imm stepping it) would
// wait for itself: it is a RuntimeError instead.
class ImmInUse {
 public:
  explicit ImmInUse(PyImm& imm) : imm_(imm) {
    if (imm.user.load() == std::this_thread::get_id()) {
      throw std::runtime_error(
          "this Imm is already running a step on this thread (a model of the Imm called it back): an Imm runs one "
          "step at a time; make another Imm for a nested run");
    }
    if (!imm.in_use.try_lock()) {
      py::gil_scoped_release release;
      imm.in_use.lock();
    }
    imm.user.store(std::this_thread::get_id());
  }
  ~ImmInUse() {
    imm_.user.store(std::thread::id());
    imm_.in_use.unlock();
  }
  ImmInUse(const ImmInUse&) = delete;
  ImmInUse& operator=(const ImmInUse&) = delete;

 private:
  PyImm& imm_;
};

// `a` as n rows of `width` (a 1-D array is one column when width is 1, or
// one row when n is 1). Throws ValueError naming `what`.
DoubleArray rows_of(const py::object& a, long n, int width, const char* what) {
  if (a.is_none()) {
    if (width == 0) return DoubleArray(std::vector<py::ssize_t>{static_cast<py::ssize_t>(n), 0});
    throw py::value_error(std::string(what) + " is required (" + std::to_string(width) + " columns)");
  }
  DoubleArray arr = DoubleArray::ensure(a);
  if (!arr) throw py::value_error(std::string(what) + ": expected an array of numbers");
  const bool fits = (arr.ndim() == 2 && arr.shape(0) == n && arr.shape(1) == width) ||
                    (arr.ndim() == 1 && width == 1 && arr.shape(0) == n) ||
                    (arr.ndim() == 1 && n == 1 && arr.shape(0) == width) || (width == 0 && arr.size() == 0);
  if (!fits) {
    std::string shape;
    for (py::ssize_t d = 0; d < arr.ndim(); ++d) shape += (d ? ", " : "") + std::to_string(arr.shape(d));
    throw py::value_error(std::string(what) + ": expected shape (" + std::to_string(n) + ", " + std::to_string(width) +
                          "), got (" + shape + ")");
  }
  return arr;
}

Estimate make_estimate(const PyImm& self, const ImmEstimate& e, int decided) {
  Estimate out;
  out.t = e.t;
  out.status = to_string(e.status);
  out.num_measured = e.num_measured;
  out.num_rejected_modes = e.num_rejected_modes;
  out.mode_probabilities = vector_array(e.mode_probabilities);
  out.log_likelihoods = vector_array(e.log_likelihoods);
  out.nis = vector_array(e.nis);
  out.state = vector_array(e.state);
  out.covariance = matrix_array(e.covariance);
  const auto modes = static_cast<py::ssize_t>(e.mode_states.size());
  const auto n = static_cast<py::ssize_t>(e.state.size());
  out.mode_states = py::array_t<double>({modes, n});
  out.mode_covariances = py::array_t<double>({modes, n, n});
  auto s = out.mode_states.mutable_unchecked<2>();
  auto c = out.mode_covariances.mutable_unchecked<3>();
  for (py::ssize_t j = 0; j < modes; ++j) {
    for (py::ssize_t a = 0; a < n; ++a) {
      s(j, a) = e.mode_states[static_cast<std::size_t>(j)][a];
      for (py::ssize_t b = 0; b < n; ++b) c(j, a, b) = e.mode_covariances[static_cast<std::size_t>(j)](a, b);
    }
  }
  out.most_likely_mode = e.most_likely_mode;
  out.mode = self.config().modes[static_cast<std::size_t>(e.most_likely_mode)].name;
  out.decision = self.decision->name(decided);
  return out;
}

Estimate step(PyImm& self, double t, const py::object& u, const py::object& z) {
  const DoubleArray uu = rows_of(u, 1, self.input_dim(), "u");
  const DoubleArray zz = rows_of(z, 1, self.measurement_dim(), "z");
  const ImmInUse hold(self);
  clear_python_model_error();
  int decided = ModeDecision::kUnknown;
  const ImmEstimate* e = nullptr;
  {
    py::gil_scoped_release release;
    e = &self.imm->step(t, Eigen::Map<const Eigen::VectorXd>(uu.data(), self.input_dim()),
                        Eigen::Map<const Eigen::VectorXd>(zz.data(), self.measurement_dim()));
    decided = self.decision->update(t, e->mode_probabilities);
  }
  throw_if_python_model_raised();
  return make_estimate(self, *e, decided);
}

py::dict run(PyImm& self, const py::object& t, const py::object& u, const py::object& z, bool smooth,
             std::optional<double> lag, const py::object& truth, bool reset) {
  const DoubleArray tt = DoubleArray::ensure(t);
  if (!tt || tt.ndim() != 1) throw py::value_error("t: expected a 1-D array of times (s)");
  const long n = static_cast<long>(tt.shape(0));
  const DoubleArray uu = rows_of(u, n, self.input_dim(), "u");
  const DoubleArray zz = rows_of(z, n, self.measurement_dim(), "z");
  const EstimatorOptions estimator = estimator_options(smooth, lag);
  py::object truth_column = py::none();
  if (!truth.is_none()) {
    std::vector<std::string> labels;
    for (const py::handle item : truth) labels.push_back(py::str(item));
    if (static_cast<long>(labels.size()) != n) throw py::value_error("truth: expected one label per row");
    truth_column = text_array(labels);
  }
  const ImmInUse hold(self);
  if (reset) {
    self.imm->reset();
    self.decision->reset();
  }
  RunArrays columns(self.config(), n);
  ArrayLog log{n, tt.data(), uu.data(), zz.data()};
  clear_python_model_error();
  {
    py::gil_scoped_release release;
    run_arrays(self.imm.get(), log, estimator, self.decision.get(), &columns.columns);
  }
  throw_if_python_model_raised();
  return columns_to_dict(std::move(columns), self.config(), truth_column);
}

// ------------------------------------------------------------------ fit

fitting::BankFitOptions fit_options_of(const std::string& objective, double window, const std::string& loss,
                                       double loss_scale, bool hold_unexcited, bool shared, bool fit_r, bool full_q,
                                       bool output_noise) {
  fitting::BankFitOptions o;
  o.objective = fitting::objective_from_string(objective);
  o.window.window = window;
  o.window.loss = loss;
  o.window.loss_scale = loss_scale;
  o.window.hold_unexcited = hold_unexcited;
  o.shared = shared;
  o.fit_measurement_noise = fit_r;
  o.full_process_noise = full_q;
  o.output_noise = output_noise;
  return o;
}

py::dict report_to_dict(const fitting::FitReport& r) {
  py::dict d;
  py::dict parameters;
  for (const auto& p : r.parameters) parameters[py::str(p.name)] = py::make_tuple(p.value, p.standard_deviation);
  d["parameters"] = parameters;
  d["rmse"] = vector_array(r.rmse);
  d["q"] = matrix_array(r.q_intensity);
  d["warnings"] = r.warnings;
  d["residuals"] = r.residuals;
  d["derivatives"] = r.derivatives;
  d["iterations"] = r.iterations;
  d["initial_cost"] = r.initial_cost;
  d["final_cost"] = r.final_cost;
  d["condition_number"] = r.condition_number;
  return d;
}

fitting::FitReport report_from_dict(const py::dict& d) {
  fitting::FitReport r;
  for (const auto& [name, value] : d["parameters"].cast<py::dict>()) {
    const py::tuple t = py::reinterpret_borrow<py::tuple>(value);
    r.parameters.push_back({name.cast<std::string>(), t[0].cast<double>(), t[1].cast<double>()});
  }
  r.rmse = d["rmse"].cast<Eigen::VectorXd>();
  r.q_intensity = d["q"].cast<Eigen::MatrixXd>();
  r.warnings = d["warnings"].cast<std::vector<std::string>>();
  r.residuals = d["residuals"].cast<int>();
  r.derivatives = d["derivatives"].cast<std::string>();
  r.iterations = d["iterations"].cast<int>();
  r.initial_cost = d["initial_cost"].cast<double>();
  r.final_cost = d["final_cost"].cast<double>();
  r.condition_number = d["condition_number"].cast<double>();
  return r;
}

py::dict trajectory_to_dict(const fitting::Trajectory& t) {
  py::dict d;
  d["source"] = t.source;
  d["log"] = t.log;
  d["t"] = py::array_t<double>(static_cast<py::ssize_t>(t.t.size()), t.t.data());
  d["u"] = matrix_array(t.u);
  d["z"] = matrix_array(t.z);
  d["truth"] = t.truth;
  return d;
}

fitting::Trajectory trajectory_from_dict(const py::dict& d) {
  fitting::Trajectory t;
  t.source = d["source"].cast<std::string>();
  t.log = d["log"].cast<std::string>();
  t.t = d["t"].cast<std::vector<double>>();
  t.u = d["u"].cast<Eigen::MatrixXd>();
  t.z = d["z"].cast<Eigen::MatrixXd>();
  t.truth = d["truth"].cast<std::vector<std::string>>();
  return t;
}

py::list mode_logs_to_list(const std::vector<fitting::ModeLogs>& data) {
  py::list out;
  for (const fitting::ModeLogs& d : data) {
    py::list logs;
    for (const fitting::Trajectory& t : d.logs) logs.append(trajectory_to_dict(t));
    out.append(py::make_tuple(d.mode, logs));
  }
  return out;
}

std::vector<fitting::ModeLogs> mode_logs_from_list(const py::list& data) {
  std::vector<fitting::ModeLogs> out;
  for (const py::handle item : data) {
    const py::tuple pair = py::reinterpret_borrow<py::tuple>(item);
    fitting::ModeLogs d;
    d.mode = pair[0].cast<int>();
    for (const py::handle t : pair[1]) d.logs.push_back(trajectory_from_dict(py::reinterpret_borrow<py::dict>(t)));
    out.push_back(std::move(d));
  }
  return out;
}

// Fits `bank` in place to `data`; returns {mode index: {"report", "parameters", "q", "logs"}}.
py::dict fit_in_place(PyBank& bank, const std::vector<fitting::ModeLogs>& data,
                      const fitting::BankFitOptions& options) {
  if (data.empty()) throw Error("no logs given");
  std::map<int, fitting::FitReport> reports;
  clear_python_model_error();
  {
    py::gil_scoped_release release;
    // Each solve's iterations, rate and time so far on stderr, only when it
    // is a terminal (a fit with a Python model can take minutes).
    StagedProgress progress("skidimm.fit", "iterations", true);
    fitting::BankFitOptions with_progress = options;
    if (progress.enabled()) with_progress.progress = std::ref(progress);
    reports = fitting::fit_bank(bank.bank.get(), data, with_progress);
  }
  throw_if_python_model_raised();
  py::dict out;
  for (const fitting::ModeLogs& d : data) {
    const fitting::FitReport& r = reports.at(d.mode);
    const sdk::MotionModel& model = *bank.bank->models[static_cast<std::size_t>(d.mode)];
    Eigen::VectorXd values(static_cast<Eigen::Index>(model.parameter_info().size()));
    model.get_parameters(values);
    py::dict entry;
    entry["report"] = report_to_dict(r);
    entry["parameters"] = vector_array(values);
    entry["q"] = matrix_array(bank.config().modes[static_cast<std::size_t>(d.mode)].q_intensity);
    const Eigen::MatrixXd& own_r = bank.config().modes[static_cast<std::size_t>(d.mode)].r;
    entry["r"] = own_r.size() > 0 ? py::object(matrix_array(own_r)) : py::object(py::none());  // the mode's own, if any
    entry["logs"] = fitting::log_count(d);
    out[py::int_(d.mode)] = entry;
  }
  return out;
}

}  // namespace

}  // namespace python
}  // namespace skidimm

using namespace skidimm;          // NOLINT
using namespace skidimm::python;  // NOLINT

PYBIND11_MODULE(_skidimm, m) {
  m.doc() = "skidimm's C++ engine (see the package skidimm and docs/python.md)";
  m.attr("__version__") = SKIDIMM_VERSION;
  register_errors(m);

  // ---------------------------------------------------------------- plugins
  m.def(
      "module_plugin_directory", [] { return module_plugin_directory(); },
      "The bundled plugins' directory next to this module (build tree or install).");
  m.def("plugin_search_path", &plugin_search_path, py::arg("plugin_paths") = std::vector<fs::path>{},
        py::arg("bank_paths") = std::vector<fs::path>{}, "The search path a bank's plugins are looked up on.");
  m.def(
      "plugins",
      [](const std::vector<fs::path>& plugin_paths) {
        PluginRegistry registry(plugin_search_path(plugin_paths, {}));
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

  // ---------------------------------------------------------------- Bank
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

  // ---------------------------------------------------------------- Imm
  py::class_<Estimate>(m, "Estimate", "What one IMM step produced (imm_estimate.h), as numpy arrays.")
      .def_readonly("t", &Estimate::t)
      .def_readonly("status", &Estimate::status)
      .def_readonly("num_measured", &Estimate::num_measured)
      .def_readonly("num_rejected_modes", &Estimate::num_rejected_modes)
      .def_readonly("mode_probabilities", &Estimate::mode_probabilities)
      .def_readonly("log_likelihoods", &Estimate::log_likelihoods)
      .def_readonly("nis", &Estimate::nis)
      .def_readonly("state", &Estimate::state)
      .def_readonly("covariance", &Estimate::covariance)
      .def_readonly("mode_states", &Estimate::mode_states)
      .def_readonly("mode_covariances", &Estimate::mode_covariances)
      .def_readonly("most_likely_mode", &Estimate::most_likely_mode)
      .def_readonly("mode", &Estimate::mode)
      .def_readonly("decision", &Estimate::decision)
      .def("__repr__", [](const Estimate& e) {
        char buffer[64];
        std::snprintf(buffer, sizeof(buffer), "%.6g", e.t);
        return "<skidimm.Estimate t=" + std::string(buffer) + " mode=" + e.mode + " status=" + e.status + ">";
      });

  py::class_<PyImm>(m, "Imm", "The IMM estimator over a bank (imm.h).")
      .def(py::init<PyBank, const std::string&, const py::object&>(), py::arg("bank"), py::arg("kernel") = "fastest",
           py::arg("decision") = py::none())
      .def_property_readonly("bank", [](const PyImm& self) { return self.bank; })
      .def("step", &step, py::arg("t"), py::arg("u"), py::arg("z"),
           "One filter cycle at time t (s) with inputs u and measurements z (NaN = not measured).")
      .def("_run", &run, py::arg("t"), py::arg("u"), py::arg("z"), py::arg("smooth") = false,
           py::arg("lag") = py::none(), py::arg("truth") = py::none(), py::arg("reset") = true)
      .def("reset",
           [](PyImm& self) {
             const ImmInUse hold(self);
             self.imm->reset();
             self.decision->reset();
           })
      .def_property_readonly("uses_fixed_size_kernel",
                             [](const PyImm& self) { return self.imm->uses_fixed_size_kernel(); })
      .def(
          "_step_loop",
          [](PyImm& self, const py::object& t, const py::object& u, const py::object& z) {
            const DoubleArray tt = DoubleArray::ensure(t);
            if (!tt || tt.ndim() != 1) throw py::value_error("t: expected a 1-D array of times (s)");
            const long n = static_cast<long>(tt.shape(0));
            const DoubleArray uu = rows_of(u, n, self.input_dim(), "u");
            const DoubleArray zz = rows_of(z, n, self.measurement_dim(), "z");
            const ImmInUse hold(self);
            self.imm->reset();
            py::gil_scoped_release release;
            return step_loop(self.imm.get(), ArrayLog{n, tt.data(), uu.data(), zz.data()});
          },
          "The bare C++ loop of Imm::step over the rows (benchmark reference).");

  // ---------------------------------------------------------------- logs
  m.def("parse_log_spec", [](const std::string& text) { return log_spec_to_dict(parse_log_spec(text)); });
  m.def(
      "expand_log_argument",
      [](const std::string& argument, bool skip_unpaired) {
        std::vector<std::string> skipped;
        const std::vector<LogSpec> specs = expand_log_argument(argument, unpaired_runs(skip_unpaired, &skipped));
        warn_skipped(skipped);
        py::list out;
        for (const LogSpec& spec : specs) out.append(log_spec_to_dict(spec));
        return out;
      },
      py::arg("argument"), py::arg("skip_unpaired") = false,
      "The logs one argument stands for, as the CLI expands it (directories, '*' patterns paired by run key; "
      "skip_unpaired: leave out, with a warning, runs some of the pattern's files lack, instead of an error).");
  m.def("group_name", &log_group_name, "A log argument's group name in `skidimm eval`.");
  m.def(
      "run_log",
      [](const PyBank& bank, const std::vector<std::string>& inputs, double rate, bool smooth,
         std::optional<double> lag, const py::object& decision) {
        const LogSpec log = join_log_arguments(inputs);
        const BankConfig& config = bank.config();
        if (!log.label.empty() && config.class_index(log.label) < 0) {
          throw Error(log.text + ": '" + log.label + "' is neither a mode nor a class of bank '" + config.name + "'");
        }
        const EstimatorOptions estimator = estimator_options(smooth, lag);
        const DecisionConfig settings = decision_of(config, decision);
        GrowingRunColumns columns(config);
        std::vector<std::string> truth;
        bool with_truth = false;
        long rows = 0;
        clear_python_model_error();
        {
          py::gil_scoped_release release;
          LogReader reader(config, log.files, sampling_of(config, rate));
          with_truth = reader.has_truth() || !log.label.empty();
          rows = run_log_file(*bank.bank, &reader, estimator, settings, log.label, with_truth, &columns, &truth);
        }
        throw_if_python_model_raised();
        if (rows == 0) {
          throw LogError(log.text, 0, "the log gives no step: no data rows, or no row where every input has a value");
        }
        return columns_to_dict(RunArrays(std::move(columns)), config,
                               with_truth ? py::object(text_array(truth)) : py::object(py::none()));
      },
      py::arg("bank"), py::arg("inputs"), py::arg("rate") = 0.0, py::arg("smooth") = false, py::arg("lag") = py::none(),
      py::arg("decision") = py::none());
  m.def(
      "evaluate_expression",
      [](const std::string& text, const py::dict& columns) {
        Expression expression(text);
        std::vector<DoubleArray> values;
        py::ssize_t n = -1;
        for (const std::string& v : expression.variables()) {
          if (!columns.contains(v)) {
            throw py::key_error("expression '" + Expression::excerpt(text) + "': no column '" + v + "'");
          }
          values.push_back(DoubleArray::ensure(columns[py::str(v)]));
          if (!values.back() || values.back().ndim() != 1) throw py::value_error("column '" + v + "': expected 1-D");
          if (n >= 0 && values.back().shape(0) != n) throw py::value_error("columns of different lengths");
          n = values.back().shape(0);
        }
        if (n < 0) throw py::value_error("expression '" + Expression::excerpt(text) + "' names no column");
        py::array_t<double> out(n);
        double* o = out.mutable_data();
        std::vector<double> row(values.size());
        for (py::ssize_t k = 0; k < n; ++k) {
          for (std::size_t i = 0; i < values.size(); ++i) row[i] = values[i].data()[k];
          o[k] = expression.evaluate(row.data());
        }
        return out;
      },
      py::arg("text"), py::arg("columns"), "A bank column expression evaluated over arrays, row by row.");
  m.def(
      "read_csv",
      [](const fs::path& file) {
        CsvColumns c;
        {
          py::gil_scoped_release release;
          c = read_csv_columns(file);
        }
        py::dict out;
        for (std::size_t i = 0; i < c.names.size(); ++i) {
          if (c.is_text[i]) {
            out[py::str(c.names[i])] = text_array(c.text[i]);
          } else {
            out[py::str(c.names[i])] = adopt(std::move(c.numbers[i]));
          }
        }
        return out;
      },
      py::arg("file"), "A CSV file as numpy columns (numbers exactly as written; text columns as str).");

  // ---------------------------------------------------------------- eval
  py::class_<evaluation::LogResult>(m, "LogResult", "One log's evaluation (log_evaluation.h); picklable.")
      .def_readonly("name", &evaluation::LogResult::name)
      .def_readonly("steps", &evaluation::LogResult::steps)
      .def_property_readonly("accuracy", [](const evaluation::LogResult& r) { return r.metrics.accuracy(); })
      .def_property_readonly("duration", [](const evaluation::LogResult& r) { return r.metrics.duration; })
      .def_property_readonly("main_truth",
                             [](const evaluation::LogResult& r) { return evaluation::main_truth(r.metrics); })
      .def("to_dict", &to_dict)
      .def_static("from_dict", &log_result_from_dict)
      .def(py::pickle([](const evaluation::LogResult& r) { return to_dict(r); },
                      [](const py::dict& d) { return log_result_from_dict(d); }))
      .def("__repr__", [](const evaluation::LogResult& r) {
        return "<skidimm.LogResult '" + r.name + "': " + std::to_string(r.steps) + " steps>";
      });
  m.def(
      "evaluate_log",
      [](const PyBank& bank, const py::object& log, double rate, bool smooth, std::optional<double> lag) {
        const LogSpec spec = log_spec_of(log);
        const EstimatorOptions estimator = estimator_options(smooth, lag);
        evaluation::LogResult result;
        clear_python_model_error();
        {
          py::gil_scoped_release release;
          result = evaluation::evaluate_log(*bank.bank, spec, sampling_of(bank.config(), rate), {}, estimator);
        }
        throw_if_python_model_raised();
        return result;
      },
      py::arg("bank"), py::arg("log"), py::arg("rate") = 0.0, py::arg("smooth") = false, py::arg("lag") = py::none(),
      "Runs a fresh IMM over one log and scores it, as `skidimm eval` does per log.");
  m.def(
      "eval_report",
      [](const std::vector<std::pair<std::string, std::vector<evaluation::LogResult>>>& groups,
         const std::vector<std::string>& states, const std::vector<std::string>& classes, const PyBank& bank) {
        std::vector<evaluation::LogGroup> g;
        for (const auto& [name, logs] : groups) g.push_back(evaluation::LogGroup{name, logs});
        const std::string decision = evaluation::decision_settings_text(bank.config().decision);
        py::gil_scoped_release release;
        return std::make_pair(evaluation::report_json(g, classes, states),
                              evaluation::report_tables(g, classes, states, decision));
      },
      py::arg("groups"), py::arg("states"), py::arg("classes"), py::arg("bank"),
      "`skidimm eval`'s JSON and table for groups of per-log results, reduced in the order given.");

  // ---------------------------------------------------------------- simulate
  m.def(
      "simulate_scenario",
      [](const fs::path& scenario, const fs::path& output, std::optional<unsigned long long> seed, double duration) {
        py::gil_scoped_release release;
        simulation::Scenario loaded = simulation::load_scenario(scenario);
        if (duration > 0.0) loaded.duration = duration;
        simulation::simulate(loaded, seed.value_or(loaded.seed), output);
      },
      py::arg("scenario"), py::arg("output"), py::arg("seed") = py::none(), py::arg("duration") = 0.0);
  m.def(
      "simulate_models",
      [](const PyBank& bank, const std::string& inputs_from, const fs::path& output, unsigned long long seed,
         double rate) {
        const LogSpec source = parse_log_spec(inputs_from);
        clear_python_model_error();
        simulation::ModelSimulationSummary summary;
        {
          py::gil_scoped_release release;
          summary = simulation::simulate_models(*bank.bank, source, sampling_of(bank.config(), rate), seed, output);
        }
        throw_if_python_model_raised();
        return py::make_tuple(summary.rows, summary.mode_switches);
      },
      py::arg("bank"), py::arg("inputs_from"), py::arg("output"), py::arg("seed") = 1, py::arg("rate") = 0.0);

  // ---------------------------------------------------------------- fit
  m.def(
      "fit_options",
      [](const std::string& objective, double window, const std::string& loss, double loss_scale, bool hold_unexcited,
         bool shared, bool fit_r, bool full_q, bool output_noise) {
        // Validated here (objective names) so that a bad option fails before any log is read.
        fit_options_of(objective, window, loss, loss_scale, hold_unexcited, shared, fit_r, full_q, output_noise);
        return py::dict(py::arg("objective") = objective, py::arg("window") = window, py::arg("loss") = loss,
                        py::arg("loss_scale") = loss_scale, py::arg("hold_unexcited") = hold_unexcited,
                        py::arg("shared") = shared, py::arg("fit_r") = fit_r, py::arg("full_q") = full_q,
                        py::arg("output_noise") = output_noise);
      },
      py::arg("objective") = "likelihood", py::arg("window") = 0.0, py::arg("loss") = "huber",
      py::arg("loss_scale") = 3.0, py::arg("hold_unexcited") = false, py::arg("shared") = false,
      py::arg("fit_r") = false, py::arg("full_q") = false, py::arg("output_noise") = false);
  auto options_from = [](const py::dict& o) {
    return fit_options_of(o["objective"].cast<std::string>(), o["window"].cast<double>(), o["loss"].cast<std::string>(),
                          o["loss_scale"].cast<double>(), o["hold_unexcited"].cast<bool>(), o["shared"].cast<bool>(),
                          o["fit_r"].cast<bool>(), o["full_q"].cast<bool>(), o["output_noise"].cast<bool>());
  };
  m.def(
      "load_fit_logs",
      [](const PyBank& bank, const std::vector<std::string>& logs, const std::string& mode, double rate,
         bool skip_unpaired) {
        std::vector<fitting::ModeLogs> data;
        std::vector<std::string> skipped;
        {
          py::gil_scoped_release release;
          data = fitting::load_mode_logs(bank.config(), logs, mode, sampling_of(bank.config(), rate), "--log",
                                         unpaired_runs(skip_unpaired, &skipped));
        }
        warn_skipped(skipped);
        return mode_logs_to_list(data);
      },
      py::arg("bank"), py::arg("logs"), py::arg("mode") = "", py::arg("rate") = 0.0, py::arg("skip_unpaired") = false,
      "The logs of `skidimm fit --log` arguments by mode: [(mode index, [trajectory dict])].");
  m.def(
      "mode_segments",
      [](const PyBank& bank, const py::object& log, const std::string& mode, double rate) {
        const LogSpec spec = log_spec_of(log);
        std::vector<fitting::ModeLogs> data;
        {
          py::gil_scoped_release release;
          data = fitting::mode_segments(bank.config(), spec, mode, sampling_of(bank.config(), rate));
        }
        return mode_logs_to_list(data);
      },
      py::arg("bank"), py::arg("log"), py::arg("mode") = "", py::arg("rate") = 0.0,
      "One log's segments by mode, as `skidimm fit` splits it.");
  m.def(
      "fit_in_place",
      [options_from](PyBank& bank, const py::list& data, const py::dict& options) {
        return fit_in_place(bank, mode_logs_from_list(data), options_from(options));
      },
      py::arg("bank"), py::arg("data"), py::arg("options"),
      "Fits the bank's modes in `data` in place (fitting::fit_bank); returns per mode index its report, "
      "flat parameters, Q and number of segments.");
  m.def(
      "apply_fit",
      [](PyBank& bank, int mode, const Eigen::VectorXd& parameters, const Eigen::MatrixXd& q,
         const std::optional<Eigen::MatrixXd>& r) {
        if (mode < 0 || mode >= bank.config().num_modes()) throw py::index_error("no mode " + std::to_string(mode));
        std::string error;
        if (!bank.bank->models[static_cast<std::size_t>(mode)]->set_parameters(parameters, &error)) throw Error(error);
        bank.bank->config.modes[static_cast<std::size_t>(mode)].q_intensity = q;
        if (r) bank.bank->config.modes[static_cast<std::size_t>(mode)].r = *r;
      },
      py::arg("bank"), py::arg("mode"), py::arg("parameters"), py::arg("q"), py::arg("r") = py::none(),
      "Sets a mode's fitted parameters, Q and (given) its own R, as fit_in_place left them on the bank it fitted.");
  m.def(
      "fit_texts",
      [options_from](const PyBank& bank, const py::dict& fitted, const py::dict& options, const std::string& mode,
                     const std::string& name, const std::vector<std::string>& header, const fs::path& output) {
        std::vector<fitting::FittedMode> modes;
        for (const auto& [index, entry] : fitted) {
          const py::dict e = py::reinterpret_borrow<py::dict>(entry);
          modes.push_back(fitting::FittedMode{index.cast<int>(), e["logs"].cast<int>(),
                                              report_from_dict(e["report"].cast<py::dict>())});
        }
        std::sort(modes.begin(), modes.end(),
                  [](const fitting::FittedMode& a, const fitting::FittedMode& b) { return a.mode < b.mode; });
        fitting::FitRequest request;
        request.mode = mode;
        request.name = name;
        request.options = options_from(options);
        const std::string entries = fitting::format_fitted_entries(*bank.bank, modes, request);
        fitting::write_fitted_bank(*bank.bank, modes, request, bank.config().file, output, header);
        std::ifstream written(output, std::ios::binary);
        std::ostringstream text;
        text << written.rdbuf();
        return py::make_tuple(entries, text.str());
      },
      py::arg("bank"), py::arg("fitted"), py::arg("options"), py::arg("mode"), py::arg("name"), py::arg("header"),
      py::arg("output"), "The mode entries and the whole bank `skidimm fit` writes for a fitted bank.");
}
