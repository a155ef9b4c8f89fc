// The body of Imm::step, for one shape of bank, chosen once when the Imm is
// built (imm.cc): fixed-size Eigen types for states and measurements of up
// to 4 components (FixedFilters<N, M>), fixed states of up to 12 with any
// measurement (FixedStateFilters<N>), dynamic ones with ExtendedKalmanFilter
// for everything else (DynamicFilters). The mixing, probabilities and
// combination around them are the same code for both.
// Private to imm.cc and the fixed-size kernels' own translation units
// (fixed_size_kernels.h).
#ifndef SKIDIMM_CORE_SRC_IMM_KERNEL_H_
#define SKIDIMM_CORE_SRC_IMM_KERNEL_H_

#include <Eigen/Core>
#include <Eigen/StdVector>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "covariance.h"
#include "extrapolation_discount.h"
#include "filter_health.h"
#include "fixed_size_ekf.h"
#include "gaussian_mixture.h"
#include "measured_outputs.h"
#include "mode_probabilities_given_a_mode.h"
#include "not_a_number.h"
#include "parameter_noise.h"
#include "probability_floor.h"
#include "residual_correlation.h"
#include "skidimm/config/bank.h"
#include "skidimm/engine/fatal_signal_report.h"
#include "skidimm/engine/imm_checkpoint.h"
#include "skidimm/engine/imm_estimate.h"
#include "skidimm/engine/measurement_model.h"
#include "skidimm/engine/mode_transition.h"
#include "student_t_likelihood.h"
#include "transposed_product.h"

namespace skidimm {
namespace internal {

constexpr double kMinusInfinity = -std::numeric_limits<double>::infinity();

// The NIS below which a consistent measurement of `dof` components falls with
// `probability` (imm.cc).
double chi_square_quantile(double probability, int dof);

// Mode j's update result into the estimate.
inline void record_update(int j, const UpdateResult& result, ImmEstimate* e, int* rejected) {
  if (result.ok) {
    e->log_likelihoods[j] = result.log_likelihood;
    e->nis[j] = result.nis;
    if (result.gated) e->mode_failures[static_cast<std::size_t>(j)] = ModeFailure::kGated;
  } else {
    e->log_likelihoods[j] = kMinusInfinity;
    ++*rejected;
  }
}

class ImmKernel {
 public:
  virtual ~ImmKernel() = default;
  // One accepted step (t increased, u finite) of Imm::step. `first`: the
  // prior holds, no prediction. Writes everything in *e but t.
  // u drives the prediction over the last dt (the input held since the last
  // step); u_now is the input at this step's time, from which the models
  // predict the outputs measured with z (measured_outputs.h).
  virtual void step(bool first, double dt, const Eigen::Ref<const Eigen::VectorXd>& u,
                    const Eigen::Ref<const Eigen::VectorXd>& u_now, const Eigen::Ref<const Eigen::VectorXd>& z,
                    ImmEstimate* e) = 0;
  // What the kernel carries between steps besides the estimate, into
  // *checkpoint (ImmCheckpoint).
  virtual void save(ImmCheckpoint* checkpoint) const = 0;
  // The filters from the checkpoint's estimate (its mode states and
  // covariances), and its memory; checked by Imm::restore.
  virtual void restore(const ImmCheckpoint& checkpoint) = 0;
  // Why the checkpoint's memory does not fit this kernel ("" when it does).
  virtual std::string checkpoint_problem(const ImmCheckpoint& checkpoint) const = 0;
};

// What every fixed-size filter bank of N states holds: each mode's model and
// Q, the state's angle mask, and the filters' states and covariances; and the
// prediction, which does not depend on how the bank measures. The banks
// below add the update for their measurement shape.
template <int N>
class FixedStateBank {
 public:
  static constexpr int kStates = N;
  using State = Eigen::Matrix<double, N, 1>;
  using Covariance = Eigen::Matrix<double, N, N>;

  explicit FixedStateBank(const Bank& bank) {
    const BankConfig& c = bank.config;
    for (int j = 0; j < c.num_modes(); ++j) {
      models_.push_back(bank.models[static_cast<std::size_t>(j)].get());
      q_.push_back(c.modes[static_cast<std::size_t>(j)].q_intensity);
    }
    for (int i = 0; i < N; ++i) {
      if (c.angle_mask[static_cast<std::size_t>(i)]) state_angles_ |= 1u << i;
    }
    x_.assign(models_.size(), State::Zero());
    p_.assign(models_.size(), Covariance::Identity());
    reused_.resize(models_.size());
    for (std::size_t j = 0; j < models_.size(); ++j) {
      // A mode with parameter uncertainty: F and Qd are the wrapped model's,
      // G Sigma G' is added at each step (parameter_noise.h).
      const sdk::MotionModel* wrapped = internal::model_under_parameter_uncertainty(*models_[j]);
      ReusedStepMatrices& reused = reused_[j];
      reused.adds_parameter_noise = wrapped != nullptr;
      reused.from = wrapped != nullptr ? wrapped : models_[j];
      reused.reusable = reused.from->jacobian_and_noise_depend_only_on_dt();
    }
  }

