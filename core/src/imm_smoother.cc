#include "skidimm/engine/imm_smoother.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <type_traits>

#include "covariance.h"
#include "filter_health.h"
#include "gaussian_mixture.h"
#include "ldlt_solve.h"
#include "mode_probabilities_given_a_mode.h"
#include "probability_floor.h"
#include "skidimm/sdk/angles.h"

namespace skidimm {

namespace {

// The smoother's dynamic workspace, or the fixed-size one on the stack.
template <bool kDynamic, typename Member, typename Local>
Local& select(Member& member, Local& local) {
  if constexpr (kDynamic) {
    return member;
  } else {
    return local;
  }
}

// The pairs' steps take N states known at compile time for the bundled
// banks' shapes (2, 3), whose pairs are most of a smoothing's time (16^2 a
// step for the 16-mode banks); Eigen::Dynamic otherwise, in the smoother's
// own workspace. The stored estimates and predictions are dynamic or flat;
// at a fixed N they are read as fixed-size maps, so that every product is
// of fixed size: no temporary on the heap, and the same sums in the same
// order.
template <int N, typename Matrix>
decltype(auto) as_fixed(const Matrix& m) {
  if constexpr (N == Eigen::Dynamic) {
    return (m);
  } else {
    return Eigen::Map<const Eigen::Matrix<double, N, Matrix::ColsAtCompileTime == 1 ? 1 : N>>(m.data());
  }
}

// A flat n-vector or n x n matrix of PairPredictions, read at N.
template <int N>
auto flat_vector(const double* data, int n) {
  return Eigen::Map<const Eigen::Matrix<double, N, 1>>(data, n);
}
template <int N>
auto flat_matrix(const double* data, int n) {
  return Eigen::Map<const Eigen::Matrix<double, N, N>>(data, n, n);
}

}  // namespace

ForwardStep record_step(double t, const Eigen::Ref<const Eigen::VectorXd>& u, const ImmEstimate& e) {
  ForwardStep step;
  step.t = t;
  step.u = u;
  step.mode_probabilities = e.mode_probabilities;
  step.unknown_probability = e.unknown_probability;
  step.mode_states = e.mode_states;
  step.mode_covariances = e.mode_covariances;
  return step;
}

ImmSmoother::ImmSmoother(const Bank& bank)
    : bank_(bank),
      transition_(ModeTransition::from_config(bank.config.transition, bank.config.num_modes())),
      angle_mask_(bank.config.angle_mask) {
  const int n = bank.config.state_dim(), modes = bank.config.num_modes();
  pair_means_.resize(n, modes);
  deviations_.resize(n, modes);
  means_.resize(n, modes);
  c_.resize(modes);
  joint_.resize(modes, modes);
  with_unknown_.resize(modes + 1);
  weights_.resize(modes);
  workspace_.predicted.resize(n);
  workspace_.difference.resize(n);
  for (Eigen::MatrixXd* m : {&workspace_.f, &workspace_.q, &workspace_.f_px, &workspace_.predicted_covariance,
                             &workspace_.gain, &workspace_.gain_transposed, &workspace_.left, &workspace_.correction}) {
    m->resize(n, n);
  }
  pair_covariances_.assign(static_cast<std::size_t>(modes), Eigen::MatrixXd(n, n));
  workspace_.ldlt = Eigen::LDLT<Eigen::MatrixXd>(n);
}

void ImmSmoother::combine(SmoothedStep* s) const {
  const int modes = bank_.config.num_modes();
  Eigen::MatrixXd means(bank_.config.state_dim(), modes), deviations(bank_.config.state_dim(), modes);
  for (int j = 0; j < modes; ++j) means.col(j) = s->mode_states[static_cast<std::size_t>(j)];
  // With an unknown hypothesis the combined state is, as the filter's, the
  // modes' estimate given that some mode holds.
  Eigen::VectorXd conditional;
  if (bank_.config.unknown.enabled()) internal::given_a_mode(s->mode_probabilities, &conditional);
  const Eigen::VectorXd& weights = bank_.config.unknown.enabled() ? conditional : s->mode_probabilities;
  s->state.resize(bank_.config.state_dim());
  weighted_mean(angle_mask_, weights, means, s->state, deviations);
  s->covariance.setZero(bank_.config.state_dim(), bank_.config.state_dim());
  for (int j = 0; j < modes; ++j) {
    s->covariance.noalias() += weights[j] * s->mode_covariances[static_cast<std::size_t>(j)];
    s->covariance.noalias() += weights[j] * deviations.col(j) * deviations.col(j).transpose();
  }
  symmetrize(s->covariance);
  s->mode_probabilities.maxCoeff(&s->most_likely_mode);
}

template <int N>
bool ImmSmoother::predict_pair(int i, const Eigen::VectorXd& x, const Eigen::MatrixXd& px, const Eigen::VectorXd& u,
                               double dt, double* predicted, double* covariance, double* gain) {
  PairWorkspace<N> local;
  PairWorkspace<N>& w = select<N == Eigen::Dynamic>(workspace_, local);
  const int n = static_cast<int>(x.size());
  const sdk::MotionModel& model = *bank_.models[static_cast<std::size_t>(i)];
  // The prediction of mode j's filtered estimate through mode i's model, as the filter predicts.
  if (!(model.jacobian(x, u, dt, w.f) &&
        model.process_noise(bank_.config.modes[static_cast<std::size_t>(i)].q_intensity, x, u, dt, w.q) &&
        model.predict(x, u, dt, w.predicted) && w.predicted.allFinite() && w.f.allFinite())) {
    return false;
  }
  for (int d = 0; d < n; ++d) {
    if (angle_mask_[static_cast<std::size_t>(d)]) w.predicted[d] = sdk::wrap_angle(w.predicted[d]);
  }
  // F P, once: it is the left factor of F P F' and the right-hand side of the gain's solve.
  w.f_px.noalias() = w.f * as_fixed<N>(px);
  w.predicted_covariance.noalias() = w.f_px * w.f.transpose();
  w.predicted_covariance += w.q;
  symmetrize(w.predicted_covariance);
  // J = P F' (P^ji)^-1, solved: J' = (P^ji)^-1 F P.
  w.ldlt.compute(w.predicted_covariance);
  if (!(w.ldlt.info() == Eigen::Success && w.ldlt.isPositive() && (w.ldlt.vectorD().array() > 0.0).all())) return false;
  if constexpr (N == Eigen::Dynamic) {
    w.gain_transposed = w.ldlt.solve(w.f_px);
  } else {
    w.gain_transposed = w.f_px;
    internal::ldlt_solve_in_place(w.ldlt, &w.gain_transposed);
  }
  w.gain = w.gain_transposed.transpose();
  if (!w.gain.allFinite()) return false;
  Eigen::Map<Eigen::Matrix<double, N, 1>>(predicted, n) = w.predicted;
  Eigen::Map<Eigen::Matrix<double, N, N>>(covariance, n, n) = w.predicted_covariance;
  Eigen::Map<Eigen::Matrix<double, N, N>>(gain, n, n) = w.gain;
  return true;
}

template <int N>
bool ImmSmoother::correct_pair(int i, const Eigen::VectorXd& x, const Eigen::MatrixXd& px, const double* predicted,
                               const double* covariance, const double* gain, const SmoothedStep& next,
                               Eigen::Ref<Eigen::VectorXd> mean, Eigen::MatrixXd* corrected) {
  PairWorkspace<N> local;
  PairWorkspace<N>& w = select<N == Eigen::Dynamic>(workspace_, local);
  const int n = static_cast<int>(x.size());
  const auto predicted_state = flat_vector<N>(predicted, n);
  const auto predicted_covariance = flat_matrix<N>(covariance, n);
  const auto j_gain = flat_matrix<N>(gain, n);
  w.difference = next.mode_states[static_cast<std::size_t>(i)] - predicted_state;
  for (int d = 0; d < n; ++d) {
    if (angle_mask_[static_cast<std::size_t>(d)]) w.difference[d] = sdk::wrap_angle(w.difference[d]);
  }
  mean = as_fixed<N>(x) + j_gain * w.difference;
  for (int d = 0; d < n; ++d) {
    if (angle_mask_[static_cast<std::size_t>(d)]) mean[d] = sdk::wrap_angle(mean[d]);
  }
  // P + J (P_{k+1|N} - P^ji) J' in the products and order Eigen evaluates
  // `px + gain * (next - predicted) * gain'` in (an N x dynamic product, then
  // an N x N one), so the same bits, but into the workspace: at a fixed N
  // nothing is allocated (the expression allocated its two temporaries).
  w.left.noalias() = j_gain * (as_fixed<N>(next.mode_covariances[static_cast<std::size_t>(i)]) - predicted_covariance);
  w.correction.noalias() = w.left * j_gain.transpose();
  // *corrected is n x n already (the smoother's pair_covariances_), written in place.
  Eigen::Map<Eigen::Matrix<double, N, N>> pc(corrected->data(), n, n);
  pc = as_fixed<N>(px) + w.correction;
  symmetrize(pc);
  return internal::filter_is_healthy(Eigen::Map<const Eigen::Matrix<double, N, 1>>(mean.data(), n), pc);
}

void ImmSmoother::predict_pairs(const ForwardStep& k, double t_next, PairPredictions* out) {
  const int modes = bank_.config.num_modes();
  const int n = bank_.config.state_dim();
  const std::size_t pairs = static_cast<std::size_t>(modes) * static_cast<std::size_t>(modes);
  const std::size_t square = static_cast<std::size_t>(n) * static_cast<std::size_t>(n);
  out->predicted.resize(pairs * static_cast<std::size_t>(n));
  out->covariance.resize(pairs * square);
  out->gain.resize(pairs * square);
  out->sound.resize(pairs);
  const double dt = t_next - k.t;
  for (int j = 0; j < modes; ++j) {
    const Eigen::VectorXd& x = k.mode_states[static_cast<std::size_t>(j)];
    const Eigen::MatrixXd& px = k.mode_covariances[static_cast<std::size_t>(j)];
    for (int i = 0; i < modes; ++i) {
      const std::size_t pair =
          static_cast<std::size_t>(j) * static_cast<std::size_t>(modes) + static_cast<std::size_t>(i);
      double* predicted = out->predicted.data() + pair * static_cast<std::size_t>(n);
      double* covariance = out->covariance.data() + pair * square;
      double* gain = out->gain.data() + pair * square;
      const bool sound = n == 2   ? predict_pair<2>(i, x, px, k.u, dt, predicted, covariance, gain)
                         : n == 3 ? predict_pair<3>(i, x, px, k.u, dt, predicted, covariance, gain)
                                  : predict_pair<Eigen::Dynamic>(i, x, px, k.u, dt, predicted, covariance, gain);
      out->sound[pair] = sound ? 1 : 0;
    }
  }
}

void ImmSmoother::backward(const ForwardStep& k, double t_next, const PairPredictions& pairs, const SmoothedStep& next,
                           SmoothedStep* out) {
  const BankConfig& config = bank_.config;
  const int modes = config.num_modes();
  const int n = config.state_dim();
  const std::size_t square = static_cast<std::size_t>(n) * static_cast<std::size_t>(n);
  const Eigen::MatrixXd& p = transition_.matrix(t_next - k.t);  // row j (from, at k), column i (to, at k+1)
  Eigen::MatrixXd& joint = joint_;
  out->t = k.t;
  if (config.unknown.enabled()) {
    smooth_probabilities_with_unknown(k, p, next, out);
  } else {
    const Eigen::VectorXd& mu = k.mode_probabilities;
    c_.noalias() = p.transpose() * mu;  // predicted probabilities of k+1
    const Eigen::VectorXd& c = c_;
    // Smoothed joint probabilities of (m_k = j, m_{k+1} = i), Kim's approximation.
    for (int j = 0; j < modes; ++j) {
      for (int i = 0; i < modes; ++i) {
        joint(j, i) = c[i] > 0.0 ? next.mode_probabilities[i] * p(j, i) * mu[j] / c[i] : 0.0;
      }
    }
    out->unknown_probability = 0.0;
    out->mode_probabilities = joint.rowwise().sum();
    const double total = out->mode_probabilities.sum();
    if (total > 0.0) out->mode_probabilities /= total;
    internal::apply_probability_floor(config.mode_probability_floor, out->mode_probabilities);
  }
  out->mode_states.resize(static_cast<std::size_t>(modes));
  out->mode_covariances.resize(static_cast<std::size_t>(modes));

  Eigen::VectorXd& weights = weights_;
  for (int j = 0; j < modes; ++j) {
    const Eigen::VectorXd& x = k.mode_states[static_cast<std::size_t>(j)];
    const Eigen::MatrixXd& px = k.mode_covariances[static_cast<std::size_t>(j)];
    const double row = joint.row(j).sum();
    for (int i = 0; i < modes; ++i) {
      weights[i] = row > 0.0 ? joint(j, i) / row : (i == j ? 1.0 : 0.0);
      Eigen::MatrixXd& pc = pair_covariances_[static_cast<std::size_t>(i)];
      auto mean = pair_means_.col(i);
      const std::size_t pair =
          static_cast<std::size_t>(j) * static_cast<std::size_t>(modes) + static_cast<std::size_t>(i);
      const double* predicted = pairs.predicted.data() + pair * static_cast<std::size_t>(n);
      const double* covariance = pairs.covariance.data() + pair * square;
      const double* gain = pairs.gain.data() + pair * square;
      const bool ok = pairs.sound[pair] != 0 &&
                      (n == 2   ? correct_pair<2>(i, x, px, predicted, covariance, gain, next, mean, &pc)
                       : n == 3 ? correct_pair<3>(i, x, px, predicted, covariance, gain, next, mean, &pc)
                                : correct_pair<Eigen::Dynamic>(i, x, px, predicted, covariance, gain, next, mean, &pc));
      // A pair that cannot be smoothed, or whose correction is absurd (across
      // a step where the filter reset a mode, or a near-singular P^ji), keeps
      // the filtered estimate.
      if (!ok) {
        mean = x;
        pc = px;
      }
    }
    Eigen::VectorXd& mean = out->mode_states[static_cast<std::size_t>(j)];
    mean.resize(n);
    weighted_mean(angle_mask_, weights, pair_means_, mean, deviations_);
    Eigen::MatrixXd& covariance = out->mode_covariances[static_cast<std::size_t>(j)];
    covariance.setZero(n, n);
    if (n == 2) {
      mix_pair_covariances<2>(&covariance);
    } else if (n == 3) {
      mix_pair_covariances<3>(&covariance);
    } else {
      mix_pair_covariances<Eigen::Dynamic>(&covariance);
    }
  }
  combine(out);
}

// sum_i w_i (P^i + d_i d_i') over the pairs of one mode j (weights_,
// pair_covariances_, deviations_) into *covariance (n x n, zero), each
// entry's terms in the order the dynamic expression took them.
template <int N>
void ImmSmoother::mix_pair_covariances(Eigen::MatrixXd* covariance) const {
  const int n = static_cast<int>(covariance->rows());
  Eigen::Map<Eigen::Matrix<double, N, N>> sum(covariance->data(), n, n);
  for (Eigen::Index i = 0; i < weights_.size(); ++i) {
    const double weight = weights_[i];
    if (weight == 0.0) continue;
    const Eigen::Map<const Eigen::Matrix<double, N, 1>> deviation(deviations_.col(i).data(), n);
    sum.noalias() += weight * as_fixed<N>(pair_covariances_[static_cast<std::size_t>(i)]);
    sum.noalias() += weight * deviation * deviation.transpose();
  }
  symmetrize(sum);
}

// The filter's chain over the modes and the unknown hypothesis U
// (docs/engine.md, "Unknown hypothesis") is a Markov chain on M + 1
// hypotheses: from mode j to mode i (1 - enter) p(j, i), to U enter; from U
// to each mode leave / M, to U 1 - leave. Kim's recursion runs on it as on
// the modes' own chain. The modes' states are, as in the filter, their
// estimates given that some mode holds, so a mode's smoothed state weighs its
// pairs by the joint over the modes at k+1 alone (joint_); a step from j into
// U carries no later information on j's state.
void ImmSmoother::smooth_probabilities_with_unknown(const ForwardStep& k, const Eigen::MatrixXd& p,
                                                    const SmoothedStep& next, SmoothedStep* out) {
  const BankConfig& config = bank_.config;
  const int modes = config.num_modes();
  const double enter = config.unknown.enter, leave = config.unknown.leave;
  const Eigen::VectorXd& mu = k.mode_probabilities;
  const double mu_unknown = k.unknown_probability;
  const double to_each_mode = leave / modes;
  c_.noalias() = p.transpose() * mu;
  c_ = (1.0 - enter) * c_ + Eigen::VectorXd::Constant(modes, mu_unknown * to_each_mode);
  const double c_unknown = enter * mu.sum() + (1.0 - leave) * mu_unknown;
  const double next_unknown = c_unknown > 0.0 ? next.unknown_probability / c_unknown : 0.0;
  with_unknown_.setZero();
  for (int j = 0; j < modes; ++j) {
    for (int i = 0; i < modes; ++i) {
      joint_(j, i) = c_[i] > 0.0 ? next.mode_probabilities[i] * (1.0 - enter) * p(j, i) * mu[j] / c_[i] : 0.0;
    }
    with_unknown_[j] = joint_.row(j).sum() + next_unknown * enter * mu[j];
  }
  for (int i = 0; i < modes; ++i) {
    if (c_[i] > 0.0) with_unknown_[modes] += next.mode_probabilities[i] * to_each_mode * mu_unknown / c_[i];
  }
  with_unknown_[modes] += next_unknown * (1.0 - leave) * mu_unknown;
  const double total = with_unknown_.sum();
  if (total > 0.0) with_unknown_ /= total;
  internal::apply_probability_floor(config.mode_probability_floor, with_unknown_);
  out->mode_probabilities = with_unknown_.head(modes);
  out->unknown_probability = with_unknown_[modes];
}

template <typename Steps, typename PairsOf>
void ImmSmoother::smooth_range(const Steps& forward, const PairsOf& pairs_of, std::vector<SmoothedStep>* out) {
  const std::size_t count = forward.size();
  // The steps of the last smoothing are reused (a fixed-lag window smooths
  // again at every step): backward() writes every field of each.
  out->resize(count);
  if (count == 0) return;
  SmoothedStep& last = (*out)[count - 1];
  last.t = forward[count - 1].t;
  last.mode_probabilities = forward[count - 1].mode_probabilities;
  last.unknown_probability = forward[count - 1].unknown_probability;
  last.mode_states = forward[count - 1].mode_states;
  last.mode_covariances = forward[count - 1].mode_covariances;
  combine(&last);
  for (std::size_t k = count - 1; k-- > 0;) {
    backward(forward[k], forward[k + 1].t, pairs_of(k), (*out)[k + 1], &(*out)[k]);
  }
}

template <typename Steps>
void ImmSmoother::smooth_predicting(const Steps& forward, std::vector<SmoothedStep>* out) {
  smooth_range(
      forward,
      [&](std::size_t k) -> const PairPredictions& {
        predict_pairs(forward[k], forward[k + 1].t, &step_pairs_);
        return step_pairs_;
      },
      out);
}

void ImmSmoother::smooth(const std::vector<ForwardStep>& forward, std::vector<SmoothedStep>* out) {
  smooth_predicting(forward, out);
}

void ImmSmoother::smooth(const std::deque<ForwardStep>& forward, std::vector<SmoothedStep>* out) {
  smooth_predicting(forward, out);
}

void ImmSmoother::smooth(const std::deque<ForwardStep>& forward, const std::deque<PairPredictions>& pairs,
                         std::vector<SmoothedStep>* out) {
  if (pairs.size() + 1 != forward.size() && !(forward.empty() && pairs.empty())) {
    throw std::invalid_argument("ImmSmoother::smooth: one PairPredictions for each step but the last");
  }
  const std::size_t modes = static_cast<std::size_t>(bank_.config.num_modes());
  const std::size_t n = static_cast<std::size_t>(bank_.config.state_dim());
  for (const PairPredictions& p : pairs) {
    if (p.sound.size() != modes * modes || p.predicted.size() != modes * modes * n ||
        p.covariance.size() != modes * modes * n * n || p.gain.size() != modes * modes * n * n) {
      throw std::invalid_argument("ImmSmoother::smooth: PairPredictions of another bank's size");
    }
  }
  smooth_range(
      forward, [&](std::size_t k) -> const PairPredictions& { return pairs[k]; }, out);
}

FixedLagSmoother::FixedLagSmoother(const Bank& bank, double lag_seconds, std::size_t most_kept_pair_bytes)
    : smoother_(bank), lag_(lag_seconds), most_kept_pair_bytes_(most_kept_pair_bytes) {}

void FixedLagSmoother::smooth_window() {
  if (keeps_pairs_) {
    smoother_.smooth(window_, pairs_, &smoothed_);
  } else {
    smoother_.smooth(window_, &smoothed_);
  }
}

void FixedLagSmoother::add(ForwardStep step, std::vector<SmoothedStep>* ready) {
  const double newest = step.t;
  window_.push_back(std::move(step));
  if (keeps_pairs_ && window_.size() >= 2) {
    // The previous newest step's pairs, now that the step after it is known.
    pairs_.emplace_back();
    smoother_.predict_pairs(window_[window_.size() - 2], newest, &pairs_.back());
    if (pairs_.back().bytes() * pairs_.size() > most_kept_pair_bytes_) {
      keeps_pairs_ = false;
      pairs_.clear();
    }
  }
  // Release every step that is now `lag` behind the newest, each smoothed
  // over the window that ends at the newest step.
  if (window_.front().t > newest - lag_) return;
  smooth_window();
  std::size_t released = 0;
  while (released < window_.size() && window_[released].t <= newest - lag_) {
    ready->push_back(smoothed_[released]);
    ++released;
  }
  window_.erase(window_.begin(), window_.begin() + static_cast<std::ptrdiff_t>(released));
  if (keeps_pairs_) {
    pairs_.erase(pairs_.begin(), pairs_.begin() + static_cast<std::ptrdiff_t>(std::min(released, pairs_.size())));
  }
}

void FixedLagSmoother::finish(std::vector<SmoothedStep>* ready) {
  smooth_window();
  ready->insert(ready->end(), smoothed_.begin(), smoothed_.end());
  window_.clear();
  pairs_.clear();
  keeps_pairs_ = true;  // for the next log
}

}  // namespace skidimm
