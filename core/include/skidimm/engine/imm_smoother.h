// ImmSmoother: mode probabilities and states given the whole log, not only
// its past (fixed-interval), or given a few seconds of its future
// (fixed-lag), from the IMM's forward pass.
//
// The algorithm is Kim's smoother for Markov-switching state-space models
// (C.-J. Kim, "Dynamic linear models with Markov-switching", J. Econometrics
// 60, 1994; Kim & Nelson, "State-Space Models with Regime Switching", MIT
// Press 1999, section 5.2), run backwards over the IMM filter's mode-matched
// estimates. With mu_k^j, x_k^j, P_k^j the filtered probability, state and
// covariance of mode j at step k, p_ji the transition from j (at k) to i (at
// k+1) for that step's dt, and c^i = sum_j p_ji mu_k^j:
//
//   mode pairs:  mu_{k,k+1|N}^{ji} = mu_{k+1|N}^i p_ji mu_k^j / c^i,   mu_{k|N}^j = sum_i mu_{k,k+1|N}^{ji}
//   per pair, a Rauch-Tung-Striebel step through mode i's model:
//     x^ji = f_i(x_k^j, u_k, dt),  F = df_i/dx,  P^ji = F P_k^j F' + Qd_i,  J = P_k^j F' (P^ji)^-1
//     x_{k|N}^{ji} = x_k^j + J (x_{k+1|N}^i - x^ji),  P_{k|N}^{ji} = P_k^j + J (P_{k+1|N}^i - P^ji) J'
//   collapsed over i with weights mu_{k,k+1|N}^{ji} / mu_{k|N}^j (moment matching,
//   angles on the circle), then over j with mu_{k|N}^j, as the filter combines.
//
// Approximations, stated plainly: (1) P(m_k = j | m_{k+1} = i, all data) is
// taken as P(m_k = j | m_{k+1} = i, data up to k), which is exact when the
// measurements after k depend on m_k only through m_{k+1} (as in a hidden
// Markov model, where this smoother is the exact forward-backward), and not
// for switching dynamics, where future data also carry information about the
// state x_k; (2) the mixtures are collapsed to one Gaussian per mode, as the
// IMM does; (3) for nonlinear models, F is the Jacobian at the filtered state,
// as in an extended RTS smoother. Steps without a measurement are smoothed
// like any other (their filtered probabilities are the predicted ones).
//
// Cost: O(N^2 n^3) per step backwards (a prediction per mode pair), the same
// order as the filter's mixing. Memory: the fixed-interval smoother keeps
// every forward step; the fixed-lag one only its window. The fixed-lag
// smoother smooths its window again for each step it releases, but predicts
// each pair of a step once (PairPredictions): a step then costs one
// prediction per pair and, per step of the window, one correction per pair.
#ifndef SKIDIMM_ENGINE_IMM_SMOOTHER_H_
#define SKIDIMM_ENGINE_IMM_SMOOTHER_H_

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <cstddef>
#include <deque>
#include <vector>

#include "skidimm/config/bank.h"
#include "skidimm/engine/imm_estimate.h"
#include "skidimm/engine/mode_transition.h"

namespace skidimm {

// What the smoother needs of one forward step.
struct ForwardStep {
  double t = 0.0;
  Eigen::VectorXd u;  // the input given at t: it drives the prediction to the next step
  Eigen::VectorXd mode_probabilities;
  double unknown_probability = 0.0;  // the bank's unknown hypothesis (0 without one)
  std::vector<Eigen::VectorXd> mode_states;
  std::vector<Eigen::MatrixXd> mode_covariances;
};

// Records a step the IMM accepted (not rejected_time or rejected_input).
ForwardStep record_step(double t, const Eigen::Ref<const Eigen::VectorXd>& u, const ImmEstimate& estimate);

// A smoothed step, in the shape of the filter's estimate.
struct SmoothedStep {
  double t = 0.0;
  Eigen::VectorXd mode_probabilities;  // with an unknown hypothesis, they sum to 1 - unknown_probability
  double unknown_probability = 0.0;
  std::vector<Eigen::VectorXd> mode_states;
  std::vector<Eigen::MatrixXd> mode_covariances;
  Eigen::VectorXd state;
  Eigen::MatrixXd covariance;
  int most_likely_mode = 0;  // of the modes, even when unknown_is_most_likely()
  // As ImmEstimate::unknown_is_most_likely().
  bool unknown_is_most_likely() const {
    return unknown_outweighs(unknown_probability, mode_probabilities[most_likely_mode]);
  }
};

class ImmSmoother {
 public:
  // `bank` (its models, transition, floor) must outlive the smoother.
  explicit ImmSmoother(const Bank& bank);
  // A temporary bank would be gone before the first smooth(): refused at compile time.
  explicit ImmSmoother(Bank&& bank) = delete;