  State& state(int j) { return x_[static_cast<std::size_t>(j)]; }
  Covariance& covariance(int j) { return p_[static_cast<std::size_t>(j)]; }
  const sdk::MotionModel& model(int j) const { return *models_[static_cast<std::size_t>(j)]; }

  bool predict(int j, const Eigen::Ref<const Eigen::VectorXd>& u, double dt) {
    const std::size_t mode = static_cast<std::size_t>(j);
    const sdk::MotionModel& model = *models_[mode];
    ReusedStepMatrices& reused = reused_[mode];
    if (!reused.reusable) return predict_fixed<N>(model, q_[mode], state_angles_, u, dt, &x_[mode], &p_[mode]);
    if (!(reused.dt == dt)) {
      reused.dt = kNaN;
      if (!compute_step_matrices<N>(*reused.from, q_[mode], x_[mode], u, dt, &reused.matrices)) return false;
      reused.dt = dt;
    }
    if (!reused.adds_parameter_noise) {
      return propagate_fixed<N>(model, reused.matrices, state_angles_, u, dt, &x_[mode], &p_[mode]);
    }
    step_ = reused.matrices;
    {
      Eigen::Ref<Eigen::MatrixXd> q_out(step_.q());
      if (!internal::add_parameter_noise(model, x_[mode], u, dt, q_out)) return false;
    }
    return propagate_fixed<N>(model, step_, state_angles_, u, dt, &x_[mode], &p_[mode]);
  }

  // From the next step on, asks the models for F and Qd afresh (a new run:
  // Imm::reset()).
  void forget_step_matrices() {
    for (ReusedStepMatrices& reused : reused_) reused.dt = kNaN;
  }

 protected:
  int modes() const { return static_cast<int>(models_.size()); }

  // A mode's F and Qd for the last dt, when its model says they depend on dt
  // alone (sdk::MotionModel::jacobian_and_noise_depend_only_on_dt): runs at
  // a fixed rate then ask for them once, not at every step (a 9-state
  // linear_features mode spends most of its model time on them: Qd takes
  // exponentials). The same values, so the same results to the bit.
  struct ReusedStepMatrices {
    bool reusable = false;
    bool adds_parameter_noise = false;      // G Sigma G' added at each step
    const sdk::MotionModel* from = nullptr;  // the model asked for F and Qd
    double dt = kNaN;                        // NaN: none kept
    StepMatrices<N> matrices;
  };

  std::vector<const sdk::MotionModel*> models_;
  std::vector<Covariance, Eigen::aligned_allocator<Covariance>> q_;
  std::vector<ReusedStepMatrices> reused_;
  StepMatrices<N> step_;  // a step's F and Qd with a mode's G Sigma G' added
  AngleMask state_angles_ = 0;
  std::vector<State, Eigen::aligned_allocator<State>> x_;
  std::vector<Covariance, Eigen::aligned_allocator<Covariance>> p_;
};

// The mode-matched filters, fixed size: N states, M measurement components.
template <int N, int M>
class FixedFilters : public FixedStateBank<N> {
 public:
  explicit FixedFilters(const Bank& bank) : FixedStateBank<N>(bank), h_(bank.config.measurement.h) {
    const BankConfig& c = bank.config;
    for (int j = 0; j < c.num_modes(); ++j) r_.push_back(c.measurement_noise(j));
    for (int a = 0; a < M; ++a) {
      if (c.measurement.is_angle[static_cast<std::size_t>(a)]) z_angles_ |= 1u << a;
    }
    h_is_identity_ = M == N && h_ == Eigen::Matrix<double, M, N>::Identity();  // update_fixed()'s h_is_identity
  }

  // Updates every mode whose log-likelihood is not already -inf with the
  // finite rows of z, less the mode's expected outputs when `outputs` is
  // given, gating at gates[k] for k rows; writes log-likelihoods, NIS and
  // kGated; with `correlation`, each applied measurement's log-likelihood is
  // conditioned on the mode's last innovation (residual_correlation.h).
  // Returns the number of rows used.
  int update(const Eigen::Ref<const Eigen::VectorXd>& z, const MeasuredOutputs* outputs, const double* gates,
             ResidualCorrelation* correlation, ImmEstimate* e, int* rejected) {
    std::array<int, M> rows{};
    int k = 0;
    for (int a = 0; a < M; ++a) {
      if (std::isfinite(z[a])) rows[static_cast<std::size_t>(k++)] = a;
    }
    switch (k) {
      case 1:
        update_rows<1>(rows, z, outputs, gates[1], correlation, e, rejected);
        break;
      case 2:
        update_rows<2>(rows, z, outputs, gates[2], correlation, e, rejected);
        break;
      case 3:
        update_rows<3>(rows, z, outputs, gates[3], correlation, e, rejected);
        break;
      case 4:
        update_rows<4>(rows, z, outputs, gates[4], correlation, e, rejected);
        break;
      default:
        break;
    }
    return k;
  }

