#include "measurement_layout.h"

#include <cstdio>

#include "measured_outputs.h"
#include "skidimm/engine/measurement_model.h"
#include "skidimm/fitting/model_fitter.h"

namespace skidimm {
namespace fitting {
namespace internal {

std::string miss_text(double sigmas) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3g", sigmas);
  return text;
}

MeasurementLayout layout_of(const BankConfig& bank, int mode) {
  MeasurementLayout m;
  const MeasurementConfig& mc = bank.measurement;
  const Eigen::MatrixXd& r = bank.measurement_noise(mode);
  m.h = mc.h;
  m.sigma = r.diagonal().cwiseSqrt();
  m.row_is_angle = mc.is_angle;
  m.state_is_angle = bank.angle_mask;
  const int n = bank.state_dim();
  m.state_row.assign(n, -1);
  const MeasurementModel measurement(mc.h, mc.r, mc.is_angle);
  m.every_row_picks = true;
  for (int row = 0; row < measurement.measurement_dim(); ++row) {
    const int s = measurement.picked_state(row);
    if (s >= 0 && m.state_row[static_cast<std::size_t>(s)] < 0) m.state_row[static_cast<std::size_t>(s)] = row;
    m.row_picks.push_back(s);
    m.every_row_picks = m.every_row_picks && s >= 0;
  }
  std::string missing;
  for (int s = 0; s < n; ++s) {
    if (m.state_row[s] < 0) missing += (missing.empty() ? "" : ", ") + bank.state_names[s];
  }
  if (!missing.empty()) {
    throw FitError("fitting starts predictions from measured states, but the bank does not measure [" + missing +
                   "] directly; list every state under measurement.observe");
  }
  m.r_state.resize(n, n);
  for (int a = 0; a < n; ++a) {
    for (int b = 0; b < n; ++b) m.r_state(a, b) = r(m.state_row[a], m.state_row[b]);
  }
  m.outputs = mc.outputs;
  m.first_output_row = mc.first_output_row();
  return m;
}

std::vector<int> output_positions(const sdk::MotionModel& model, const MeasurementLayout& m) {
  const std::vector<int> positions = output_indices(model, m.outputs);
  for (std::size_t k = 0; k < positions.size(); ++k) {
    if (positions[k] < 0) throw FitError("the model has no output '" + m.outputs[k] + "', which the bank measures");
  }
  return positions;
}

bool expected_outputs(const sdk::MotionModel& model, const MeasurementLayout& m, const std::vector<int>& positions,
                      const Eigen::Ref<const Eigen::VectorXd>& u, Eigen::VectorXd* all, Eigen::VectorXd* expected) {
  if (m.outputs.empty()) return true;
  all->resize(static_cast<Eigen::Index>(model.output_names().size()));
  if (!model.outputs(u, *all)) return false;
  for (std::size_t k = 0; k < positions.size(); ++k) {
    (*expected)[m.first_output_row + static_cast<Eigen::Index>(k)] = (*all)[positions[k]];
  }
  return expected->allFinite();
}

}  // namespace internal
}  // namespace fitting
}  // namespace skidimm
