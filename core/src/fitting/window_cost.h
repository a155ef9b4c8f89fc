// The window objective's residuals: a log cut into prediction windows, each
// predicted from its measured start with the logged inputs and compared with
// the measurements after it (multiple shooting), as a Ceres cost with exact
// derivatives. Private to the fitting library (model_fitter.cc,
// condensed_windows.h).
#ifndef SKIDIMM_CORE_SRC_FITTING_WINDOW_COST_H_
#define SKIDIMM_CORE_SRC_FITTING_WINDOW_COST_H_

#include <ceres/ceres.h>

#include <Eigen/Core>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "measurement_layout.h"
#include "skidimm/fitting/trajectory.h"
#include "skidimm/sdk/motion_model.h"

namespace skidimm {
namespace fitting {
namespace internal {

// Some component of row k of t is measured.
inline bool any_measured(const Trajectory& t, int k) { return t.z.col(k).array().isFinite().any(); }

// A prediction window: from the fully measured row `start` to the measured
// rows `targets` after it, `residuals` measured components in all.
struct Window {
  const Trajectory* trajectory;
  int start;
  std::vector<int> targets;  // measured rows after start, in order
  int residuals;
};

// Calls visit(w) with each window of the log in turn, one Window reused: a
// long log's windows are never all held at once.
template <typename Visit>
void for_each_window(const MeasurementLayout& m, const Trajectory& t, double window, Visit&& visit) {
  // Times within this of a window's end belong to it: a 0.5 s window at 50 Hz
  // holds 25 rows whatever the rounding of the logged times.
  constexpr double kTimeTolerance = 1e-9;
  double next_start = -std::numeric_limits<double>::infinity();
  Window w{&t, 0, {}, 0};
  for (int start = 0; start < t.size(); ++start) {
    if (!fully_measured(m, t, start) || t.t[start] < next_start - kTimeTolerance) continue;
    w.start = start;
    w.targets.clear();
    w.residuals = 0;
    const double end = t.t[start] + window + kTimeTolerance;
    for (int k = start + 1; k < t.size(); ++k) {
      if (!any_measured(t, k)) continue;
      if (!w.targets.empty() && t.t[k] > end) break;
      w.targets.push_back(k);
      w.residuals += static_cast<int>(t.z.col(k).array().isFinite().count());
      if (window <= 0.0) break;  // one-step: the next measured row only
    }
    // Multi-step windows do not overlap (multiple shooting); one-step ones start at every fully measured row.
    next_start = window > 0.0 ? t.t[start] + window : -std::numeric_limits<double>::infinity();
    if (!w.targets.empty()) visit(static_cast<const Window&>(w));
  }
}

// "<log>: the prediction from step k (t = ...) to t = ... s", for messages.
std::string window_text(const Trajectory& t, const Window& w);

// Which entries of a model's flat parameter vector the problem's parameter
// block sets: block index -> model index.
struct ParameterMapping {
  std::vector<int> model_index;
  std::vector<int> block_index;
};

// What the windows of one model evaluate in: every window of a problem runs
// on the same model instance, one after the other (the solver runs one
// thread), so they share their buffers, and the parameters last given to the
// model: Ceres evaluates every window at the same point, and setting a
// model's parameters is not free (bounds checks, and for some models a
// matrix exponential).
struct WindowWorkspace {
  Eigen::VectorXd full;  // the model's flat parameters
  Eigen::VectorXd set;   // as last given to the model (empty: none yet)
  Eigen::VectorXd x, next, all_outputs, expected, predicted;
  Eigen::MatrixXd sensitivity, updated, f, g, output_g;
  Eigen::RowVectorXd d;
};

// The residuals of one window, each error divided by its measurement
// standard deviation. With `jacobians`, also their exact derivatives: the
// sensitivity S = dx/dtheta of the propagated state is carried through the
// window,
//   S_{k+1} = F_k S_k + df/dtheta|_k,   S_start = 0 (the start is measured),
// with F_k from jacobian() and df/dtheta from parameter_jacobian().
class WindowCost : public ceres::CostFunction {
 public:
  // Evaluates `window` of `model` (left at base with the block's entries
  // set through `mapping`); `workspace` is shared by every window of the model.
  WindowCost(sdk::MotionModel* model, Eigen::VectorXd base, ParameterMapping mapping, const MeasurementLayout* m,
             Window window, int block_size, std::shared_ptr<WindowWorkspace> workspace);

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    return EvaluateWindow(window_, parameters, residuals, jacobians);
  }

  // Evaluate() for any window of the mode's logs (CondensedWindows).
  bool EvaluateWindow(const Window& window, double const* const* parameters, double* residuals,
                      double** jacobians) const;

  // Why the model's last call failed, in its own words, or "" (sdk/failure.h).
  std::string model_failure() const {
    const char* reason = model_->failure_reason();
    return reason != nullptr ? reason : "";
  }

 private:
  sdk::MotionModel* model_;
  Eigen::VectorXd base_;
  ParameterMapping mapping_;
  const MeasurementLayout* m_;
  Window window_;
  std::vector<int> positions_;  // output_positions()
  std::shared_ptr<WindowWorkspace> w_;
};

// The same residuals for Ceres' numeric differentiation, for models without
// parameter_jacobian().
struct NumericWindowResidual {
  std::unique_ptr<WindowCost> cost;
  bool operator()(double const* const* parameters, double* residuals) const {
    return cost->Evaluate(parameters, residuals, nullptr);
  }
};

// True if the model gives exact parameter derivatives at the log's first
// row, of its outputs too when the bank measures some.
bool has_parameter_jacobian(const sdk::MotionModel& model, const MeasurementLayout& m, const Trajectory& t);

}  // namespace internal
}  // namespace fitting
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_FITTING_WINDOW_COST_H_