 private:
  template <int K>
  void update_rows(const std::array<int, M>& rows, const Eigen::Ref<const Eigen::VectorXd>& z,
                   const MeasuredOutputs* outputs, double gate, ResidualCorrelation* correlation, ImmEstimate* e,
                   int* rejected) {
    if constexpr (K <= M) {
      Eigen::Matrix<double, K, 1> zk;
      Eigen::Matrix<double, K, N> hk;
      Eigen::Matrix<double, K, K> rk;
      AngleMask angles = 0;
      for (int a = 0; a < K; ++a) {
        const int row = rows[static_cast<std::size_t>(a)];
        zk[a] = z[row];
        hk.row(a) = h_.row(row);
        if (z_angles_ >> row & 1u) angles |= 1u << a;
      }
      const int modes = this->modes();
      for (int j = 0; j < modes; ++j) {
        if (e->log_likelihoods[j] == kMinusInfinity) continue;  // failed in predict
        const Eigen::Matrix<double, M, M>& r = r_[static_cast<std::size_t>(j)];
        for (int a = 0; a < K; ++a) {
          for (int b = 0; b < K; ++b)
            rk(a, b) = r(rows[static_cast<std::size_t>(a)], rows[static_cast<std::size_t>(b)]);
        }
        Eigen::Matrix<double, K, 1> zj = zk;
        if (outputs != nullptr) {
          for (int a = 0; a < K; ++a) zj[a] -= outputs->expected(j)[rows[static_cast<std::size_t>(a)]];
        }
        Eigen::Matrix<double, K, 1> whitened;
        UpdateResult result = update_fixed<N, K>(
            zj, hk, rk, angles, this->state_angles_, &this->x_[static_cast<std::size_t>(j)],
            &this->p_[static_cast<std::size_t>(j)], gate, correlation != nullptr ? &whitened : nullptr,
            K == M && h_is_identity_);
        if (correlation != nullptr && result.ok && !result.gated) {
          result.log_likelihood = correlation->condition(j, rows, K, whitened, result.log_likelihood, result.nis);
        }
        record_update(j, result, e, rejected);
      }
    }
  }

  Eigen::Matrix<double, M, N> h_;
  std::vector<Eigen::Matrix<double, M, M>, Eigen::aligned_allocator<Eigen::Matrix<double, M, M>>> r_;  // per mode
  AngleMask z_angles_ = 0;
  bool h_is_identity_ = false;  // H = I: every state measured directly
};

// The mode-matched filters for N states known at compile time and any number
// of measurement rows: banks past FixedFilters' 4 x 4 (BorealTC's 9 features
// measured directly, stc_traction's 3 states with 3 outputs measured).
// update_selected() (fixed_size_ekf.h) on the rows MeasurementModel::select() keeps.
template <int N>
class FixedStateFilters : public FixedStateBank<N> {
 public:
  explicit FixedStateFilters(const Bank& bank)
      : FixedStateBank<N>(bank),
        measurement_model_(bank.config.measurement.h, bank.config.measurement.r, bank.config.measurement.is_angle),
        workspace_(static_cast<int>(bank.config.measurement.h.rows())) {
    const BankConfig& c = bank.config;
    selection_ = measurement_model_.make_selection();
    measured_ = selection_.z;
    if (c.any_mode_measurement_noise()) {
      for (int j = 0; j < c.num_modes(); ++j) mode_r_.push_back(c.measurement_noise(j));
    }
  }

  // As FixedFilters::update.
  int update(const Eigen::Ref<const Eigen::VectorXd>& z, const MeasuredOutputs* outputs, const double* gates,
             ResidualCorrelation* correlation, ImmEstimate* e, int* rejected) {
    measurement_model_.select(z, &selection_);
    if (selection_.size == 0) return 0;
    if (outputs != nullptr) measured_ = selection_.z;
    const int modes = this->modes();
    for (int j = 0; j < modes; ++j) {
      if (e->log_likelihoods[j] == kMinusInfinity) continue;  // failed in predict
      if (outputs != nullptr) {
        for (int a = 0; a < selection_.size; ++a) {
          selection_.z[a] = measured_[a] - outputs->expected(j)[selection_.rows[static_cast<std::size_t>(a)]];
        }
      }
      // The selected block of this mode's R (select() filled the bank's).
      if (!mode_r_.empty()) MeasurementModel::select_noise(mode_r_[static_cast<std::size_t>(j)], &selection_);
      UpdateResult result =
          update_selected<N>(selection_, this->state_angles_, &this->x_[static_cast<std::size_t>(j)],
                             &this->p_[static_cast<std::size_t>(j)], &workspace_, gates[selection_.size]);
      if (correlation != nullptr && result.ok && !result.gated) {
        result.log_likelihood = correlation->condition(j, selection_.rows, selection_.size, workspace_.whitened,
                                                       result.log_likelihood, result.nis);
      }
      record_update(j, result, e, rejected);
    }
    return selection_.size;
  }

 private:
  MeasurementModel measurement_model_;
  SelectedMeasurement selection_;
  Eigen::VectorXd measured_;             // selection_.z as measured, when modes subtract their outputs
  std::vector<Eigen::MatrixXd> mode_r_;  // as DynamicFilters'
  SelectedUpdateWorkspace<N> workspace_;
};

// The mode-matched filters for any size: ExtendedKalmanFilter.
class DynamicFilters {
 public:
  static constexpr int kStates = Eigen::Dynamic;
  using State = Eigen::VectorXd;
  using Covariance = Eigen::MatrixXd;

