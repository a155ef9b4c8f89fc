// Evaluation: LogResult (one log's scores, picklable for Dask), evaluate_log
// and eval_report (`skidimm eval`'s JSON and tables from per-log results).
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <map>
#include <optional>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "bindings.h"
#include "log_result_codec.h"
#include "py_bank.h"
#include "python_arguments.h"
#include "python_model.h"
#include "skidimm/config/run_overrides.h"
#include "skidimm/evaluation/accuracy_range.h"
#include "skidimm/evaluation/evaluation_report.h"
#include "skidimm/evaluation/log_evaluation.h"
#include "skidimm/evaluation/log_groups.h"

namespace skidimm {
namespace python {

namespace py = pybind11;

void bind_evaluation(py::module_& m) {
  // eval --range-for's bound on a class's count, for Python's own check of range_for.
  m.attr("MOST_LOGS_PER_CLASS") = evaluation::kMostLogsPerClass;
  py::class_<evaluation::LogResult>(m, "LogResult", "One log's evaluation (log_evaluation.h); picklable.")
      .def_readonly("name", &evaluation::LogResult::name)
      .def_readonly("steps", &evaluation::LogResult::steps)
      .def_readonly("source", &evaluation::LogResult::source)
      .def_readonly("unmeasured", &evaluation::LogResult::unmeasured,
                    "Each measurement the log left without a value for all of it or a long stretch (as `skidimm "
                    "eval` warns)")
      .def_readonly("skipped", &evaluation::LogResult::skipped,
                    "What the bank's options left out of the log (sampling.skip_gaps, skip_out_of_order), as "
                    "`skidimm eval` says it")
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
      "evaluate_spliced",
      [](const PyBank& bank, const std::vector<std::pair<std::string, std::vector<py::object>>>& groups, double rate) {
        std::vector<evaluation::SplicedGroup> spliced;
        for (const auto& [name, logs] : groups) {
          evaluation::SplicedGroup group{name, {}};
          for (const py::object& log : logs) group.logs.push_back(log_spec_of(log));
          spliced.push_back(std::move(group));
        }
        std::vector<evaluation::LogGroup> scored;
        clear_python_model_error();
        {
          py::gil_scoped_release release;
          scored = evaluation::evaluate_spliced_groups(*bank.bank, spliced, sampling_of(bank.config(), rate));
        }
        throw_if_python_model_raised();
        std::vector<std::pair<std::string, std::vector<evaluation::LogResult>>> out;
        for (evaluation::LogGroup& g : scored) out.emplace_back(g.name, std::move(g.logs));
        return out;
      },
      py::arg("bank"), py::arg("groups"), py::arg("rate") = 0.0,
      "The groups' logs spliced end to end into one run, the groups taking turns, scored by one IMM, as `skidimm "
      "eval --splice` does: [(name, [LogResult])].");
  m.def(
      "rate_unlike_the_banks",
      [](const PyBank& bank, double rate) {
        return rate_unlike_the_banks(bank.config(), rate > 0.0 ? std::optional<double>(rate) : std::nullopt);
      },
      py::arg("bank"), py::arg("rate"),
      "Why stepping the bank at `rate` Hz measures something other than what its modes were fitted on (its "
      "aggregated measurements over steps of another length), from 'at another rate than its sampling.rate'; "
      "empty when it does not.");
  m.def(
      "eval_report",
      [](const std::vector<std::pair<std::string, std::vector<evaluation::LogResult>>>& groups,
         const std::vector<std::string>& states, const std::vector<std::string>& classes, const PyBank& bank,
         const std::map<std::string, int>& range_for) {
        std::vector<evaluation::LogGroup> g;
        for (const auto& [name, logs] : groups) g.push_back(evaluation::LogGroup{name, logs});
        const std::string decision = evaluation::decision_settings_text(bank.config().decision);
        py::gil_scoped_release release;
        return std::make_tuple(evaluation::report_json(g, classes, states, range_for),
                               evaluation::report_tables(g, classes, states, decision, range_for),
                               range_for.empty() ? std::string() : evaluation::logs_per_class_problem(g, range_for));
      },
      py::arg("groups"), py::arg("states"), py::arg("classes"), py::arg("bank"),
      py::arg("range_for") = std::map<std::string, int>{},
      "`skidimm eval`'s JSON and table for groups of per-log results, reduced in the order given, and why "
      "`range_for` (eval --range-for's counts) does not fit the scored classes (empty where it does).");
}

}  // namespace python
}  // namespace skidimm
