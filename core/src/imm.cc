#include "skidimm/engine/imm.h"

#include <boost/math/special_functions/gamma.hpp>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include "check.h"
#include "fixed_size_kernels.h"
#include "imm_kernel.h"
#include "not_a_number.h"
#include "skidimm/errors.h"

namespace skidimm {

namespace {

using ::skidimm::internal::kNaN;

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
    case StepStatus::kGated:
      return "gated";
    case StepStatus::kModeGated:
      return "mode_gated";
    case StepStatus::kModeReset:
      return "mode_reset";
  }
  return "unknown";
}

namespace internal {

double chi_square_quantile(double probability, int dof) {
  // chi2(k) is Gamma(k/2, scale 2).
  return 2.0 * boost::math::gamma_p_inv(0.5 * dof, probability);
}

}  // namespace internal

Imm Imm::from_yaml(const std::filesystem::path& bank_file, const std::vector<std::filesystem::path>& plugin_paths) {
  return Imm(Bank::load(bank_file, plugin_paths));
}

namespace {

template <int N>
std::unique_ptr<internal::ImmKernel> fixed_kernel_for_measurement(const Bank& bank, int m) {
  switch (m) {
    case 1:
      return internal::make_fixed_filters_kernel<N, 1>(bank);
    case 2:
      return internal::make_fixed_filters_kernel<N, 2>(bank);
    case 3:
      return internal::make_fixed_filters_kernel<N, 3>(bank);
    case 4:
      return internal::make_fixed_filters_kernel<N, 4>(bank);
  }
  return nullptr;
}

// A fixed-size kernel for n states and m rows: fixed sizes up to 4 x 4;
// fixed states up to kMaxFixedStates with any measurement; null if the build
// has none for the shape (fixed_size_shapes.h). The kernels are compiled
// apart from this file (fixed_size_kernels.h).
std::unique_ptr<internal::ImmKernel> fixed_size_kernel(const Bank& bank, int n, int m) {
  if (m < 1) return nullptr;
  if (m <= 4) {
    std::unique_ptr<internal::ImmKernel> kernel;
    switch (n) {
      case 1:
        kernel = fixed_kernel_for_measurement<1>(bank, m);
        break;
      case 2:
        kernel = fixed_kernel_for_measurement<2>(bank, m);
        break;
      case 3:
        kernel = fixed_kernel_for_measurement<3>(bank, m);
        break;
      case 4:
        kernel = fixed_kernel_for_measurement<4>(bank, m);
        break;
      default:
        break;
    }
    if (kernel) return kernel;
  }
  switch (n) {
    case 1:
      return internal::make_fixed_state_kernel<1>(bank);
    case 2:
      return internal::make_fixed_state_kernel<2>(bank);
    case 3:
      return internal::make_fixed_state_kernel<3>(bank);
    case 4:
      return internal::make_fixed_state_kernel<4>(bank);
    case 5:
      return internal::make_fixed_state_kernel<5>(bank);
    case 6:
      return internal::make_fixed_state_kernel<6>(bank);
    case 7:
      return internal::make_fixed_state_kernel<7>(bank);
    case 8:
      return internal::make_fixed_state_kernel<8>(bank);
    case 9:
      return internal::make_fixed_state_kernel<9>(bank);
    case 10:
      return internal::make_fixed_state_kernel<10>(bank);
    case 11:
      return internal::make_fixed_state_kernel<11>(bank);
    case 12:
      return internal::make_fixed_state_kernel<12>(bank);
    default:
      return nullptr;
  }
}

}  // namespace

Imm::Imm(Bank bank, ImmKernelChoice choice) : bank_(std::move(bank)) {
  const BankConfig& config = bank_.config;
  const int num_modes = config.num_modes();
  SKIDIMM_CHECK(num_modes > 0 && static_cast<int>(bank_.models.size()) == num_modes, "one model per mode");
  const int n = config.state_dim();
  const int m = static_cast<int>(config.measurement.h.rows());
  SKIDIMM_CHECK(config.measurement.h.cols() == n && config.measurement.r.rows() == m &&
                    config.measurement.r.cols() == m &&
                    static_cast<int>(config.measurement.is_angle.size()) == m &&
                    static_cast<int>(config.angle_mask.size()) == n,
                "measurement model and angles must match the state");
  for (int j = 0; j < num_modes; ++j) {
    SKIDIMM_CHECK(config.measurement_noise(j).rows() == m && config.measurement_noise(j).cols() == m,
                  "a mode's own R must cover every measurement row");
  }
  if (choice == ImmKernelChoice::kFastest) kernel_ = fixed_size_kernel(bank_, n, m);
  fixed_size_ = kernel_ != nullptr;
  if (!kernel_) kernel_ = std::make_unique<internal::Kernel<internal::DynamicFilters>>(bank_);
  held_input_ = Eigen::VectorXd::Zero(config.input_dim());
  reset();  // sizes the estimate; step() then only writes into it
}

