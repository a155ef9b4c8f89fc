// The engine's view of a mode with parameter uncertainty
// (skidimm/engine/parameter_uncertainty.h): its process noise is the
// wrapped model's plus G Sigma G'. When the wrapped model's F and Qd depend
// on the step's dt alone (sdk::MotionModel::jacobian_and_noise_depend_only_on_dt),
// the filters keep them for as long as dt repeats, as for any such model,
// and add only G Sigma G' at each step: the same sums, so the same results
// to the bit.
#ifndef SKIDIMM_CORE_SRC_PARAMETER_NOISE_H_
#define SKIDIMM_CORE_SRC_PARAMETER_NOISE_H_

#include <Eigen/Core>

#include "skidimm/sdk/motion_model.h"

namespace skidimm {
namespace internal {

// The model `model` adds parameter uncertainty to, or nullptr when it adds
// none.
const sdk::MotionModel* model_under_parameter_uncertainty(const sdk::MotionModel& model);

// noise += G Sigma G' at (x, u, dt) for a model with parameter uncertainty;
// false (with the reason in model.failure_reason()) if its parameter
// Jacobian fails.
bool add_parameter_noise(const sdk::MotionModel& model, const Eigen::Ref<const Eigen::VectorXd>& x,
                         const Eigen::Ref<const Eigen::VectorXd>& u, double dt, Eigen::Ref<Eigen::MatrixXd> noise);

}  // namespace internal
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_PARAMETER_NOISE_H_
