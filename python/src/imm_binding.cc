// Imm: the IMM estimator over a bank, one step at a time (Estimate) or over
// whole arrays in C++ (run, into the columns `skidimm run` writes).
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "array_run.h"
#include "bindings.h"
#include "errors.h"
#include "numpy_values.h"
#include "py_bank.h"
#include "python_arguments.h"
#include "python_model.h"
#include "run_columns.h"
#include "skidimm/config/run_overrides.h"
#include "skidimm/engine/decision.h"
#include "skidimm/engine/imm.h"
#include "skidimm/io/csv.h"

namespace skidimm {
namespace python {

namespace py = pybind11;

namespace {

struct Estimate {
  double t = 0.0;
  std::string status;
  int num_measured = 0;
  int num_rejected_modes = 0;
  // Per mode, what went wrong in the step and the model's own words; "" where it ran.
  std::vector<std::string> mode_failures;
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
  bool started = false;  // a step since construction or reset: the first's time shows its unit
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

// Measurements are numbers or NaN (not measured); the engine would take an
// infinity for "not measured" too, which the CLI's reader refuses as a cell.
void refuse_infinite_measurements(const DoubleArray& z, long rows, int width) {
  const double* data = z.data();
  for (long k = 0; k < rows; ++k) {
    for (int j = 0; j < width; ++j) {
      const double v = data[k * width + j];
      if (std::isinf(v)) {
        throw py::value_error("z[" + std::to_string(k) + ", " + std::to_string(j) + "] is " +
                              (v > 0 ? "inf" : "-inf") +
                              ": a measurement is a finite number, or NaN where it was not measured");
      }
    }
  }
}

// Times in another unit than seconds, read as seconds, make every step a
// gap over which each filter forgets all it knew, and a run of wrong
// estimates without an error: refused where the unit shows. A first time
// beyond 1e11 s (over 3000 years) is ns, us or ms since 1970 (a pandas
// datetime's nanoseconds); steps of an hour at the median are ns or us at a
// sensor's rate. A single bad time later in a run (NaN, inf, 1e308) is a
// step the engine ignores, not a unit: a robot's loop goes on. Steps
// longer than the bank's sampling.max_gap at the median (milliseconds from
// the start: 20 a step at 50 Hz) would each be a gap the log reader refuses,
// and with no gap the CLI would read: refused with the unit asked about.
void refuse_times_not_in_seconds(const double* t, long rows, bool one, double max_gap) {
  constexpr double kLongestTimeInSeconds = 1e11;
  constexpr double kLongestMedianStep = 3600.0;
  const std::string how =
      " Stamps in ms, us or ns are divided by 1e3, 1e6 or 1e9 first (a pandas datetime column: (t - t[0]) / "
      "np.timedelta64(1, 's'))";
  long first = 0;
  while (first < rows && !std::isfinite(t[first])) ++first;
  if (first < rows && std::abs(t[first]) > kLongestTimeInSeconds) {
    throw py::value_error((one ? std::string("t") : "t[" + std::to_string(first) + "]") + " = " +
                          CsvWriter::format(t[first]) + ": over 3000 years, no time in seconds." + how);
  }
  std::vector<double> steps;
  for (long k = first + 1; k < rows; ++k) {
    const double step = t[k] - t[k - 1];
    if (std::isfinite(step) && step > 0.0) steps.push_back(step);
  }
  if (steps.size() < 3) return;  // too few to tell a unit from a pause
  const auto lower_median = steps.begin() + static_cast<long>((steps.size() - 1) / 2);
  std::nth_element(steps.begin(), lower_median, steps.end());
  const double median = *lower_median;
  if (median > kLongestMedianStep) {
    throw py::value_error("t steps by " + CsvWriter::format(median) +
                          " s at the median, over an hour: are the times in seconds?" + how);
  }
  if (median > max_gap) {
    throw py::value_error("t steps by " + CsvWriter::format(median) + " s at the median, longer than the bank's " +
                          "sampling.max_gap (" + CsvWriter::format(max_gap) +
                          " s), the longest step the log reader takes without a gap: are the times in seconds "
                          "(milliseconds from the start step by 20 at 50 Hz)?" +
                          how + "; for a log that truly steps so slowly, raise sampling.max_gap in the bank");
  }
}

Estimate make_estimate(const PyImm& self, const ImmEstimate& e, int decided) {
  Estimate out;
  out.t = e.t;
  out.status = to_string(e.status);
  out.num_measured = e.num_measured;
  out.num_rejected_modes = e.num_rejected_modes;
  out.mode_failures.reserve(e.mode_failures.size());
  for (std::size_t j = 0; j < e.mode_failures.size(); ++j) {
    const ModeFailure failure = e.mode_failures[j];
    const std::string& reason = j < e.failure_reasons.size() ? e.failure_reasons[j] : std::string();
    // The model's own words belong to a model failure alone: the reasons
    // are kept from the step that gave them.
    const bool with_reason = failure == ModeFailure::kModel && !reason.empty();
    out.mode_failures.push_back(failure == ModeFailure::kNone ? std::string()
                                : with_reason                 ? std::string(to_string(failure)) + ": " + reason
                                                              : std::string(to_string(failure)));
  }
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
  refuse_infinite_measurements(zz, 1, self.measurement_dim());
  if (!self.started) refuse_times_not_in_seconds(&t, 1, true, self.config().sampling.max_gap);
  const ImmInUse hold(self);
  self.started = self.started || std::isfinite(t);  // a NaN first step shows no unit
  clear_python_model_error();
  int decided = ModeDecision::kUnknown;
  const ImmEstimate* e = nullptr;
  {
    py::gil_scoped_release release;
    e = &self.imm->step(t, Eigen::Map<const Eigen::VectorXd>(uu.data(), self.input_dim()),
                        Eigen::Map<const Eigen::VectorXd>(zz.data(), self.measurement_dim()));
    decided = self.decision->update(t, e->mode_probabilities, e->measured());
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
  refuse_infinite_measurements(zz, n, self.measurement_dim());
  if (reset || !self.started) refuse_times_not_in_seconds(tt.data(), n, false, self.config().sampling.max_gap);
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
  self.started = self.started || std::any_of(tt.data(), tt.data() + n, [](double v) { return std::isfinite(v); });
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

}  // namespace

void bind_imm(py::module_& m) {
  py::class_<Estimate>(m, "Estimate", "What one IMM step produced (imm_estimate.h), as numpy arrays.")
      .def_readonly("t", &Estimate::t)
      .def_readonly("status", &Estimate::status)
      .def_readonly("num_measured", &Estimate::num_measured)
      .def_readonly("num_rejected_modes", &Estimate::num_rejected_modes)
      .def_readonly("mode_failures", &Estimate::mode_failures)
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
             self.started = false;
           })
      .def(
          "checkpoint",
          [](PyImm& self) {
            const ImmInUse hold(self);
            ImmCheckpoint checkpoint = self.imm->checkpoint();
            checkpoint.decision = self.decision->memory();
            return checkpoint;
          },
          "The filter's and the decision's state after the last step (a Checkpoint), for restore() here or in "
          "another process.")
      .def(
          "restore",
          [](PyImm& self, const ImmCheckpoint& checkpoint) {
            const ImmInUse hold(self);
            // A refused checkpoint leaves the Imm and its decision as they were.
            const ImmCheckpoint previous = self.imm->checkpoint();
            self.imm->restore(checkpoint);
            ModeDecision decision = *self.decision;
            decision.reset();
            try {
              if (checkpoint.decision) decision.restore(*checkpoint.decision);
            } catch (...) {
              self.imm->restore(previous);
              throw;
            }
            *self.decision = decision;
            self.started = checkpoint.started;
            self.last_decision = decision.decision();
          },
          py::arg("checkpoint"),
          "Goes on from a Checkpoint of a bank with the same modes, states, inputs and measurement (Error saying "
          "what differs otherwise); the next step must come after its time. run() resets unless reset=False.")
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
}

}  // namespace python
}  // namespace skidimm
