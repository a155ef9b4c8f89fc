#include "skidimm/imm.h"

#include <cmath>
#include <limits>
#include <utility>

#include "skidimm/check.h"
#include "skidimm/covariance.h"
#include "skidimm/gaussian_mixture.h"
#include "skidimm/sdk/angles.h"

namespace skidimm {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kMinusInfinity = -std::numeric_limits<double>::infinity();

}  // namespace

const char* to_string(StepStatus status) {
  switch (status) {
    case StepStatus::kUpdated:
      return "updated";
    case StepStatus::kPredictOnly:
      return "predict_only";
    case StepStatus::kAllModesRejected:
      return "all_modes_rejected";
    case StepStatus::kRejectedTime:
      return "rejected_time";
    case StepStatus::kRejectedInput:
      return "rejected_input";
  }
  return "unknown";
}

Imm Imm::from_yaml(const std::filesystem::path& bank_file, const std::vector<std::filesystem::path>& plugin_paths) {
  return Imm(Bank::load(bank_file, plugin_paths));
}

Imm::Imm(Bank bank)
    : bank_(std::move(bank)),
      transition_(ModeTransition::from_config(bank_.config.transition, bank_.config.num_modes())),
      measurement_model_(bank_.config.measurement.h, bank_.config.measurement.r, bank_.config.measurement.is_angle),
      angle_mask_(bank_.config.angle_mask) {
  const BankConfig& config = bank_.config;
  const int n = config.state_dim();
  const int num_modes = config.num_modes();
  SKIDIMM_CHECK(num_modes > 0 && static_cast<int>(bank_.models.size()) == num_modes, "one model per mode");
  const int m = measurement_model_.measurement_dim();
  filters_.reserve(num_modes);
  for (int j = 0; j < num_modes; ++j) {
    filters_.emplace_back(*bank_.models[j], config.modes[j].q_intensity, m);
  }
  selection_ = measurement_model_.make_selection();
  predicted_probabilities_.resize(num_modes);
  mixing_.resize(num_modes, num_modes);
  means_.resize(n, num_modes);
  deviations_.resize(n, num_modes);
  mixed_mean_.resize(n);
  mixed_covariance_.resize(n, n);
  log_posterior_.resize(num_modes);
  held_input_ = Eigen::VectorXd::Zero(config.input_dim());
  reset();  // sizes the estimate; step() then only writes into it
}

void Imm::reset() {
  const BankConfig& config = bank_.config;
  initialized_ = false;
  last_t_ = 0.0;
  held_input_.setZero();
  estimate_ = ImmEstimate{};
  estimate_.mode_probabilities = config.initial_mode_probabilities;
  estimate_.log_likelihoods = Eigen::VectorXd::Constant(num_modes(), kNaN);
  estimate_.nis = Eigen::VectorXd::Constant(num_modes(), kNaN);
  estimate_.mode_states.assign(num_modes(), config.initial_state);
  estimate_.mode_covariances.assign(num_modes(), config.initial_covariance);
  estimate_.state = config.initial_state;
  estimate_.covariance = config.initial_covariance;
  estimate_.mode_probabilities.maxCoeff(&estimate_.most_likely_mode);
}

