#include "log_result_codec.h"

#include <pybind11/stl.h>

namespace skidimm {
namespace python {

namespace py = pybind11;
using evaluation::ModeMetrics;
using evaluation::NisAccumulator;
using evaluation::SwitchDetection;

namespace {

py::dict metrics_to_dict(const ModeMetrics& m) {
  py::dict d;
  d["duration"] = m.duration;
  d["unlabelled"] = m.unlabelled;
  d["correct"] = m.correct;
  d["truth_probability"] = m.truth_probability;
  d["truth_log_probability"] = m.truth_log_probability;
  d["confusion"] = m.confusion;
  d["log_probability_by_truth"] = m.log_probability_by_truth;
  py::list switches;
  for (const SwitchDetection& s : m.switches) {
    py::dict w;
    w["time"] = s.time;
    w["from"] = s.from;
    w["to"] = s.to;
    w["latency"] = s.latency;
    w["first_latency"] = s.first_latency;
    w["changes"] = s.changes;
    switches.append(w);
  }
  d["switches"] = switches;
  d["truth_absent"] = m.truth_absent;
  d["estimate_changes"] = m.estimate_changes;
  d["truth_changes"] = m.truth_changes;
  d["unknown_seconds"] = m.unknown_seconds;
  d["brier"] = m.brier;
  py::list calibration;
  for (const evaluation::CalibrationBin& b : m.calibration) calibration.append(py::make_tuple(b.seconds, b.correct, b.confidence));
  d["calibration"] = calibration;
  return d;
}

ModeMetrics metrics_from_dict(const py::dict& d) {
  ModeMetrics m;
  m.duration = d["duration"].cast<double>();
  m.unlabelled = d["unlabelled"].cast<double>();
  m.correct = d["correct"].cast<double>();
  m.truth_probability = d["truth_probability"].cast<double>();
  m.truth_log_probability = d["truth_log_probability"].cast<double>();
  m.confusion = d["confusion"].cast<std::map<std::string, std::map<std::string, double>>>();
  m.log_probability_by_truth = d["log_probability_by_truth"].cast<std::map<std::string, double>>();
  for (const py::handle item : d["switches"]) {
    const py::dict w = py::reinterpret_borrow<py::dict>(item);
    SwitchDetection s;
    s.time = w["time"].cast<double>();
    s.from = w["from"].cast<std::string>();
    s.to = w["to"].cast<std::string>();
    s.latency = w["latency"].cast<double>();
    s.first_latency = w["first_latency"].cast<double>();
    s.changes = w["changes"].cast<long>();
    m.switches.push_back(s);
  }
  m.truth_absent = d["truth_absent"].cast<std::map<std::string, double>>();
  m.estimate_changes = d["estimate_changes"].cast<long>();
  m.truth_changes = d["truth_changes"].cast<long>();
  m.unknown_seconds = d["unknown_seconds"].cast<double>();
  m.brier = d["brier"].cast<double>();
  const py::list calibration = d["calibration"].cast<py::list>();
  for (std::size_t b = 0; b < m.calibration.size() && b < calibration.size(); ++b) {
    const auto [seconds, correct, confidence] = calibration[b].cast<std::tuple<double, double, double>>();
    m.calibration[b] = {seconds, correct, confidence};
  }
  return m;
}

}  // namespace

py::dict to_dict(const evaluation::LogResult& result) {
  py::dict d;
  d["name"] = result.name;
  d["source"] = result.source;
  d["classes"] = result.classes;
  d["unmeasured"] = result.unmeasured;
  d["skipped"] = result.skipped;
  d["metrics"] = metrics_to_dict(result.metrics);
  d["decision_metrics"] = metrics_to_dict(result.decision_metrics);
  py::dict nis;
  for (const auto& [mode, acc] : result.nis) {
    py::dict a;
    a["sum"] = acc.sum;
    a["dof"] = acc.dof;
    a["steps"] = acc.steps;
    nis[py::str(mode)] = a;
  }
  d["nis"] = nis;
  d["squared_state_error"] = result.squared_state_error;
  d["state_error_count"] = result.state_error_count;
  d["steps"] = result.steps;
  const evaluation::ExtrapolationCounts& e = result.extrapolation;
  py::dict extrapolation;
  extrapolation["steps"] = e.steps;
  extrapolation["outside_estimate"] = e.outside_estimate;
  extrapolation["labelled"] = e.labelled;
  extrapolation["outside_truth"] = e.outside_truth;
  extrapolation["outside_truth_right"] = e.outside_truth_right;
  extrapolation["inside_truth_right"] = e.inside_truth_right;
  extrapolation["farthest"] = e.farthest;
  extrapolation["farthest_beyond"] = e.farthest_beyond;
  d["extrapolation"] = extrapolation;
  return d;
}

evaluation::LogResult log_result_from_dict(const py::dict& d) {
  evaluation::LogResult r;
  r.name = d["name"].cast<std::string>();
  r.source = d["source"].cast<std::string>();
  r.classes = d["classes"].cast<std::vector<std::string>>();
  if (d.contains("unmeasured")) r.unmeasured = d["unmeasured"].cast<std::vector<std::string>>();
  if (d.contains("skipped")) r.skipped = d["skipped"].cast<std::vector<std::string>>();
  r.metrics = metrics_from_dict(d["metrics"].cast<py::dict>());
  r.decision_metrics = metrics_from_dict(d["decision_metrics"].cast<py::dict>());
  for (const auto& [mode, value] : d["nis"].cast<py::dict>()) {
    const py::dict a = py::reinterpret_borrow<py::dict>(value);
    NisAccumulator acc;
    acc.sum = a["sum"].cast<double>();
    acc.dof = a["dof"].cast<double>();
    acc.steps = a["steps"].cast<long>();
    r.nis[mode.cast<std::string>()] = acc;
  }
  r.squared_state_error = d["squared_state_error"].cast<std::vector<double>>();
  r.state_error_count = d["state_error_count"].cast<std::vector<long>>();
  r.steps = d["steps"].cast<long>();
  const py::dict e = d["extrapolation"].cast<py::dict>();
  r.extrapolation.steps = e["steps"].cast<long>();
  r.extrapolation.outside_estimate = e["outside_estimate"].cast<long>();
  r.extrapolation.labelled = e["labelled"].cast<long>();
  r.extrapolation.outside_truth = e["outside_truth"].cast<long>();
  r.extrapolation.outside_truth_right = e["outside_truth_right"].cast<long>();
  r.extrapolation.inside_truth_right = e["inside_truth_right"].cast<long>();
  r.extrapolation.farthest = e["farthest"].cast<std::string>();
  r.extrapolation.farthest_beyond = e["farthest_beyond"].cast<double>();
  return r;
}

}  // namespace python
}  // namespace skidimm