  explicit DynamicFilters(const Bank& bank)
      : measurement_model_(bank.config.measurement.h, bank.config.measurement.r, bank.config.measurement.is_angle) {
    const BankConfig& c = bank.config;
    filters_.reserve(static_cast<std::size_t>(c.num_modes()));
    for (int j = 0; j < c.num_modes(); ++j) {
      models_.push_back(bank.models[static_cast<std::size_t>(j)].get());
      filters_.emplace_back(*bank.models[static_cast<std::size_t>(j)], c.modes[static_cast<std::size_t>(j)].q_intensity,
                            measurement_model_.measurement_dim());
    }
    selection_ = measurement_model_.make_selection();
    measured_ = selection_.z;
    if (c.any_mode_measurement_noise()) {
      for (int j = 0; j < c.num_modes(); ++j) mode_r_.push_back(c.measurement_noise(j));
    }
  }

  State& state(int j) { return filters_[static_cast<std::size_t>(j)].state(); }
  Covariance& covariance(int j) { return filters_[static_cast<std::size_t>(j)].covariance(); }
  const sdk::MotionModel& model(int j) const { return *models_[static_cast<std::size_t>(j)]; }

  bool predict(int j, const Eigen::Ref<const Eigen::VectorXd>& u, double dt) {
    return filters_[static_cast<std::size_t>(j)].predict(u, dt);
  }
  // ExtendedKalmanFilter asks the model for F and Qd at every step.
  void forget_step_matrices() {}

  int update(const Eigen::Ref<const Eigen::VectorXd>& z, const MeasuredOutputs* outputs, const double* gates,
             ResidualCorrelation* correlation, ImmEstimate* e, int* rejected) {
    measurement_model_.select(z, &selection_);
    if (selection_.size == 0) return 0;
    if (outputs != nullptr) measured_ = selection_.z;
    const int modes = static_cast<int>(filters_.size());
    for (int j = 0; j < modes; ++j) {
      if (e->log_likelihoods[j] == kMinusInfinity) continue;  // failed in predict
      if (outputs != nullptr) {
        for (int a = 0; a < selection_.size; ++a) {
          selection_.z[a] = measured_[a] - outputs->expected(j)[selection_.rows[static_cast<std::size_t>(a)]];
        }
      }
      // The selected block of this mode's R (select() filled the bank's).
      if (!mode_r_.empty()) MeasurementModel::select_noise(mode_r_[static_cast<std::size_t>(j)], &selection_);
      ExtendedKalmanFilter& filter = filters_[static_cast<std::size_t>(j)];
      UpdateResult result = filter.update(selection_, gates[selection_.size]);
      if (correlation != nullptr && result.ok && !result.gated) {
        result.log_likelihood = correlation->condition(j, selection_.rows, selection_.size,
                                                       filter.whitened_innovation(), result.log_likelihood, result.nis);
      }
      record_update(j, result, e, rejected);
    }
    return selection_.size;
  }

 private:
  std::vector<const sdk::MotionModel*> models_;
  MeasurementModel measurement_model_;
  std::vector<ExtendedKalmanFilter> filters_;
  SelectedMeasurement selection_;
  Eigen::VectorXd measured_;  // selection_.z as measured, when modes subtract their outputs
  // Per mode, the R its filter uses (BankConfig::measurement_noise); empty
  // when every mode uses the bank's, which select() already gives.
  std::vector<Eigen::MatrixXd> mode_r_;
};

// Mixing (eq. 4-7, all targets in one product), the filters, the mode
// probabilities (eq. 9 with c_j, log domain, floored) and the combination
// (eq. 10-11).
template <typename Filters>
class Kernel final : public ImmKernel {
 public:
  using State = typename Filters::State;
  using Covariance = typename Filters::Covariance;

  explicit Kernel(const Bank& bank)
      : filters_(bank),
        outputs_(bank),
        transition_(ModeTransition::from_config(bank.config.transition, bank.config.num_modes())),
        n_(bank.config.state_dim()),
        modes_(bank.config.num_modes()),
        floor_(bank.config.mode_probability_floor),
        likelihood_weight_(bank.config.likelihood_weight),
        unknown_(bank.config.unknown),
        student_t_(bank.config.likelihood_dof, static_cast<int>(bank.config.measurement.h.rows())),
        discount_(bank.config),
        correlation_(bank.config),
        initial_state_(bank.config.initial_state),
        initial_covariance_(bank.config.initial_covariance) {
    is_angle_.reset(new bool[static_cast<std::size_t>(n_)]);
    for (int d = 0; d < n_; ++d) {
      is_angle_[static_cast<std::size_t>(d)] = bank.config.angle_mask[static_cast<std::size_t>(d)];
    }
    const int columns = moment_columns(n_);
    moments_.resize(modes_, columns);
    flowed_.resize(modes_, columns);
    prior_moments_.resize(columns);
    transition_.reserve_columns(columns);
    predicted_.resize(modes_);
    log_posterior_.resize(unknown_.enabled() ? modes_ + 1 : modes_);
    if (unknown_.enabled()) {
      with_unknown_.resize(modes_ + 1);
      conditional_.resize(modes_);
    }
    reference_.resize(n_);
    offset_.resize(n_);
    mean_.resize(n_);
    deviation_.resize(n_);
    combined_.resize(n_, n_);
    // gates_[k]: the chi-square quantile for k measured components.
    const int m = static_cast<int>(bank.config.measurement.h.rows());
    gates_.assign(static_cast<std::size_t>(m) + 1, std::numeric_limits<double>::infinity());
    if (bank.config.innovation_gate > 0.0) {
      for (int k = 1; k <= m; ++k)
        gates_[static_cast<std::size_t>(k)] = chi_square_quantile(bank.config.innovation_gate, k);
    }
  }