const ImmEstimate& Imm::step(double t, const Eigen::Ref<const Eigen::VectorXd>& u,
                             const Eigen::Ref<const Eigen::VectorXd>& z) {
  SKIDIMM_CHECK(u.size() == bank_.config.input_dim(), "input vector size differs from the bank's inputs");
  SKIDIMM_CHECK(z.size() == measurement_model_.measurement_dim(),
                "measurement vector size differs from the bank's measurement");
  if (!u.allFinite() || !std::isfinite(t)) {
    estimate_.status = StepStatus::kRejectedInput;
    return estimate_;
  }
  if (initialized_ && !(t > last_t_)) {
    estimate_.status = StepStatus::kRejectedTime;
    return estimate_;
  }

  const int num_modes = this->num_modes();
  int rejected = 0;
  estimate_.log_likelihoods.setConstant(kNaN);
  estimate_.nis.setConstant(kNaN);

  if (!initialized_) {
    for (int j = 0; j < num_modes; ++j) {
      filters_[j].state() = bank_.config.initial_state;
      filters_[j].covariance() = bank_.config.initial_covariance;
    }
    predicted_probabilities_ = estimate_.mode_probabilities;
  } else {
    const double dt = t - last_t_;
    const Eigen::MatrixXd& transition = transition_.matrix(dt);
    predicted_probabilities_.noalias() = transition.transpose() * estimate_.mode_probabilities;
    mix(transition);
    for (int j = 0; j < num_modes; ++j) {
      if (!filters_[j].predict(held_input_, dt)) {
        estimate_.log_likelihoods[j] = kMinusInfinity;
        ++rejected;
      }
    }
  }

  measurement_model_.select(z, &selection_);
  const bool measured = selection_.size > 0;
  if (measured) {
    for (int j = 0; j < num_modes; ++j) {
      if (estimate_.log_likelihoods[j] == kMinusInfinity) continue;  // failed in predict
      const UpdateResult result = filters_[j].update(selection_);
      if (result.ok) {
        estimate_.log_likelihoods[j] = result.log_likelihood;
        estimate_.nis[j] = result.nis;
      } else {
        estimate_.log_likelihoods[j] = kMinusInfinity;
        ++rejected;
      }
    }
  }
  // A failed filter restarts from the last combined estimate, so one bad step
  // does not leave NaN in a mode forever.
  for (int j = 0; j < num_modes; ++j) {
    if (estimate_.log_likelihoods[j] == kMinusInfinity) {
      filters_[j].state() = estimate_.state;
      filters_[j].covariance() = estimate_.covariance;
    }
  }

  const bool all_rejected = rejected == num_modes;
  estimate_.status = !measured      ? StepStatus::kPredictOnly
                     : all_rejected ? StepStatus::kAllModesRejected
                                    : StepStatus::kUpdated;
  estimate_.num_measured = selection_.size;
  estimate_.num_rejected_modes = rejected;
  update_mode_probabilities(measured && !all_rejected);
  combine();

  estimate_.t = t;
  held_input_ = u;
  last_t_ = t;
  initialized_ = true;
  return estimate_;
}

void Imm::mix(const Eigen::MatrixXd& transition) {
  const int num_modes = this->num_modes();
  const Eigen::VectorXd& mu = estimate_.mode_probabilities;
  for (int i = 0; i < num_modes; ++i) means_.col(i) = estimate_.mode_states[i];
  for (int j = 0; j < num_modes; ++j) {
    const double c = predicted_probabilities_[j];
    if (c > 0.0) {
      mixing_.col(j) = transition.col(j).cwiseProduct(mu) / c;
    } else {
      mixing_.col(j) = mu;  // nothing flows into j: mixing degenerates to the prior weights
    }
    weighted_mean(angle_mask_, mixing_.col(j), means_, mixed_mean_, deviations_);
    mixed_covariance_.setZero();
    for (int i = 0; i < num_modes; ++i) {
      const double w = mixing_(i, j);
      if (w == 0.0) continue;
      mixed_covariance_.noalias() += w * estimate_.mode_covariances[i];
      mixed_covariance_.noalias() += w * deviations_.col(i) * deviations_.col(i).transpose();
    }
    symmetrize(mixed_covariance_);
    filters_[j].state() = mixed_mean_;
    filters_[j].covariance() = mixed_covariance_;
  }
}

void Imm::update_mode_probabilities(bool have_likelihoods) {
  const int num_modes = this->num_modes();
  for (int j = 0; j < num_modes; ++j) {
    const double c = predicted_probabilities_[j];
    log_posterior_[j] = c > 0.0 ? std::log(c) : kMinusInfinity;
    if (have_likelihoods) log_posterior_[j] += estimate_.log_likelihoods[j];
  }
  // log-sum-exp: the largest term is exp(0) = 1, so nothing underflows to an
  // all-zero vector however small the likelihoods are.
  const double largest = log_posterior_.maxCoeff();
  Eigen::VectorXd& mu = estimate_.mode_probabilities;
  for (int j = 0; j < num_modes; ++j) mu[j] = std::exp(log_posterior_[j] - largest);
  mu /= mu.sum();
  const double floor = bank_.config.mode_probability_floor;
  if (floor > 0.0) {
    mu = mu.cwiseMax(floor);
    mu /= mu.sum();
  }
  mu.maxCoeff(&estimate_.most_likely_mode);
}

void Imm::combine() {
  const int num_modes = this->num_modes();
  for (int j = 0; j < num_modes; ++j) {
    estimate_.mode_states[j] = filters_[j].state();
    estimate_.mode_covariances[j] = filters_[j].covariance();
    means_.col(j) = filters_[j].state();
  }
  const Eigen::VectorXd& mu = estimate_.mode_probabilities;
  weighted_mean(angle_mask_, mu, means_, estimate_.state, deviations_);
  estimate_.covariance.setZero();
  for (int j = 0; j < num_modes; ++j) {
    estimate_.covariance.noalias() += mu[j] * estimate_.mode_covariances[j];
    estimate_.covariance.noalias() += mu[j] * deviations_.col(j) * deviations_.col(j).transpose();
  }
  symmetrize(estimate_.covariance);
}

}  // namespace skidimm