Imm::Imm(Imm&&) noexcept = default;
Imm& Imm::operator=(Imm&&) noexcept = default;
Imm::~Imm() = default;

void Imm::reset() {
  const BankConfig& config = bank_.config;
  initialized_ = false;
  last_t_ = 0.0;
  held_input_.setZero();
  estimate_ = ImmEstimate{};
  estimate_.mode_probabilities = config.initial_mode_probabilities;
  estimate_.log_likelihoods = Eigen::VectorXd::Constant(num_modes(), kNaN);
  estimate_.nis = Eigen::VectorXd::Constant(num_modes(), kNaN);
  estimate_.mode_failures.assign(static_cast<std::size_t>(num_modes()), ModeFailure::kNone);
  estimate_.failure_reasons.assign(static_cast<std::size_t>(num_modes()), std::string());
  estimate_.mode_states.assign(num_modes(), config.initial_state);
  estimate_.mode_covariances.assign(num_modes(), config.initial_covariance);
  estimate_.state = config.initial_state;
  estimate_.covariance = config.initial_covariance;
  estimate_.mode_probabilities.maxCoeff(&estimate_.most_likely_mode);
}

const ImmEstimate& Imm::step(double t, const Eigen::Ref<const Eigen::VectorXd>& u,
                             const Eigen::Ref<const Eigen::VectorXd>& z) {
  SKIDIMM_CHECK(u.size() == bank_.config.input_dim(), "input vector size differs from the bank's inputs");
  SKIDIMM_CHECK(z.size() == bank_.config.measurement.h.rows(),
                "measurement vector size differs from the bank's measurement");
  if (!u.allFinite() || !std::isfinite(t)) {
    estimate_.status = StepStatus::kRejectedInput;
    return estimate_;
  }
  if (initialized_ && !(t > last_t_)) {
    estimate_.status = StepStatus::kRejectedTime;
    return estimate_;
  }
  kernel_->step(!initialized_, initialized_ ? t - last_t_ : 0.0, held_input_, u, z, &estimate_);
  if (estimate_.num_rejected_modes > 0) {
    // The kernel names failures in prediction; the others came later.
    for (int j = 0; j < num_modes(); ++j) {
      ModeFailure& failure = estimate_.mode_failures[static_cast<std::size_t>(j)];
      if (failure == ModeFailure::kNone && std::isinf(estimate_.log_likelihoods[j])) {
        failure = ModeFailure::kUpdate;
      }
    }
  }
  estimate_.t = t;
  held_input_ = u;
  last_t_ = t;
  initialized_ = true;
  return estimate_;
}

ImmCheckpoint Imm::checkpoint() const {
  const BankConfig& config = bank_.config;
  ImmCheckpoint checkpoint;
  for (const ModeConfig& mode : config.modes) checkpoint.mode_names.push_back(mode.name);
  checkpoint.state_names = config.state_names;
  checkpoint.input_names = config.input_names;
  checkpoint.measurement_rows = static_cast<int>(config.measurement.h.rows());
  checkpoint.started = initialized_;
  checkpoint.t = last_t_;
  checkpoint.held_input = held_input_;
  checkpoint.estimate = estimate_;
  kernel_->save(&checkpoint);
  return checkpoint;
}

