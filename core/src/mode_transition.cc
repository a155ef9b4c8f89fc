#include "skidimm/mode_transition.h"

#include <cmath>

#include "skidimm/check.h"

namespace skidimm {

ModeTransition ModeTransition::from_config(const TransitionConfig& config, int num_modes) {
  switch (config.kind) {
    case TransitionConfig::Kind::kMatrix:
      return per_step(config.matrix);
    case TransitionConfig::Kind::kStay:
      return per_step_stay(num_modes, config.stay);
    case TransitionConfig::Kind::kDwellTimes:
      return from_dwell_times(config.dwell_seconds);
  }
  return per_step_stay(num_modes, config.stay);
}

ModeTransition ModeTransition::per_step(const Eigen::MatrixXd& matrix) {
  SKIDIMM_CHECK(matrix.rows() == matrix.cols() && matrix.rows() > 0, "transition matrix must be square");
  ModeTransition t;
  t.matrix_ = matrix;
  t.generator_ = Eigen::MatrixXd::Zero(matrix.rows(), matrix.cols());
  return t;
}

ModeTransition ModeTransition::per_step_stay(int num_modes, double stay_probability) {
  SKIDIMM_CHECK(num_modes > 0, "a bank needs at least one mode");
  if (num_modes == 1) return per_step(Eigen::MatrixXd::Ones(1, 1));
  const double move = (1.0 - stay_probability) / (num_modes - 1);
  Eigen::MatrixXd m = Eigen::MatrixXd::Constant(num_modes, num_modes, move);
  m.diagonal().setConstant(stay_probability);
  return per_step(m);
}

ModeTransition ModeTransition::from_dwell_times(const Eigen::VectorXd& mean_dwell_seconds) {
  const Eigen::Index n = mean_dwell_seconds.size();
  SKIDIMM_CHECK(n > 0 && (mean_dwell_seconds.array() > 0.0).all(), "dwell times must be positive");
  ModeTransition t;
  t.continuous_ = true;
  t.generator_ = Eigen::MatrixXd::Zero(n, n);
  if (n > 1) {
    for (Eigen::Index i = 0; i < n; ++i) {
      const double rate = 1.0 / mean_dwell_seconds[i];
      t.generator_.row(i).setConstant(rate / static_cast<double>(n - 1));
      t.generator_(i, i) = -rate;
    }
  }
  t.max_rate_ = (-t.generator_.diagonal()).maxCoeff();
  t.uniform_rates_ = (mean_dwell_seconds.array() == mean_dwell_seconds[0]).all();
  t.matrix_ = Eigen::MatrixXd::Identity(n, n);
  t.jump_ = Eigen::MatrixXd::Identity(n, n);
  if (t.max_rate_ > 0.0) t.jump_ += t.generator_ / t.max_rate_;
  t.power_.resize(n, n);
  t.scratch_.resize(n, n);
  return t;
}

const Eigen::MatrixXd& ModeTransition::matrix(double dt) {
  if (!continuous_ || dt == cached_dt_) return matrix_;
  exponentiate(dt);
  cached_dt_ = dt;
  return matrix_;
}

void ModeTransition::exponentiate(double dt) {
  const Eigen::Index n = matrix_.rows();
  if (n == 1 || max_rate_ == 0.0 || dt <= 0.0) {
    matrix_.setIdentity();
    return;
  }
  if (uniform_rates_) {
    // Equal rates r: the chain forgets its state at rate r n/(n-1), so
    // P = 1/n + (delta_ij - 1/n) exp(-r n dt / (n-1)).
    const double nn = static_cast<double>(n);
    const double decay = std::exp(-max_rate_ * nn / (nn - 1.0) * dt);
    matrix_.setConstant((1.0 - decay) / nn);
    matrix_.diagonal().array() += decay;
    return;
  }
  // Uniformisation: expm(Pi h) = sum_k Poisson(k; r h) J^k, with J = I + Pi/r
  // stochastic, so every term is non-negative and nothing cancels. Scale h so
  // that r h <= 1/2 (about 15 terms reach 1e-17), then square back.
  int squarings = 0;
  double h = dt;
  while (max_rate_ * h > 0.5) {
    h *= 0.5;
    ++squarings;
  }
  const double lambda = max_rate_ * h;
  double weight = std::exp(-lambda);
  double accumulated = weight;
  matrix_.setIdentity();
  matrix_ *= weight;
  power_.setIdentity();
  for (int k = 1; k < 64 && 1.0 - accumulated > 1e-17; ++k) {
    scratch_.noalias() = power_ * jump_;
    power_.swap(scratch_);
    weight *= lambda / k;
    accumulated += weight;
    matrix_ += weight * power_;
  }
  for (int s = 0; s < squarings; ++s) {
    scratch_.noalias() = matrix_ * matrix_;
    matrix_.swap(scratch_);
  }
  // Remove the truncated tail so rows sum to one to machine precision.
  for (Eigen::Index i = 0; i < n; ++i) matrix_.row(i) /= matrix_.row(i).sum();
}

}  // namespace skidimm
