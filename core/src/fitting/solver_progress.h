// A Ceres iteration callback that reports each iteration of a solve to a
// fit's progress function (FitOptions::progress), so a long fit is seen to
// advance. It never stops the solver.
#ifndef SKIDIMM_FITTING_SOLVER_PROGRESS_H_
#define SKIDIMM_FITTING_SOLVER_PROGRESS_H_

#include <ceres/iteration_callback.h>

#include <string>
#include <utility>

#include "skidimm/fitting/model_fitter.h"

namespace skidimm {
namespace fitting {

class SolverProgress final : public ceres::IterationCallback {
 public:
  // `what` is fitted; iterations are counted from `first_iteration` (a solve
  // run in several parts continues the count).
  SolverProgress(const FitProgress& report, std::string what, int first_iteration = 0)
      : report_(report), what_(std::move(what)), first_iteration_(first_iteration) {}

  ceres::CallbackReturnType operator()(const ceres::IterationSummary& summary) override {
    if (report_ && summary.iteration > 0) report_(what_, first_iteration_ + summary.iteration);
    return ceres::SOLVER_CONTINUE;
  }

 private:
  const FitProgress& report_;
  std::string what_;
  int first_iteration_;
};

}  // namespace fitting
}  // namespace skidimm

#endif  // SKIDIMM_FITTING_SOLVER_PROGRESS_H_
