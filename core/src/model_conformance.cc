#include "skidimm/engine/model_conformance.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "skidimm/engine/measurement_model.h"
#include "skidimm/errors.h"
#include "skidimm/sdk/angles.h"

namespace skidimm {

std::vector<LogOperatingPoint> operating_points_from_log(const BankConfig& bank, const LogSpec& log, int count,
                                                         std::vector<std::string>* unmeasured,
                                                         std::vector<std::string>* labels) {
  if (labels != nullptr) {
    labels->clear();
    if (!log.label.empty()) labels->push_back(log.label);
  }
  const MeasurementModel measurement(bank.measurement.h, bank.measurement.r, bank.measurement.is_angle);
  LogReader reader(bank, log.files, bank.sampling);
  Eigen::VectorXd x = bank.initial_state;
  // Every stride-th step is kept; when twice `count` are kept past the
  // first `count`, every other one is dropped and the stride doubles, so the
  // kept steps stay evenly spread over a log of any length in bounded memory.
  std::vector<LogOperatingPoint> kept;
  long stride = 1, step = 0;
  double previous_t = 0.0;
  LogSample sample;
  while (reader.next(&sample)) {
    if (labels != nullptr && log.label.empty() && !sample.truth_mode.empty() && labels->size() < kMostLabelsListed &&
        std::find(labels->begin(), labels->end(), sample.truth_mode) == labels->end()) {
      labels->push_back(sample.truth_mode);
    }
    for (int row = 0; row < measurement.measurement_dim(); ++row) {
      const int s = measurement.picked_state(row);
      if (s >= 0 && s < x.size() && std::isfinite(sample.z[row])) x[s] = sample.z[row];
    }
    const double dt = sample.t - previous_t;
    const bool first = step++ == 0;
    previous_t = sample.t;
    if (first || !(dt > 0.0) || !sample.u.allFinite() || (step - 2) % stride != 0) continue;
    LogOperatingPoint point;
    point.point.x = x;
    for (int s = 0; s < bank.state_dim(); ++s) {
      if (bank.angle_mask[static_cast<std::size_t>(s)]) point.point.x[s] = sdk::wrap_angle(point.point.x[s]);
    }
    point.point.u = sample.u;
    point.point.dt = dt;
    point.log = log.text;
    point.row = sample.row;
    point.t = sample.t;
    kept.push_back(std::move(point));
    if (static_cast<int>(kept.size()) >= 4 * std::max(count, 1)) {
      std::vector<LogOperatingPoint> halved;
      for (std::size_t i = 0; i < kept.size(); i += 2) halved.push_back(std::move(kept[i]));
      kept = std::move(halved);
      stride *= 2;
    }
  }
  if (unmeasured != nullptr) *unmeasured = reader.unmeasured(bank);
  if (kept.empty()) {
    throw LogError(log.text, 0, "no step to check the models at: the log needs two steps with every input given");
  }
  if (static_cast<int>(kept.size()) <= count) return kept;
  std::vector<LogOperatingPoint> points;
  for (int k = 0; k < count; ++k) {
    // The first and the last kept step, and evenly between.
    const std::size_t i =
        count == 1
            ? 0
            : static_cast<std::size_t>(std::llround(static_cast<double>(k) * static_cast<double>(kept.size() - 1) /
                                                    static_cast<double>(count - 1)));
    points.push_back(kept[i]);
  }
  return points;
}

std::vector<ModeConformance> check_models(const Bank& bank, const std::vector<LogOperatingPoint>& points) {
  std::vector<ModeConformance> results;
  for (std::size_t j = 0; j < bank.models.size(); ++j) {
    ModeConformance result;
    result.mode = bank.config.modes[j].name;
    sdk::MotionModel& model = *bank.models[j];
    for (const LogOperatingPoint& p : points) {
      ++result.points;
      std::vector<std::string> failures = sdk::testing::motion_model_failures(model, p.point.x, p.point.u, p.point.dt);
      if (failures.empty()) continue;
      if (result.failed_points++ == 0) {
        result.first_failure_at = p.log + " step " + std::to_string(p.row) + " (t = " + std::to_string(p.t) + ")";
        result.failures = std::move(failures);
      }
    }
    results.push_back(std::move(result));
  }
  return results;
}

}  // namespace skidimm