  void step(bool first, double dt, const Eigen::Ref<const Eigen::VectorXd>& u,
            const Eigen::Ref<const Eigen::VectorXd>& u_now, const Eigen::Ref<const Eigen::VectorXd>& z,
            ImmEstimate* e) override {
    int rejected = 0;
    const double previous_unknown = e->unknown_probability;
    for (int j = 0; j < modes_; ++j) {
      e->log_likelihoods[j] = kNaN;
      e->nis[j] = kNaN;
    }
    std::fill(e->mode_failures.begin(), e->mode_failures.end(), ModeFailure::kNone);
    if (first) {
      for (int j = 0; j < modes_; ++j) {
        filters_.state(j) = initial_state_;
        filters_.covariance(j) = initial_covariance_;
      }
      predicted_ = e->mode_probabilities;
      correlation_.forget_all();
      filters_.forget_step_matrices();
    } else {
      correlation_.advance();
      // The filters run on as the modes' estimates given that some mode
      // holds: the unknown hypothesis has no state to mix in.
      mix(dt, unknown_.enabled() ? condition_on_modes(e->mode_probabilities) : e->mode_probabilities);
      for (int j = 0; j < modes_; ++j) {
        const internal::ModelCallMark in_model(j);
        if (!filters_.predict(j, u, dt)) {
          e->log_likelihoods[j] = kMinusInfinity;
          record_predict_failure(j, e);
          ++rejected;
        }
      }
    }
    // What each mode predicts for the outputs measured (measured_outputs.h).
    const bool outputs_measured = outputs_.any() && outputs_.measured(z);
    if (outputs_measured) {
      for (int j = 0; j < modes_; ++j) {
        if (e->log_likelihoods[j] == kMinusInfinity) continue;
        const internal::ModelCallMark in_model(j);
        if (!outputs_.predict(j, u_now, &output_failure_)) {
          e->log_likelihoods[j] = kMinusInfinity;
          e->mode_failures[static_cast<std::size_t>(j)] = ModeFailure::kModel;
          e->failure_reasons[static_cast<std::size_t>(j)] = output_failure_;
          ++rejected;
        }
      }
    }
    ResidualCorrelation* correlation = correlation_.active() ? &correlation_ : nullptr;
    const int measured =
        filters_.update(z, outputs_measured ? &outputs_ : nullptr, gates_.data(), correlation, e, &rejected);
    // From the Gaussian densities, before a Student-t rescoring.
    const double unknown_log_likelihood = unknown_.enabled() ? score_unknown(measured, *e) : kNaN;
    if (!student_t_.gaussian()) rescore_student_t(measured, e);
    // A filter that ran but holds absurd numbers has diverged (filter_health.h).
    for (int j = 0; j < modes_; ++j) {
      if (e->log_likelihoods[j] == kMinusInfinity) continue;
      if (!filter_is_healthy(filters_.state(j), filters_.covariance(j))) {
        e->log_likelihoods[j] = kMinusInfinity;
        e->mode_failures[static_cast<std::size_t>(j)] = ModeFailure::kDiverged;
        ++rejected;
      }
    }
    // A failed or diverged filter restarts from the last combined estimate
    // (sound, see combine()), so one bad step does not leave NaN in a mode
    // forever.
    for (int j = 0; j < modes_; ++j) {
      if (e->log_likelihoods[j] == kMinusInfinity) {
        filters_.state(j) = e->state;
        filters_.covariance(j) = e->covariance;
      }
      // A mode that failed, diverged or gated this step's measurement starts
      // a new innovation memory: what it remembered is not what followed.
      if (correlation != nullptr && (e->log_likelihoods[j] == kMinusInfinity ||
                                     e->mode_failures[static_cast<std::size_t>(j)] == ModeFailure::kGated)) {
        correlation_.forget(j);
      }
    }
    const int gated = score_gated_modes(e);
    const int accepted = measured == 0 ? 0 : modes_ - rejected - gated;
    e->status = rejected == modes_ ? StepStatus::kAllModesRejected
                : rejected > 0     ? StepStatus::kModeReset
                : measured == 0    ? StepStatus::kPredictOnly
                : accepted == 0    ? StepStatus::kGated
                : gated > 0        ? StepStatus::kModeGated
                                   : StepStatus::kUpdated;
    e->num_measured = measured;
    e->num_rejected_modes = rejected;
    e->num_gated_modes = gated;
    // Likelihoods count only when some mode applied the measurement: a
    // measurement every mode gated (or failed on) says nothing about which
    // mode is right. Where a class's models extrapolate, their evidence is
    // faded (extrapolation_discount.h).
    const Eigen::VectorXd& evidence = discount_.active() && accepted > 0
                                          ? discount_.evidence(u_now, predicted_, e->log_likelihoods)
                                          : e->log_likelihoods;
    if (unknown_.enabled()) {
      update_probabilities_with_unknown(first, accepted > 0, previous_unknown, unknown_log_likelihood, evidence, e);
      combine(condition_on_modes(e->mode_probabilities), e);
    } else {
      update_mode_probabilities(accepted > 0, evidence, e);
      combine(e->mode_probabilities, e);
    }
  }

