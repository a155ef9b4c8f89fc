// Logs: log arguments as the CLI expands them, `skidimm run` over a log file
// (run_log), the bank's column expressions over arrays, and CSV files as
// numpy columns.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <exception>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "array_run.h"
#include "bindings.h"
#include "csv_columns.h"
#include "errors.h"
#include "numpy_values.h"
#include "py_bank.h"
#include "python_arguments.h"
#include "python_model.h"
#include "run_columns.h"
#include "skidimm/config/expression.h"
#include "skidimm/config/run_overrides.h"
#include "skidimm/errors.h"
#include "skidimm/io/log_arguments.h"
#include "skidimm/io/log_reader.h"

namespace skidimm {
namespace python {

namespace py = pybind11;
namespace fs = std::filesystem;

void bind_logs(py::module_& m) {
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
  m.def("group_names", &log_group_names, py::arg("arguments"),
        "Several log arguments' group names in `skidimm eval`: arguments that would be named alike told apart by "
        "their folders; arguments still of one name are one group.");
  m.def(
      "run_log",
      [](const PyBank& bank, const std::vector<std::string>& inputs, double rate, bool smooth,
         std::optional<double> lag, const py::object& decision) {
        const LogSpec log = join_log_arguments(inputs);
        const BankConfig& config = bank.config();
        if (!log.label.empty() && config.class_index(log.label) < 0) {
          throw Error(log.text + ": " + config.unknown_label(log.label));
        }
        const EstimatorOptions estimator = estimator_options(smooth, lag);
        const DecisionConfig settings = decision_of(config, decision);
        GrowingRunColumns columns(config);
        std::vector<std::string> truth, unmeasured;
        bool with_truth = false;
        long rows = 0;
        std::exception_ptr failure;
        clear_python_model_error();
        {
          py::gil_scoped_release release;
          try {
            LogReader reader(config, log.files, sampling_of(config, rate));
            with_truth = reader.has_truth() || !log.label.empty();
            rows = run_log_file(*bank.bank, &reader, estimator, settings, log.label, with_truth, &columns, &truth);
            unmeasured = reader.unmeasured(config);
          } catch (...) {
            failure = std::current_exception();
          }
        }
        throw_if_python_model_raised();
        // The rows computed before an error (a recording cut short) are not
        // lost: the exception carries them as `partial`, as `skidimm run`
        // keeps them in its .partial file.
        if (failure) {
          if (columns.t.empty()) std::rethrow_exception(failure);
          raise_with(failure, "partial",
                     columns_to_dict(RunArrays(std::move(columns)), config,
                                     with_truth ? py::object(text_array(truth)) : py::object(py::none())));
        }
        // As `skidimm run` warns: a measurement the log never gave, or not
        // for a long stretch, left those steps to the others.
        const py::object warn = py::module_::import("warnings").attr("warn");
        for (const std::string& line : unmeasured)
          warn(log.text + ": " + line, py::module_::import("builtins").attr("UserWarning"), 2);
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
}

}  // namespace python
}  // namespace skidimm
