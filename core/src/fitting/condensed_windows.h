// The window objective condensed into one residual block whose memory does
// not grow with the logs. Private to the fitting library (model_fitter.cc).
#ifndef SKIDIMM_CORE_SRC_FITTING_CONDENSED_WINDOWS_H_
#define SKIDIMM_CORE_SRC_FITTING_CONDENSED_WINDOWS_H_

#include <ceres/ceres.h>

#include <Eigen/Core>
#include <memory>
#include <vector>

#include "measurement_layout.h"
#include "skidimm/fitting/trajectory.h"
#include "window_cost.h"

namespace skidimm {
namespace fitting {
namespace internal {

// Every window of a problem as one residual block of p + 1 residuals (p
// parameters) that Ceres' Levenberg-Marquardt solver cannot tell from the
// windows' own: the same cost, gradient and Gauss-Newton matrix. Each
// evaluation runs through the windows once, accumulating
//   C = 1/2 sum_w rho(|r_w|^2),  g = sum_w J_w' r_w,  H = sum_w J_w' J_w
// (r_w, J_w corrected for the robust loss as Ceres corrects them: Triggs et
// al., "Bundle adjustment: a modern synthesis", 2000), and returns
//   r = [L^-1 g; sqrt(2C - |L^-1 g|^2)],  J = [L'; 0],  H = L L'
// (L from H's eigenvalues, so a direction the logs do not excite is a zero
// singular value of J, as in the windows' own Jacobian). Its memory is the
// p x p sums, whatever the rows; the windows' Jacobians are never stored.
class CondensedWindows : public ceres::CostFunction {
 public:
  struct Log {
    const WindowCost* windows;  // evaluates any window of the log's mode
    const Trajectory* trajectory;
    const MeasurementLayout* layout;
  };
  CondensedWindows(std::vector<Log> logs, double window, int block_size, int most_residuals,
                   std::unique_ptr<ceres::LossFunction> loss)
      : logs_(std::move(logs)), window_(window), loss_(std::move(loss)), p_(block_size) {
    mutable_parameter_block_sizes()->push_back(block_size);
    set_num_residuals(block_size + 1);
    r_.resize(most_residuals);
    j_.resize(most_residuals, block_size);
    h_.resize(block_size, block_size);
    g_.resize(block_size);
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override;

 private:
  // H += j' j (its lower triangle), g += j' r.
  template <typename J, typename R>
  void accumulate(const J& j, const R& r) const;

  std::vector<Log> logs_;
  double window_;
  std::unique_ptr<ceres::LossFunction> loss_;
  int p_;
  mutable Eigen::VectorXd r_;
  mutable Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> j_;  // as Ceres lays a Jacobian out
  mutable Eigen::MatrixXd h_;
  mutable Eigen::VectorXd g_;
};

}  // namespace internal
}  // namespace fitting
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_FITTING_CONDENSED_WINDOWS_H_