  void save(ImmCheckpoint* checkpoint) const override {
    checkpoint->innovations = correlation_.memory();
    checkpoint->transition_anchors = transition_.anchor_memory();
  }

  std::string checkpoint_problem(const ImmCheckpoint& checkpoint) const override {
    return transition_.anchor_memory_problem(checkpoint.transition_anchors);
  }

  void restore(const ImmCheckpoint& checkpoint) override {
    for (int j = 0; j < modes_; ++j) {
      filters_.state(j) = checkpoint.estimate.mode_states[static_cast<std::size_t>(j)];
      filters_.covariance(j) = checkpoint.estimate.mode_covariances[static_cast<std::size_t>(j)];
    }
    // Kept F and Qd are asked for again: the same values.
    filters_.forget_step_matrices();
    correlation_.restore(checkpoint.innovations);
    transition_.restore_anchors(checkpoint.transition_anchors);
  }

 private:
  // A gated mode is scored at its gate's boundary, and no better than the
  // worst mode that applied the measurement, so rejecting a measurement can
  // never make a mode win (docs/engine.md). Returns the number of gated modes.
  int score_gated_modes(ImmEstimate* e) const {
    int gated = 0;
    double worst_applied = std::numeric_limits<double>::infinity();
    for (int j = 0; j < modes_; ++j) {
      const ModeFailure failure = e->mode_failures[static_cast<std::size_t>(j)];
      const double log_likelihood = e->log_likelihoods[j];
      if (failure == ModeFailure::kGated) {
        ++gated;
      } else if (failure == ModeFailure::kNone && log_likelihood > kMinusInfinity) {
        worst_applied = std::min(worst_applied, log_likelihood);
      }
    }
    if (gated == 0 || worst_applied == std::numeric_limits<double>::infinity()) return gated;
    for (int j = 0; j < modes_; ++j) {
      if (e->mode_failures[static_cast<std::size_t>(j)] == ModeFailure::kGated) {
        e->log_likelihoods[j] = std::min(e->log_likelihoods[j], worst_applied);
      }
    }
    return gated;
  }

  // The Student-t log density of each updated mode's innovation from its
  // Gaussian one (student_t_likelihood.h); a gated mode was scored at its
  // gate, and is scored there again. With correlated innovations the
  // Gaussian density is the conditional one, and so is d2.
  void rescore_student_t(int measured, ImmEstimate* e) const {
    for (int j = 0; j < modes_; ++j) {
      if (e->log_likelihoods[j] == kMinusInfinity || std::isnan(e->log_likelihoods[j])) continue;
      const bool gated = e->mode_failures[static_cast<std::size_t>(j)] == ModeFailure::kGated;
      const double d2 = gated                   ? gates_[static_cast<std::size_t>(measured)]
                        : correlation_.active() ? correlation_.conditional_d2(j)
                                                : e->nis[j];
      e->log_likelihoods[j] = student_t_(e->log_likelihoods[j], d2, measured);
    }
  }

  // Why mode j's prediction failed. A model that returns false leaves the
  // filter's state as it was (finite, as every failed filter restarts from
  // the combined estimate); one that returns non-finite numbers does not.
  void record_predict_failure(int j, ImmEstimate* e) {
    const std::size_t m = static_cast<std::size_t>(j);
    const char* reason = filters_.model(j).failure_reason();
    const bool finite = filters_.state(j).allFinite() && filters_.covariance(j).allFinite();
    if ((reason != nullptr && reason[0] != '\0') || finite) {
      e->mode_failures[m] = ModeFailure::kModel;
      e->failure_reasons[m] = reason != nullptr && reason[0] != '\0'
                                  ? reason
                                  : "predict(), jacobian() or process_noise() returned false without a reason "
                                    "(report_failure(), sdk/failure.h)";
    } else {
      e->mode_failures[m] = ModeFailure::kNotFinite;
    }
  }