namespace {

std::string name_list(const std::vector<std::string>& names) {
  std::string text;
  for (const std::string& name : names) text += (text.empty() ? "" : ", ") + name;
  return "[" + text + "]";
}

// Throws what makes `checkpoint` unfit for an Imm of `config` whose kernel
// keeps memory shaped as `current` (its own checkpoint); nothing when it fits.
void check_checkpoint(const BankConfig& config, const ImmCheckpoint& current, const ImmCheckpoint& checkpoint) {
  const auto fail = [](const std::string& what) { throw Error("cannot restore this checkpoint: " + what); };
  const auto same_names = [&](const char* what, const std::vector<std::string>& theirs,
                              const std::vector<std::string>& ours) {
    if (theirs != ours) {
      fail(std::string("it was made by a bank of ") + what + " " + name_list(theirs) + ", this bank's are " +
           name_list(ours));
    }
  };
  same_names("modes", checkpoint.mode_names, current.mode_names);
  same_names("states", checkpoint.state_names, current.state_names);
  same_names("inputs", checkpoint.input_names, current.input_names);
  if (checkpoint.measurement_rows != current.measurement_rows) {
    fail("it was made by a bank measuring " + std::to_string(checkpoint.measurement_rows) +
         " rows, this bank measures " + std::to_string(current.measurement_rows));
  }
  const Eigen::Index modes = config.num_modes(), n = config.state_dim(), m = current.measurement_rows;
  const ImmEstimate& e = checkpoint.estimate;
  const auto sized = [&](const char* what, Eigen::Index size, Eigen::Index expected) {
    if (size != expected) {
      fail(std::string(what) + " has " + std::to_string(size) + " entries, expected " + std::to_string(expected));
    }
  };
  const auto finite = [&](const char* what, bool all_finite) {
    if (!all_finite) fail(std::string(what) + " is not finite");
  };
  if (!std::isfinite(checkpoint.t)) fail("its time is not finite");
  sized("the held input", checkpoint.held_input.size(), config.input_dim());
  finite("the held input", checkpoint.held_input.allFinite());
  sized("the mode probabilities", e.mode_probabilities.size(), modes);
  if (!e.mode_probabilities.allFinite() || (e.mode_probabilities.array() < 0.0).any() ||
      !(e.mode_probabilities.sum() > 0.0) || !(e.unknown_probability >= 0.0 && e.unknown_probability <= 1.0)) {
    fail("its mode probabilities are not probabilities");
  }
  if (e.most_likely_mode < 0 || e.most_likely_mode >= modes) fail("its most likely mode is not a mode");
  sized("the log-likelihoods", e.log_likelihoods.size(), modes);
  sized("the NIS", e.nis.size(), modes);
  sized("the mode failures", static_cast<Eigen::Index>(e.mode_failures.size()), modes);
  sized("the failure reasons", static_cast<Eigen::Index>(e.failure_reasons.size()), modes);
  sized("the mode states", static_cast<Eigen::Index>(e.mode_states.size()), modes);
  sized("the mode covariances", static_cast<Eigen::Index>(e.mode_covariances.size()), modes);
  for (Eigen::Index j = 0; j < modes; ++j) {
    const Eigen::VectorXd& x = e.mode_states[static_cast<std::size_t>(j)];
    const Eigen::MatrixXd& p = e.mode_covariances[static_cast<std::size_t>(j)];
    sized("a mode's state", x.size(), n);
    if (p.rows() != n || p.cols() != n)
      fail("a mode's covariance is not " + std::to_string(n) + " x " + std::to_string(n));
    finite("a mode's state", x.allFinite());
    finite("a mode's covariance", p.allFinite());
  }
  sized("the combined state", e.state.size(), n);
  if (e.covariance.rows() != n || e.covariance.cols() != n) fail("the combined covariance is not n x n");
  finite("the combined state", e.state.allFinite());
  finite("the combined covariance", e.covariance.allFinite());
  if (!checkpoint.innovations.empty()) {
    sized("the innovation memory", static_cast<Eigen::Index>(checkpoint.innovations.size()), modes);
    for (const InnovationMemory& memory : checkpoint.innovations) {
      // A count of steps, bounded by the engine as it counts (residual_correlation.h).
      if (memory.rows.size() != memory.whitened.size() || static_cast<Eigen::Index>(memory.rows.size()) > m ||
          memory.steps_since < 0 || memory.steps_since > (1 << 20)) {
        fail("a mode's innovation memory is malformed");
      }
      for (std::size_t a = 0; a < memory.rows.size(); ++a) {
        if (memory.rows[a] < 0 || memory.rows[a] >= m || (a > 0 && memory.rows[a] <= memory.rows[a - 1])) {
          fail("a mode's innovation memory names rows that are not increasing measurement rows");
        }
        if (!std::isfinite(memory.whitened[a])) fail("a mode's innovation memory is not finite");
      }
    }
  }
}

}  // namespace

void Imm::restore(const ImmCheckpoint& checkpoint) {
  check_checkpoint(bank_.config, this->checkpoint(), checkpoint);
  const std::string problem = kernel_->checkpoint_problem(checkpoint);
  if (!problem.empty()) throw Error("cannot restore this checkpoint: " + problem);
  kernel_->restore(checkpoint);
  initialized_ = checkpoint.started;
  last_t_ = checkpoint.t;
  held_input_ = checkpoint.held_input;
  estimate_ = checkpoint.estimate;
  if (!bank_.config.unknown.enabled() && estimate_.unknown_probability != 0.0) {
    // From a bank with a "none of these" hypothesis: this one has none, so
    // the modes share what it held, in proportion, as conditioning on "some
    // mode holds" gives them.
    estimate_.unknown_probability = 0.0;
    estimate_.mode_probabilities /= estimate_.mode_probabilities.sum();
    estimate_.mode_probabilities.maxCoeff(&estimate_.most_likely_mode);
  }
}

const char* to_string(ModeFailure failure) {
  switch (failure) {
    case ModeFailure::kNone:
      return "none";
    case ModeFailure::kModel:
      return "the model failed";
    case ModeFailure::kNotFinite:
      return "the model returned a non-finite state, Jacobian or process noise";
    case ModeFailure::kUpdate:
      return "the measurement update failed (innovation covariance not positive definite, or a non-finite result)";
    case ModeFailure::kDiverged:
      return "the filter diverged (a non-finite or absurd state, or a negative variance) and was reset";
    case ModeFailure::kGated:
      return "the measurement was outside the innovation gate";
  }
  return "unknown";
}

}  // namespace skidimm
