// Where a bank measures each state of a mode, as the window fit and the
// process-noise search read logs (window_cost.h, process_noise_search.cc).
// Private to the fitting library.
#ifndef SKIDIMM_CORE_SRC_FITTING_MEASUREMENT_LAYOUT_H_
#define SKIDIMM_CORE_SRC_FITTING_MEASUREMENT_LAYOUT_H_

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "skidimm/config/bank.h"
#include "skidimm/fitting/trajectory.h"
#include "skidimm/sdk/angles.h"
#include "skidimm/sdk/motion_model.h"

namespace skidimm {
namespace fitting {
namespace internal {

// Where each state is measured: state i is row state_row[i] of z (a row of H
// that picks that state alone). Fitting starts predictions from measured
// states, so every state must be measured directly.
struct MeasurementLayout {
  std::vector<int> state_row;
  Eigen::MatrixXd h;
  Eigen::VectorXd sigma;  // sqrt(R_ii)
  std::vector<bool> row_is_angle;
  std::vector<bool> state_is_angle;
  Eigen::MatrixXd r_state;  // R in state order
  // The model outputs measured (measurement.outputs): rows first_output_row
  // on, where H is zero and the prediction is the model's outputs().
  std::vector<std::string> outputs;
  int first_output_row = 0;
  // Per row of z, the state it picks alone (a 1 there, 0 elsewhere in H),
  // or -1; every_row_picks: no output rows, and no row measuring a sum.
  std::vector<int> row_picks;
  bool every_row_picks = false;
};

// `mode`'s layout: its residuals are weighed by its own R where it has one
// (R: in its entry), the noise its filter assumes; else by the bank's.
// Throws FitError if a state is not measured directly.
MeasurementLayout layout_of(const BankConfig& bank, int mode);

// Where each output the bank measures is in `model`'s outputs(). Throws
// FitError if the model lacks one.
std::vector<int> output_positions(const sdk::MotionModel& model, const MeasurementLayout& m);

// The measurement the model predicts besides H x: zero on the state rows,
// its outputs at input u on the output rows. False if outputs() fails or is
// not finite.
bool expected_outputs(const sdk::MotionModel& model, const MeasurementLayout& m, const std::vector<int>& positions,
                      const Eigen::Ref<const Eigen::VectorXd>& u, Eigen::VectorXd* all, Eigen::VectorXd* expected);

// Every state is measured at row k of t.
inline bool fully_measured(const MeasurementLayout& m, const Trajectory& t, int k) {
  for (int row : m.state_row) {
    if (!std::isfinite(t.z(row, k))) return false;
  }
  return true;
}

// The state as measured at row k of t.
inline Eigen::VectorXd measured_state(const MeasurementLayout& m, const Trajectory& t, int k) {
  Eigen::VectorXd x(static_cast<Eigen::Index>(m.state_row.size()));
  for (std::size_t s = 0; s < m.state_row.size(); ++s) x[static_cast<Eigen::Index>(s)] = t.z(m.state_row[s], k);
  return x;
}

// Calls f(component, error) for each measured component of row `target`,
// with error = z - H x - expected (wrapped for angles); expected holds the
// model's outputs on the output rows (expected_outputs()).
template <typename F>
void for_each_error(const MeasurementLayout& m, const Trajectory& t, int target, const Eigen::VectorXd& x,
                    const Eigen::VectorXd& expected, F&& f) {
  const Eigen::VectorXd predicted = m.h * x + expected;
  for (Eigen::Index c = 0; c < t.z.rows(); ++c) {
    if (!std::isfinite(t.z(c, target))) continue;
    double e = t.z(c, target) - predicted[c];
    if (m.row_is_angle[c]) e = sdk::wrap_angle(e);
    f(c, e);
  }
}

// How many times the median miss (at least one sigma of R) a window or a
// one-step prediction may miss its measurements by before it is called a
// corrupt cell rather than a poor model: a start far off a robot's dynamics
// misses by tens of sigma, a cell of 1e100 by 1e90.
inline constexpr double kAbsurdMissRatio = 1e6;

// Whether the largest miss, against the median miss (both in sigma of R),
// is a corrupt cell by kAbsurdMissRatio (a NaN miss is).
inline bool is_absurd_miss(double largest, double median) {
  return !(largest <= kAbsurdMissRatio * std::max(1.0, median));
}

// A miss in sigma of R as the error messages give it, three digits.
std::string miss_text(double sigmas);

}  // namespace internal
}  // namespace fitting
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_FITTING_MEASUREMENT_LAYOUT_H_