  // Mixed initial conditions of every target (eq. 4-7) from the last step's
  // probabilities and estimates: one product with P(dt)' (gaussian_mixture.h).
  void mix(double dt, const Eigen::VectorXd& mu) {
    Eigen::Index heaviest = 0;
    mu.maxCoeff(&heaviest);
    reference_ = filters_.state(static_cast<int>(heaviest));
    for (int i = 0; i < modes_; ++i) {
      pack_moments(is_angle_.get(), mu[i], filters_.state(i), filters_.covariance(i), reference_, offset_,
                   moments_.row(i));
    }
    transition_.propagate(dt, moments_, flowed_);
    if (transition_.matrix_in_closed_form()) {
      // c = P' mu as the IMM always computed it (mode_transition.h): exact
      // ties between modes stay ties, broken by index as before.
      transposed_times(transition_.matrix(dt), mu, &predicted_);
    } else {
      predicted_ = flowed_.col(0);
    }
    bool prior_ready = false;
    for (int j = 0; j < modes_; ++j) {
      const double c = flowed_(j, 0);
      if (c > 0.0) {
        unpack_moments(is_angle_.get(), flowed_.row(j), c, reference_, offset_, filters_.state(j),
                       filters_.covariance(j));
      } else {
        // Nothing flows into j: mixing degenerates to the prior weights.
        if (!prior_ready) prior_moments_ = moments_.colwise().sum().transpose();
        prior_ready = true;
        unpack_moments(is_angle_.get(), prior_moments_, 1.0, reference_, offset_, filters_.state(j),
                       filters_.covariance(j));
      }
    }
  }

  // The unknown hypothesis' log-likelihood of this step: the best of the
  // modes that applied the measurement, each mode's innovation scored under
  // its covariance S times s = inflation,
  //   log N(nu; 0, s S) = log N(nu; 0, S) + d2 (1 - 1/s) / 2 - m log(s) / 2,
  // with d2 the NIS (the conditional one with correlated innovations, whose
  // density the mode's log-likelihood is) and m the rows measured. Under a
  // Student-t likelihood, the same family at scale s S: the Student-t value
  // from that Gaussian one at d2 / s. Scored by a broad Gaussian against
  // heavy-tailed modes, the unknown would lose every far miss (the modes'
  // density falls with log d2, its own with d2), which is when it should win;
  // in the same family it wins the far tail by dof log(s) / 2. NaN when no
  // mode applied it.
  double score_unknown(int measured, const ImmEstimate& e) const {
    const double s = unknown_.inflation;
    double best = kNaN;
    for (int j = 0; j < modes_; ++j) {
      const double log_likelihood = e.log_likelihoods[j];
      if (e.mode_failures[static_cast<std::size_t>(j)] != ModeFailure::kNone || !std::isfinite(log_likelihood)) {
        continue;
      }
      const double d2 = correlation_.active() ? correlation_.conditional_d2(j) : e.nis[j];
      double broad = log_likelihood + 0.5 * d2 * (1.0 - 1.0 / s) - 0.5 * measured * std::log(s);
      if (!student_t_.gaussian()) broad = student_t_(broad, d2 / s, measured);
      if (!(broad <= best)) best = broad;
    }
    return best;
  }

  // The modes' probabilities given that some mode holds (summing to 1).
  const Eigen::VectorXd& condition_on_modes(const Eigen::VectorXd& mu) {
    given_a_mode(mu, &conditional_);
    return conditional_;
  }

  // As update_mode_probabilities, over the modes and the unknown hypothesis
  // U. The chain first moves `enter` of the modes' mass into U and `leave` of
  // U's mass evenly back into the modes:
  //   c_j = (1 - mu_U) (1 - enter) c'_j + mu_U leave / M,
  //   c_U = (1 - mu_U) enter + mu_U (1 - leave),
  // with c'_j the modes' own chain on their conditional probabilities (the
  // first step: no transition). Then mu ~ c Lambda^w, floored.
  void update_probabilities_with_unknown(bool first, bool have_likelihoods, double previous_unknown,
                                         double unknown_log_likelihood, const Eigen::VectorXd& evidence,
                                         ImmEstimate* e) {
    const double known = 1.0 - previous_unknown;
    const double enter = unknown_.enter, leave = unknown_.leave;
    for (int j = 0; j < modes_; ++j) {
      const double c =
          !first ? known * (1.0 - enter) * predicted_[j] + previous_unknown * leave / modes_ : predicted_[j];
      log_posterior_[j] = c > 0.0 ? std::log(c) : kMinusInfinity;
      if (have_likelihoods) log_posterior_[j] += likelihood_weight_ * evidence[j];
    }
    const double c_unknown = !first ? known * enter + previous_unknown * (1.0 - leave) : previous_unknown;
    log_posterior_[modes_] = c_unknown > 0.0 ? std::log(c_unknown) : kMinusInfinity;
    // Some mode applied the measurement whenever there are likelihoods, so the
    // unknown hypothesis has one too.
    if (have_likelihoods && !std::isnan(unknown_log_likelihood)) {
      log_posterior_[modes_] += likelihood_weight_ * unknown_log_likelihood;
    }
    const double largest = log_posterior_.maxCoeff();
    for (int j = 0; j <= modes_; ++j) with_unknown_[j] = std::exp(log_posterior_[j] - largest);
    with_unknown_ /= with_unknown_.sum();
    apply_probability_floor(floor_, with_unknown_);
    e->mode_probabilities = with_unknown_.head(modes_);
    e->unknown_probability = with_unknown_[modes_];
    e->mode_probabilities.maxCoeff(&e->most_likely_mode);
  }