  // Fixed-interval smoothing of a whole forward pass: out[k] for forward[k].
  void smooth(const std::vector<ForwardStep>& forward, std::vector<SmoothedStep>* out);
  // The same over a window of steps, the last one's smoothed estimate being
  // its filtered one. Used by the fixed-lag smoother on its window.
  void smooth(const std::deque<ForwardStep>& forward, std::vector<SmoothedStep>* out);

  // What the RTS steps of one step's mode pairs take from the forward pass
  // alone: for the pair (mode j at k, mode i at k+1), mode j's filtered
  // estimate predicted through mode i's model (x^ji, P^ji) and the gain J.
  // Only the correction depends on the smoothed step k+1. A fixed-lag window
  // smooths each of its steps again for every step it releases, and these
  // stay the same, so FixedLagSmoother keeps them while it holds the step.
  struct PairPredictions {
    std::vector<double> predicted;     // x^ji, n for each pair j * N + i
    std::vector<double> covariance;    // P^ji, n x n column-major for each pair
    std::vector<double> gain;          // J, n x n for each pair
    std::vector<unsigned char> sound;  // 0: the pair cannot be smoothed and keeps mode j's filtered estimate
    // The bytes of its numbers (what FixedLagSmoother's budget counts).
    std::size_t bytes() const {
      return (predicted.size() + covariance.size() + gain.size()) * sizeof(double) + sound.size();
    }
  };
  // The predictions of step k's pairs to the step at t_next into *out.
  void predict_pairs(const ForwardStep& k, double t_next, PairPredictions* out);
  // smooth() of a window whose pairs are predicted already: pairs[k] those
  // of forward[k] to forward[k + 1] (predict_pairs() by a smoother of the
  // same bank), for every step but the last. The same result, bit for bit.
  // Throws std::invalid_argument for a count or an entry of the wrong size.
  void smooth(const std::deque<ForwardStep>& forward, const std::deque<PairPredictions>& pairs,
              std::vector<SmoothedStep>* out);

 private:
  // pairs_of(k): the PairPredictions of forward[k] (to forward[k + 1]).
  template <typename Steps, typename PairsOf>
  void smooth_range(const Steps& forward, const PairsOf& pairs_of, std::vector<SmoothedStep>* out);
  // smooth_range() predicting each step's pairs as it comes to it.
  template <typename Steps>
  void smooth_predicting(const Steps& forward, std::vector<SmoothedStep>* out);
  // From the smoothed step k+1, the filtered k and its pairs' predictions to the smoothed k.
  void backward(const ForwardStep& k, double t_next, const PairPredictions& pairs, const SmoothedStep& next,
                SmoothedStep* out);
  // What one pair's RTS step works in: N states known at compile time (on
  // the stack), or Eigen::Dynamic (the smoother's own, sized once).
  template <int N>
  struct PairWorkspace {
    Eigen::Matrix<double, N, 1> predicted, difference;
    Eigen::Matrix<double, N, N> f, q, f_px, predicted_covariance, gain, gain_transposed, correction;
    Eigen::Matrix<double, N, Eigen::Dynamic, 0, N, N> left;  // J (P_{k+1|N} - P^ji): N x n, stored inline at a fixed N
    Eigen::LDLT<Eigen::Matrix<double, N, N>> ldlt;
  };
  // The forward half of the pair (mode j's filtered x, px at k; mode i's
  // model): x^ji, P^ji and J into the n, n x n and n x n doubles at
  // `predicted`, `covariance` and `gain`. False if the pair cannot be smoothed.
  template <int N>
  bool predict_pair(int i, const Eigen::VectorXd& x, const Eigen::MatrixXd& px, const Eigen::VectorXd& u, double dt,
                    double* predicted, double* covariance, double* gain);
  // The RTS correction of a predicted pair by mode i's smoothed estimate at
  // k+1, into mean and *covariance; false if it is not sound.
  template <int N>
  bool correct_pair(int i, const Eigen::VectorXd& x, const Eigen::MatrixXd& px, const double* predicted,
                    const double* covariance, const double* gain, const SmoothedStep& next,
                    Eigen::Ref<Eigen::VectorXd> mean, Eigen::MatrixXd* corrected);
  template <int N>
  void mix_pair_covariances(Eigen::MatrixXd* covariance) const;
  void combine(SmoothedStep* s) const;
  // Kim's smoothed probabilities over the modes and the unknown hypothesis
  // (the bank's `unknown:`) into out, and the modes' joint into joint_.
  void smooth_probabilities_with_unknown(const ForwardStep& k, const Eigen::MatrixXd& p, const SmoothedStep& next,
                                         SmoothedStep* out);

