// ImmEstimate: everything one IMM step produces.
#ifndef SKIDIMM_IMM_ESTIMATE_H_
#define SKIDIMM_IMM_ESTIMATE_H_

#include <Eigen/Core>
#include <string>
#include <vector>

namespace skidimm {

enum class StepStatus {
  kUpdated,           // prediction (unless first step) and measurement update
  kPredictOnly,       // no measurement: probabilities moved only through the chain
  kAllModesRejected,  // every mode's filter failed: treated as predict-only
  kRejectedTime,      // t did not increase: the step was ignored
  kRejectedInput,     // u had non-finite entries: the step was ignored
};

const char* to_string(StepStatus status);

// Why a mode's filter was rejected in a step.
enum class ModeFailure : unsigned char {
  kNone,
  kModel,      // the model's predict/jacobian/process_noise returned false (or threw): failure_reasons says why
  kNotFinite,  // the model returned a non-finite state, Jacobian or process noise
  kUpdate,     // the measurement update failed: innovation covariance not positive definite, or not finite
};

const char* to_string(ModeFailure failure);

struct ImmEstimate {
  double t = 0.0;
  StepStatus status = StepStatus::kUpdated;
  int num_measured = 0;        // measurement components used in the update
  int num_rejected_modes = 0;  // modes whose filter failed this step

  Eigen::VectorXd mode_probabilities;             // mu_k^j, sums to 1 (eq. 9 with c_j)
  Eigen::VectorXd log_likelihoods;                // log Lambda_k^j; NaN on predict-only, -inf if rejected
  Eigen::VectorXd nis;                            // nu' S^-1 nu per mode; NaN when not updated
  std::vector<ModeFailure> mode_failures;         // per mode: kNone unless its filter was rejected this step
  std::vector<std::string> failure_reasons;       // per mode: the model's reason, where mode_failures is kModel
  std::vector<Eigen::VectorXd> mode_states;       // x_k^{+j}
  std::vector<Eigen::MatrixXd> mode_covariances;  // P_k^{+j}
  Eigen::VectorXd state;                          // combined, eq. 10
  Eigen::MatrixXd covariance;                     // combined, eq. 11
  int most_likely_mode = 0;
};

}  // namespace skidimm

#endif  // SKIDIMM_IMM_ESTIMATE_H_