  // evidence: the modes' log-likelihoods as the probabilities use them.
  void update_mode_probabilities(bool have_likelihoods, const Eigen::VectorXd& evidence, ImmEstimate* e) {
    for (int j = 0; j < modes_; ++j) {
      const double c = predicted_[j];
      log_posterior_[j] = c > 0.0 ? std::log(c) : kMinusInfinity;
      if (have_likelihoods) log_posterior_[j] += likelihood_weight_ * evidence[j];
    }
    // log-sum-exp: the largest term is exp(0) = 1, so nothing underflows to an
    // all-zero vector however small the likelihoods are.
    const double largest = log_posterior_.maxCoeff();
    Eigen::VectorXd& mu = e->mode_probabilities;
    for (int j = 0; j < modes_; ++j) mu[j] = std::exp(log_posterior_[j] - largest);
    mu /= mu.sum();
    apply_probability_floor(floor_, mu);
    mu.maxCoeff(&e->most_likely_mode);
  }

  // Combined estimate (eq. 10-11), angles around the most probable mode's
  // (weighted_mean's rule, gaussian_mixture.h).
  // mu: the modes' weights, summing to 1.
  void combine(const Eigen::VectorXd& mu, ImmEstimate* e) {
    Eigen::Index heaviest = 0;
    mu.maxCoeff(&heaviest);
    const State& reference = filters_.state(static_cast<int>(heaviest));
    for (int d = 0; d < n_; ++d) {
      double sum = 0.0;
      if (is_angle_[static_cast<std::size_t>(d)]) {
        const double r = reference[d];
        for (int j = 0; j < modes_; ++j) sum += mu[j] * wrap_angle_fast(filters_.state(j)[d] - r);
        mean_[d] = wrap_angle_fast(r + sum);
      } else {
        for (int j = 0; j < modes_; ++j) sum += mu[j] * filters_.state(j)[d];
        mean_[d] = sum;
      }
    }
    combined_.setZero();
    for (int j = 0; j < modes_; ++j) {
      const State& x = filters_.state(j);
      for (int d = 0; d < n_; ++d) {
        const double v = x[d] - mean_[d];
        deviation_[d] = is_angle_[static_cast<std::size_t>(d)] ? wrap_angle_fast(v) : v;
      }
      combined_.noalias() += mu[j] * filters_.covariance(j);
      combined_.noalias() += mu[j] * deviation_ * deviation_.transpose();
      copy_out(x, &e->mode_states[static_cast<std::size_t>(j)]);
      copy_out(filters_.covariance(j), &e->mode_covariances[static_cast<std::size_t>(j)]);
    }
    symmetrize(combined_);
    if (!estimate_is_sound(mean_, combined_)) {
      // Cannot happen with every mode healthy (filter_health.h); kept so
      // that the output's promise holds whatever a model does.
      restart_from_prior(e);
      return;
    }
    copy_out(mean_, &e->state);
    copy_out(combined_, &e->covariance);
  }

  void restart_from_prior(ImmEstimate* e) {
    correlation_.forget_all();
    for (int j = 0; j < modes_; ++j) {
      filters_.state(j) = initial_state_;
      filters_.covariance(j) = initial_covariance_;
      copy_out(filters_.state(j), &e->mode_states[static_cast<std::size_t>(j)]);
      copy_out(filters_.covariance(j), &e->mode_covariances[static_cast<std::size_t>(j)]);
    }
    e->state = initial_state_;  // same size: no allocation
    e->covariance = initial_covariance_;
  }

  // Into the estimate's dynamic storage (already of the right size): a
  // fixed-size copy when the kernel's sizes are fixed.
  template <typename From, typename To>
  static void copy_out(const From& from, To* to) {
    if constexpr (From::SizeAtCompileTime == Eigen::Dynamic) {
      *to = from;
    } else {
      Eigen::Map<typename From::PlainObject>(to->data()) = from;
    }
  }

  Filters filters_;
  MeasuredOutputs outputs_;
  std::string output_failure_;
  ModeTransition transition_;
  int n_;
  int modes_;
  double floor_;
  double likelihood_weight_;         // w of Lambda_j^w (bank.h)
  UnknownHypothesisConfig unknown_;  // the bank's "none of these" hypothesis
  StudentTLikelihood student_t_;     // the bank's likelihood_dof
  ExtrapolationDiscount discount_;   // the bank's extrapolation_scale
  ResidualCorrelation correlation_;  // the modes' residual_correlation
  std::vector<double> gates_;        // by number of measured components; +inf: no gate
  Eigen::VectorXd initial_state_;
  Eigen::MatrixXd initial_covariance_;
  std::unique_ptr<bool[]> is_angle_;
  // Workspace.
  Eigen::MatrixXd moments_;  // row i: mu_i [1, y_i, vech(P_i + y_i y_i')]
  Eigen::MatrixXd flowed_;   // P(dt)' moments
  Eigen::VectorXd prior_moments_;
  Eigen::VectorXd predicted_;      // c_j
  Eigen::VectorXd log_posterior_;  // the modes', then the unknown hypothesis' when on
  Eigen::VectorXd with_unknown_;   // the probabilities of the modes and the unknown hypothesis
  Eigen::VectorXd conditional_;    // the modes' probabilities given that some mode holds
  State reference_;
  State offset_;
  State mean_;
  State deviation_;
  Covariance combined_;
};

}  // namespace internal
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_IMM_KERNEL_H_
