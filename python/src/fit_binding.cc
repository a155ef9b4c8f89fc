// Fitting: the options of `skidimm fit`, its logs by mode (as dicts of
// arrays, so that Dask can ship them), a fit of a bank in place, and the
// entries and bank file `fit` writes.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "bindings.h"
#include "numpy_values.h"
#include "py_bank.h"
#include "python_arguments.h"
#include "python_model.h"
#include "skidimm/config/run_overrides.h"
#include "skidimm/engine/parameter_uncertainty.h"
#include "skidimm/errors.h"
#include "skidimm/fitting/bank_fit.h"
#include "skidimm/fitting/fit_logs.h"
#include "skidimm/fitting/fit_output.h"
#include "skidimm/io/output_file.h"
#include "skidimm/progress.h"

namespace skidimm {
namespace python {

namespace py = pybind11;
namespace fs = std::filesystem;

namespace {

fitting::BankFitOptions fit_options_of(const std::string& objective, double window, const std::string& loss,
                                       double loss_scale, bool hold_unexcited, bool shared, bool fit_r, bool full_q,
                                       bool output_noise, bool parameter_uncertainty, bool uncertainty_per_log,
                                       bool residual_correlation, bool pooled_q, bool partial_pooling) {
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
  o.parameter_uncertainty = parameter_uncertainty;
  o.uncertainty_per_log = uncertainty_per_log;
  o.residual_correlation = residual_correlation;
  o.pooled_process_noise = pooled_q;
  o.partial_pooling = partial_pooling;
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
  d["skipped"] = t.skipped;
  d["log_steps"] = t.log_steps;
  d["log_seconds"] = t.log_seconds;
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
  if (d.contains("skipped")) t.skipped = d["skipped"].cast<std::vector<std::string>>();
  if (d.contains("log_steps")) t.log_steps = d["log_steps"].cast<long>();
  if (d.contains("log_seconds")) t.log_seconds = d["log_seconds"].cast<double>();
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
    py::dict ranges;  // ModeConfig::fitted_inputs
    for (const auto& [input, range] : bank.config().modes[static_cast<std::size_t>(d.mode)].fitted_inputs) {
      ranges[py::str(input)] = py::make_tuple(range.lowest, range.highest);
    }
    entry["fitted_inputs"] = ranges;
    // What --parameter-uncertainty and --residual-correlation wrote into the mode.
    const ModeConfig& fitted = bank.config().modes[static_cast<std::size_t>(d.mode)];
    entry["parameter_covariance"] = fitted.parameter_covariance.size() > 0
                                        ? py::object(matrix_array(fitted.parameter_covariance))
                                        : py::object(py::none());
    entry["residual_correlation"] = fitted.residual_correlation;
    entry["logs"] = fitting::log_count(d);
    out[py::int_(d.mode)] = entry;
  }
  return out;
}

}  // namespace

void bind_fit(py::module_& m) {
  m.def(
      "fit_options",
      [](const std::string& objective, double window, const std::string& loss, double loss_scale, bool hold_unexcited,
         bool shared, bool fit_r, bool full_q, bool output_noise, bool parameter_uncertainty, bool uncertainty_per_log,
         bool residual_correlation, bool pooled_q, bool partial_pooling) {
        // Validated here (objective names) so that a bad option fails before any log is read.
        const fitting::BankFitOptions o =
            fit_options_of(objective, window, loss, loss_scale, hold_unexcited, shared, fit_r, full_q, output_noise,
                           parameter_uncertainty, uncertainty_per_log, residual_correlation, pooled_q, partial_pooling);
        if (uncertainty_per_log && !parameter_uncertainty) {
          throw Error(
              "uncertainty_per_log scales each mode's parameter covariance, which parameter_uncertainty=True "
              "writes; give both");
        }
        if (partial_pooling && !parameter_uncertainty) {
          throw Error(
              "partial_pooling weighs each mode's estimates by their covariance, which parameter_uncertainty=True "
              "estimates; give both");
        }
        // Another objective's option would be ignored without a word, as `skidimm fit` refuses it.
        const fitting::FitOptions defaults;
        if (o.objective == fitting::Objective::kLikelihood) {
          for (const auto& [name, given] : {std::pair<const char*, bool>{"window", window != defaults.window},
                                            {"loss", loss != defaults.loss},
                                            {"loss_scale", loss_scale != defaults.loss_scale},
                                            {"output_noise", output_noise},
                                            {"parameter_uncertainty", parameter_uncertainty},
                                            {"residual_correlation", residual_correlation},
                                            {"pooled_q", pooled_q}}) {
            if (given) {
              throw Error(std::string(name) +
                          " is an option of the window objective; add objective=\"window\" (the default objective "
                          "is likelihood: docs/fitting.md)");
            }
          }
        } else if (fit_r) {
          throw Error(
              "fit_r is an option of the likelihood objective (the window objective keeps the bank's R); leave out "
              "objective=\"window\" or fit_r");
        }
        return py::dict(py::arg("objective") = objective, py::arg("window") = window, py::arg("loss") = loss,
                        py::arg("loss_scale") = loss_scale, py::arg("hold_unexcited") = hold_unexcited,
                        py::arg("shared") = shared, py::arg("fit_r") = fit_r, py::arg("full_q") = full_q,
                        py::arg("output_noise") = output_noise,
                        py::arg("parameter_uncertainty") = parameter_uncertainty,
                        py::arg("uncertainty_per_log") = uncertainty_per_log,
                        py::arg("residual_correlation") = residual_correlation, py::arg("pooled_q") = pooled_q,
                        py::arg("partial_pooling") = partial_pooling);
      },
      py::arg("objective") = "likelihood", py::arg("window") = 0.0, py::arg("loss") = "huber",
      py::arg("loss_scale") = 3.0, py::arg("hold_unexcited") = false, py::arg("shared") = false,
      py::arg("fit_r") = false, py::arg("full_q") = false, py::arg("output_noise") = false,
      py::arg("parameter_uncertainty") = false, py::arg("uncertainty_per_log") = false,
      py::arg("residual_correlation") = false, py::arg("pooled_q") = false, py::arg("partial_pooling") = false);
  auto options_from = [](const py::dict& o) {
    return fit_options_of(o["objective"].cast<std::string>(), o["window"].cast<double>(), o["loss"].cast<std::string>(),
                          o["loss_scale"].cast<double>(), o["hold_unexcited"].cast<bool>(), o["shared"].cast<bool>(),
                          o["fit_r"].cast<bool>(), o["full_q"].cast<bool>(), o["output_noise"].cast<bool>(),
                          o["parameter_uncertainty"].cast<bool>(), o["uncertainty_per_log"].cast<bool>(),
                          o["residual_correlation"].cast<bool>(), o["pooled_q"].cast<bool>(),
                          o["partial_pooling"].cast<bool>());
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
      "fit_notes",
      [](const PyBank& bank, const py::list& data, bool of_the_bank) {
        const std::vector<fitting::ModeLogs> logs = mode_logs_from_list(data);
        std::vector<std::string> notes = fitting::labels_overriding_truth(bank.config(), logs);
        for (const std::string& left_out : fitting::skipped_by_sampling(logs)) notes.push_back(left_out);
        for (const std::string& short_log : fitting::logs_spanning_under_a_second(bank.config(), logs)) {
          notes.push_back(short_log);
        }
        if (of_the_bank) {
          for (const std::string& unfitted : fitting::classes_leaving_steps_unfitted(bank.config())) {
            notes.push_back(bank.file.string() + ": " + unfitted);
          }
        }
        return notes;
      },
      py::arg("bank"), py::arg("data"), py::arg("of_the_bank") = true,
      "What `skidimm fit` says before it fits, about `data` (load_fit_logs' or mode_segments'): labels over a "
      "log's truth column, rows the bank's sampling options left out of a log; with `of_the_bank`, the classes "
      "whose steps no mode's fit_when takes.");
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
         const std::optional<Eigen::MatrixXd>& r, const std::map<std::string, std::pair<double, double>>& fitted_inputs,
         const std::optional<Eigen::MatrixXd>& parameter_covariance, double residual_correlation) {
        if (mode < 0 || mode >= bank.config().num_modes()) throw py::index_error("no mode " + std::to_string(mode));
        std::string error;
        if (!bank.bank->models[static_cast<std::size_t>(mode)]->set_parameters(parameters, &error)) throw Error(error);
        ModeConfig& config = bank.bank->config.modes[static_cast<std::size_t>(mode)];
        config.q_intensity = q;
        if (r) config.r = *r;
        config.fitted_inputs.clear();
        for (const auto& [input, range] : fitted_inputs)
          config.fitted_inputs[input] = InputRange{range.first, range.second};
        config.residual_correlation = residual_correlation;
        // As fit_bank leaves it: the fitted covariance, or none where the fit wrote none over a start's.
        if (parameter_covariance || config.parameter_covariance.size() > 0) {
          set_fitted_parameter_covariance(bank.bank.get(), mode,
                                          parameter_covariance ? *parameter_covariance : Eigen::MatrixXd());
        }
      },
      py::arg("bank"), py::arg("mode"), py::arg("parameters"), py::arg("q"), py::arg("r") = py::none(),
      py::arg("fitted_inputs") = std::map<std::string, std::pair<double, double>>{},
      py::arg("parameter_covariance") = py::none(), py::arg("residual_correlation") = 0.0,
      "Sets a mode's fitted parameters, Q, (given) its own R, its inputs' fitted ranges, (given) its parameter "
      "covariance and its residual correlation, as fit_in_place left them on the bank it fitted.");
  m.def(
      "check_output_path", [](const fs::path& path, const std::string& option) { check_output_path(path, option); },
      py::arg("path"), py::arg("option"),
      "Raises skidimm.Error, naming `option`, when a file cannot be written at `path` (output_file.h), so that "
      "fit fails before the work and not after it.");
  m.def(
      "renaming_problem",
      [](const PyBank& bank, const std::string& mode, const std::string& name) {
        return fitting::renaming_problem(bank.config(), mode, name);
      },
      "Why the bank fit writes cannot take mode `mode` renamed `name`, or ''.");
  m.def(
      "fit_texts",
      [options_from](const PyBank& bank, const py::dict& fitted, const py::dict& options, const std::string& mode,
                     const std::string& name, const std::vector<std::string>& header, const fs::path& output,
                     double rate) {
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
        request.sampling = sampling_of(bank.config(), rate);
        const std::string entries = fitting::format_fitted_entries(*bank.bank, modes, request);
        fitting::write_fitted_bank(*bank.bank, modes, request, bank.config().file, output, header);
        std::ifstream written(output, std::ios::binary);
        std::ostringstream text;
        text << written.rdbuf();
        return py::make_tuple(entries, text.str());
      },
      py::arg("bank"), py::arg("fitted"), py::arg("options"), py::arg("mode"), py::arg("name"), py::arg("header"),
      py::arg("output"), py::arg("rate") = 0.0,
      "The mode entries and the whole bank `skidimm fit` writes for a fitted bank; `rate` (Hz, 0: the bank's) is "
      "the rate its logs were stepped at, written as the bank's sampling.rate where it is not the bank's.");
}

}  // namespace python
}  // namespace skidimm
