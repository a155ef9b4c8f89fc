// ImmEstimate: everything one IMM step produces.
#ifndef SKIDIMM_ENGINE_IMM_ESTIMATE_H_
#define SKIDIMM_ENGINE_IMM_ESTIMATE_H_

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
  // (Appended, so that the codes above keep their numbers.)
  kGated,      // every mode that ran gated the measurement (innovation_gate): treated as predict-only
  kModeGated,  // some modes gated the measurement, the others applied it
  kModeReset,  // some modes' filters failed or diverged and were reset; the others ran
};

const char* to_string(StepStatus status);

// Why a mode's filter was rejected in a step.
enum class ModeFailure : unsigned char {
  kNone,
  kModel,      // the model's predict/jacobian/process_noise returned false (or threw): failure_reasons says why
  kNotFinite,  // the model returned a non-finite state, Jacobian or process noise
  kUpdate,     // the measurement update failed: innovation covariance not positive definite, or not finite
  kDiverged,   // the filter's state or covariance became absurd (filter_health.h): reset
  kGated,      // not a failure: the measurement was outside this mode's innovation gate and not applied
};

constexpr int kNumModeFailures = 6;

// Whether mode j's filter was rejected (and reset) in the step: any failure
// but a gated measurement.
inline bool is_rejection(ModeFailure failure) {
  return failure != ModeFailure::kNone && failure != ModeFailure::kGated;
}

const char* to_string(ModeFailure failure);

// Whether the unknown hypothesis (BankConfig::unknown), at probability
// `unknown`, outweighs the most likely alternative (a mode, or a class), at
// probability `best`: the estimate then reads "unknown". For filtered and
// smoothed estimates and for their scores alike.
inline bool unknown_outweighs(double unknown, double best) { return unknown > 0.0 && unknown > best; }

struct ImmEstimate {
  double t = 0.0;
  StepStatus status = StepStatus::kUpdated;
  int num_measured = 0;        // measurement components used in the update
  int num_rejected_modes = 0;  // modes whose filter failed (or diverged) this step, and were reset
  int num_gated_modes = 0;     // modes that gated the measurement this step (innovation_gate)

  // mu_k^j (eq. 9 with c_j): sums to 1, or to 1 - unknown_probability when
  // the bank has an unknown hypothesis.
  Eigen::VectorXd mode_probabilities;
  // The probability of "none of these" (BankConfig::unknown); 0 without one.
  double unknown_probability = 0.0;
  // log Lambda_k^j; NaN on predict-only, -inf if rejected; for a gated mode
  // the likelihood it was scored with (docs/engine.md, innovation gate).
  Eigen::VectorXd log_likelihoods;
  Eigen::VectorXd nis;                            // nu' S^-1 nu per mode (also when gated); NaN when not updated
  std::vector<ModeFailure> mode_failures;         // per mode: kNone unless rejected or gated this step
  std::vector<std::string> failure_reasons;       // per mode: the model's reason, where mode_failures is kModel
  std::vector<Eigen::VectorXd> mode_states;       // x_k^{+j}
  std::vector<Eigen::MatrixXd> mode_covariances;  // P_k^{+j}
  Eigen::VectorXd state;                          // combined, eq. 10
  Eigen::MatrixXd covariance;                     // combined, eq. 11
  int most_likely_mode = 0;  // of the modes, even when unknown_is_most_likely()
  // Whether "none of these" outweighs every single mode.
  bool unknown_is_most_likely() const {
    return unknown_outweighs(unknown_probability, mode_probabilities[most_likely_mode]);
  }
  // Whether the step had a measurement (what keeps a decision current,
  // decision.h): not a step the engine ignored, which returns the last
  // step's estimate, its num_measured included.
  bool measured() const {
    return num_measured > 0 && status != StepStatus::kRejectedTime && status != StepStatus::kRejectedInput;
  }
};

}  // namespace skidimm

#endif  // SKIDIMM_ENGINE_IMM_ESTIMATE_H_
