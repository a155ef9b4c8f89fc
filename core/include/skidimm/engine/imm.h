// Imm: the Interacting Multiple Model estimator (paper, section IV; Bar-Shalom,
// Li and Kirubarajan 2001, section 11.6.6).
//
// One step k, for N modes with transition p_ij (row = from, column = to):
//   c_j       = sum_i p_ij mu_{k-1}^i                          (eq. 5)
//   mu^{i|j}  = p_ij mu_{k-1}^i / c_j                          (eq. 4)
//   x^{0j}, P^{0j}: mixed initial conditions                   (eq. 6-7)
//   per mode: EKF predict from x^{0j}, P^{0j}, update, Lambda^j (eq. 8)
//   mu_k^j    = (Lambda^j)^w c_j / sum_i (Lambda^i)^w c_i     (w = 1 unless the
//                                        bank sets likelihood_weight)
//   x_k, P_k: combined estimate                                (eq. 10-11)
//
// The paper's eq. 9 writes mu_{k-1}^j where the predicted probability c_j
// belongs; with it the transition matrix would have no effect on the mode
// probabilities. We use Bar-Shalom's form. Likelihoods stay in the log domain
// (log-sum-exp), probabilities are floored (mode_probability_floor) so a mode
// can always come back, and angle components are mixed around a reference so
// that the +-pi seam does not average 179 deg and -179 deg to 0.
//
// Time: the prior holds at the first step's t, whose measurement is applied
// without prediction. Each later step predicts from the previous t with the
// previous step's input (zero-order hold), then updates with its measurement.
// NaN entries of z are missing: with none present the step is predict-only and
// no likelihood is applied; with some present only those are used.
//
// step() allocates nothing after construction.
//
// Thread safety: one Imm is used from one thread at a time (step() and
// reset() change it). Separate Imms may run on separate threads, also when
// they share model instances (Imms made from copies of one Bank): the engine
// calls only a model's const members, which the SDK requires to be safe to
// call concurrently (sdk/motion_model.h). Pinned by
// tests/core/thread_safety_test.cc under ThreadSanitizer (docs/engine.md).
//
// Parameters: an Imm reads its models' parameters as they are at each step,
// except that the fixed-size kernels keep F and Qd of a model whose
// jacobian_and_noise_depend_only_on_dt() for as long as dt repeats, from the
// first step after reset() on. Change a model's parameters between runs and
// reset() before the next.
//
// Speed: the step runs in a kernel chosen once, here, for the bank's shape:
// fixed-size Eigen types when the state and the measurement have at most 4
// components each, dynamic ones otherwise; mixing (eq. 6-7) is one product of
// the transition with the modes' moments about a common reference
// (gaussian_mixture.h), and the transition for dwell times costs O(N^2) per
// step like a per-step matrix (mode_transition.h). docs/performance.md has the
// figures; tests/core/imm_test.cc pins the results against a hand-written
// per-target IMM.
#ifndef SKIDIMM_ENGINE_IMM_H_
#define SKIDIMM_ENGINE_IMM_H_

#include <Eigen/Core>
#include <filesystem>
#include <memory>
#include <vector>

#include "skidimm/config/bank.h"
#include "skidimm/engine/ekf.h"
#include "skidimm/engine/imm_checkpoint.h"
#include "skidimm/engine/imm_estimate.h"
#include "skidimm/engine/measurement_model.h"
#include "skidimm/engine/mode_transition.h"

namespace skidimm {

namespace internal {
class ImmKernel;  // imm_kernel.h, private
}  // namespace internal

// Which kernel runs the step: the fastest for the bank's shape (fixed sizes:
// for states and measurements of at most 4 components each, and for up to
// kMaxFixedStates states with a measurement of any size; a build configured
// with SKIDIMM_FIXED_SIZE_KERNELS=bundled has only the bundled banks' shapes),
// or always the dynamic one (tests and benchmarks compare the two).
enum class ImmKernelChoice { kFastest, kDynamic };
inline constexpr int kMaxFixedStates = 12;

class Imm {
 public:
  // Loads a bank file and its plugins; see Bank::load for the search path.
  static Imm from_yaml(const std::filesystem::path& bank_file,
                       const std::vector<std::filesystem::path>& plugin_paths = {});

  explicit Imm(Bank bank, ImmKernelChoice kernel = ImmKernelChoice::kFastest);
  Imm(Imm&&) noexcept;
  Imm& operator=(Imm&&) noexcept;
  ~Imm();

  // One filter cycle at time t (s) with input u (bank input order) and
  // measurement z (bank measurement order, NaN = not measured).
  const ImmEstimate& step(double t, const Eigen::Ref<const Eigen::VectorXd>& u,
                          const Eigen::Ref<const Eigen::VectorXd>& z);

  const ImmEstimate& estimate() const { return estimate_; }
  const Bank& bank() const { return bank_; }
  const BankConfig& config() const { return bank_.config; }
  int num_modes() const { return bank_.config.num_modes(); }

  // Back to the prior; the next step is a first step again.
  void reset();

  // Everything the next step depends on (imm_checkpoint.h): restored into an
  // Imm of a bank with the same modes, states, inputs and measurement, every
  // later step gives what this Imm's would, bit for bit. The checkpoint's
  // `decision` is left empty (ModeDecision::memory()).
  ImmCheckpoint checkpoint() const;
  // Continues from `checkpoint` (its decision is not the Imm's). Throws an
  // Error saying what does not fit this bank (modes, states, inputs,
  // measurement rows, sizes); the Imm is then unchanged.
  void restore(const ImmCheckpoint& checkpoint);

  // Whether the bank runs on a fixed-size kernel (the fastest kernel chosen,
  // and one compiled for the bank's shape).
  bool uses_fixed_size_kernel() const { return fixed_size_; }

 private:
  Bank bank_;
  std::unique_ptr<internal::ImmKernel> kernel_;
  bool fixed_size_ = false;

  ImmEstimate estimate_;
  bool initialized_ = false;
  double last_t_ = 0.0;
  Eigen::VectorXd held_input_;
};

}  // namespace skidimm

#endif  // SKIDIMM_ENGINE_IMM_H_
