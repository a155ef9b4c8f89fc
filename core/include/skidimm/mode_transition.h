// ModeTransition: the Markov chain that switches modes between steps.
//
// p_ij = P(mode j at step k | mode i at step k-1): row = from, column = to,
// rows sum to 1 (Bar-Shalom et al. 2001, section 11.6; paper eq. 4-5).
//
// Two kinds:
//  * per step: a fixed matrix used at every step, whatever dt is. Simple, and
//    right for uniformly sampled logs.
//  * continuous: a generator Pi_c built from mean dwell times tau_i (mode i is
//    left at rate 1/tau_i, to every other mode with equal probability), and
//    P(dt) = expm(Pi_c dt) per step, so that irregular sampling keeps the same
//    switching statistics in seconds.
//
// matrix(dt) allocates nothing after construction: the exponential is computed
// by uniformisation with scaling and squaring in preallocated workspaces, in
// closed form when all dwell times are equal, and cached for repeated dt.
#ifndef SKIDIMM_MODE_TRANSITION_H_
#define SKIDIMM_MODE_TRANSITION_H_

#include <Eigen/Core>

namespace skidimm {

// The `transition:` of a bank (docs/bank-format.md).
struct TransitionConfig {
  enum class Kind { kMatrix, kStay, kDwellTimes };
  Kind kind = Kind::kStay;
  Eigen::MatrixXd matrix;         // kMatrix: per-step p_ij, row = from
  double stay = 0.95;             // kStay: per-step probability of staying
  Eigen::VectorXd dwell_seconds;  // kDwellTimes: mean time in each mode
};

class ModeTransition {
 public:
  // The chain a bank's `transition:` describes, for `num_modes` modes.
  static ModeTransition from_config(const TransitionConfig& config, int num_modes);
  // A per-step matrix. Checked by the bank loader; here only asserted square.
  static ModeTransition per_step(const Eigen::MatrixXd& matrix);
  // Equal stay probability on the diagonal, the rest spread evenly.
  static ModeTransition per_step_stay(int num_modes, double stay_probability);
  // Continuous-time chain from mean dwell times in seconds (all > 0).
  static ModeTransition from_dwell_times(const Eigen::VectorXd& mean_dwell_seconds);

  int num_modes() const { return static_cast<int>(matrix_.rows()); }
  bool is_continuous() const { return continuous_; }
  // The generator Pi_c (zero for per-step transitions).
  const Eigen::MatrixXd& generator() const { return generator_; }

  // Transition matrix for a step of dt > 0 seconds.
  const Eigen::MatrixXd& matrix(double dt);

 private:
  ModeTransition() = default;
  void exponentiate(double dt);

  bool continuous_ = false;
  bool uniform_rates_ = false;
  double cached_dt_ = -1.0;
  double max_rate_ = 0.0;
  Eigen::MatrixXd matrix_;
  Eigen::MatrixXd generator_;
  Eigen::MatrixXd jump_;  // I + Pi_c / max_rate: the uniformised chain
  Eigen::MatrixXd power_;
  Eigen::MatrixXd scratch_;
};

}  // namespace skidimm

#endif  // SKIDIMM_MODE_TRANSITION_H_