  const Bank& bank_;
  ModeTransition transition_;
  std::vector<bool> angle_mask_;
  // Workspace.
  Eigen::MatrixXd pair_means_;  // n x N: x_{k|N}^{ji} for one j, over i
  Eigen::MatrixXd deviations_;
  Eigen::MatrixXd means_;
  Eigen::VectorXd with_unknown_;                   // N + 1: the modes' probabilities, then the unknown's
  Eigen::VectorXd c_;                              // N: predicted mode probabilities of k+1
  Eigen::MatrixXd joint_;                          // N x N
  Eigen::VectorXd weights_;                        // N: of the pairs (j, i) over i
  std::vector<Eigen::MatrixXd> pair_covariances_;  // N, n x n each
  PairWorkspace<Eigen::Dynamic> workspace_;        // the pairs' steps for other than 2 and 3 states
  PairPredictions step_pairs_;                     // one step's, where none are kept
};

// Fixed-lag smoothing for online use that can wait: each step's smoothed
// estimate is released once `lag` seconds of later steps have been seen,
// smoothed over that window (a fixed-interval smoother on the window: the
// same algorithm, with the window's last step as its end).
class FixedLagSmoother {
 public:
  // How many bytes of numbers of its window's pair predictions (ImmSmoother::
  // PairPredictions) a smoother keeps at most: 16 modes of 3 states take
  // 43 kB a step, 4 MB for a 2 s lag at 50 Hz. Past it (a bank of hundreds
  // of modes, a long lag) it stops keeping them until finish() and predicts
  // them again at every smoothing, the same result at more cost.
  static constexpr std::size_t kDefaultMostKeptPairBytes = std::size_t{64} << 20;

  FixedLagSmoother(const Bank& bank, double lag_seconds, std::size_t most_kept_pair_bytes = kDefaultMostKeptPairBytes);
  FixedLagSmoother(Bank&& bank, double lag_seconds, std::size_t most_kept_pair_bytes = 0) = delete;  // as ImmSmoother's

  // Adds the newest forward step; appends the steps now `lag` behind it,
  // oldest first, to *ready.
  void add(ForwardStep step, std::vector<SmoothedStep>* ready);
  // At the end of the log: releases the rest, smoothed over what remains.
  void finish(std::vector<SmoothedStep>* ready);

 private:
  // The window smoothed into smoothed_, with its kept predictions while there are.
  void smooth_window();

  ImmSmoother smoother_;
  double lag_;
  std::deque<ForwardStep> window_;
  // pairs_[k]: window_[k]'s pair predictions to window_[k + 1], while
  // keeps_pairs_: until the window's would exceed most_kept_pair_bytes_.
  std::size_t most_kept_pair_bytes_;
  bool keeps_pairs_ = true;
  std::deque<ImmSmoother::PairPredictions> pairs_;
  std::vector<SmoothedStep> smoothed_;
};

}  // namespace skidimm

#endif  // SKIDIMM_ENGINE_IMM_SMOOTHER_H_
