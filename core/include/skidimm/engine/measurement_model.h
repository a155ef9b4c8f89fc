// MeasurementModel: z = H x + v, v ~ N(0, R), shared by every mode of a bank.
//
// A row of z may be missing (NaN) at a step: a 10 Hz GPS inside a 100 Hz IMU
// log. select() keeps the rows present, so the update uses exactly the
// components measured, and does so in preallocated storage.
#ifndef SKIDIMM_ENGINE_MEASUREMENT_MODEL_H_
#define SKIDIMM_ENGINE_MEASUREMENT_MODEL_H_

#include <Eigen/Core>
#include <vector>

namespace skidimm {

// The measured subset of one step, in the leading rows/columns of
// capacity-sized storage (size() rows are valid).
struct SelectedMeasurement {
  int size = 0;
  Eigen::VectorXd z;           // measured values
  Eigen::MatrixXd h;           // selected rows of H
  Eigen::MatrixXd r;           // selected block of R
  std::vector<bool> is_angle;  // row wraps at +-pi
  std::vector<int> rows;       // which rows of the full z
  // When every selected row of H picks one state alone (a 1 there, 0
  // elsewhere: the state is measured directly, the common case), the state
  // each picks, and picks_states is true: the filter then gathers rows and
  // columns of P where it would multiply by H (ekf.cc).
  std::vector<int> picked_state;
  bool picks_states = false;
};

class MeasurementModel {
 public:
  // h: m x n, r: m x m. is_angle[i]: row i measures an angle directly.
  MeasurementModel(Eigen::MatrixXd h, Eigen::MatrixXd r, std::vector<bool> is_angle);

  int measurement_dim() const { return static_cast<int>(h_.rows()); }
  int state_dim() const { return static_cast<int>(h_.cols()); }
  const Eigen::MatrixXd& h() const { return h_; }
  const Eigen::MatrixXd& r() const { return r_; }
  bool is_angle(int row) const { return is_angle_[row]; }
  // The state row `row` of H measures alone (a 1 there, 0 elsewhere), or -1.
  int picked_state(int row) const { return picked_state_[static_cast<std::size_t>(row)]; }

  // Storage sized for the full measurement, to pass to select().
  SelectedMeasurement make_selection() const;
  // Keeps the finite rows of z. Allocates nothing.
  void select(const Eigen::Ref<const Eigen::VectorXd>& z, SelectedMeasurement* out) const;
  // Writes the block of `r` (m x m) over out's selected rows into out->r:
  // what select() does with this model's R, for another R over the same rows
  // (a mode's own). Allocates nothing.
  static void select_noise(const Eigen::MatrixXd& r, SelectedMeasurement* out);

 private:
  Eigen::MatrixXd h_;
  Eigen::MatrixXd r_;
  std::vector<bool> is_angle_;
  std::vector<int> picked_state_;  // per row of H: the state it picks alone, or -1
};

}  // namespace skidimm

#endif  // SKIDIMM_ENGINE_MEASUREMENT_MODEL_H_
