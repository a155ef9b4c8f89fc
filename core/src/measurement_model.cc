#include "skidimm/engine/measurement_model.h"

#include <cmath>
#include <utility>

#include "check.h"

namespace skidimm {

MeasurementModel::MeasurementModel(Eigen::MatrixXd h, Eigen::MatrixXd r, std::vector<bool> is_angle)
    : h_(std::move(h)), r_(std::move(r)), is_angle_(std::move(is_angle)) {
  SKIDIMM_CHECK(r_.rows() == h_.rows() && r_.cols() == h_.rows(), "R must be m x m for an m-row H");
  SKIDIMM_CHECK(static_cast<Eigen::Index>(is_angle_.size()) == h_.rows(), "one angle flag per row of H");
  picked_state_.assign(static_cast<std::size_t>(h_.rows()), -1);
  for (Eigen::Index row = 0; row < h_.rows(); ++row) {
    Eigen::Index state = -1;
    const bool one_unit_entry = (h_.row(row).array() != 0.0).count() == 1 && h_.row(row).maxCoeff(&state) == 1.0;
    if (one_unit_entry) picked_state_[static_cast<std::size_t>(row)] = static_cast<int>(state);
  }
}

SelectedMeasurement MeasurementModel::make_selection() const {
  SelectedMeasurement s;
  const Eigen::Index m = h_.rows();
  s.z.resize(m);
  s.h.resize(m, h_.cols());
  s.r.resize(m, m);
  s.is_angle.assign(m, false);
  s.rows.assign(m, 0);
  s.picked_state.assign(m, -1);
  return s;
}

void MeasurementModel::select(const Eigen::Ref<const Eigen::VectorXd>& z, SelectedMeasurement* out) const {
  SKIDIMM_CHECK(z.size() == h_.rows(), "measurement vector has the wrong size");
  int k = 0;
  for (Eigen::Index i = 0; i < z.size(); ++i) {
    if (std::isfinite(z[i])) out->rows[k++] = static_cast<int>(i);
  }
  out->size = k;
  out->picks_states = true;
  for (int a = 0; a < k; ++a) {
    const int row = out->rows[a];
    out->picked_state[a] = picked_state_[static_cast<std::size_t>(row)];
    out->picks_states = out->picks_states && out->picked_state[a] >= 0;
    out->z[a] = z[row];
    out->h.row(a) = h_.row(row);
    out->is_angle[a] = is_angle_[row];
  }
  select_noise(r_, out);
}

void MeasurementModel::select_noise(const Eigen::MatrixXd& r, SelectedMeasurement* out) {
  for (int a = 0; a < out->size; ++a) {
    for (int b = 0; b < out->size; ++b) out->r(a, b) = r(out->rows[a], out->rows[b]);
  }
}

}  // namespace skidimm
