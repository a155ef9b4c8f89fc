// Temporally correlated innovations: each mode's likelihood of a step
// conditioned on its innovation at the step before (`residual_correlation:`
// of a bank mode, docs/engine.md "Correlated innovations").
//
// The IMM scores mode j at step k with N(nu_k; 0, S_k), as if its innovations
// were independent from step to step. A mode whose model misses the same way
// for many steps (a regression that is a little off for this drive, features
// averaged over overlapping windows) then counts the same miss again at every
// step. The model here: mode j's whitened innovation e_k = L_k^-1 nu_k
// (S_k = L_k L_k', the Cholesky factor of its innovation covariance) is a
// stationary AR(1) with coefficient rho_j,
//
//   e_k = rho e_{k-1} + sqrt(1 - rho^2) eta_k,    eta_k ~ N(0, I),
//
// so marginally e_k ~ N(0, I), as the filter assumes, and given the last
// innovation, g steps back (g > 1 across steps that measured nothing),
//
//   e_k | e_{k-g} ~ N(a e_{k-g}, (1 - a^2) I),    a = rho^g.
//
// With nu_k = L_k e_k, the conditional log density of nu_k is
//
//   log Lambda = -1/2 (d2c + k log(1 - a^2) + log det(2 pi S_k)),
//   d2c = |e_k - a e_{k-g}|^2 / (1 - a^2),
//
// which is log N(nu_k; 0, S_k) + d2/2 - d2c/2 - k/2 log(1 - a^2) with
// d2 = |e_k|^2, the step's NIS. A mode's innovation memory is its own: the
// whitened coordinates of two modes differ (their S differ), so a mixture of
// memories would be a memory of nothing; the misfit the AR(1) describes is
// that of the mode's model, which persists with the model, not with the
// probabilities. The memory holds one set of measured rows: a step that
// measures another set (whitening another set mixes rows differently) is
// scored by the marginal density and starts a new memory, as does a step after
// the mode was gated, failed or was reset, and the first step.
//
// Allocates only at construction. Private to the engine.
#ifndef SKIDIMM_CORE_SRC_RESIDUAL_CORRELATION_H_
#define SKIDIMM_CORE_SRC_RESIDUAL_CORRELATION_H_

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "skidimm/config/bank.h"
#include "skidimm/engine/imm_checkpoint.h"

namespace skidimm {
namespace internal {

class ResidualCorrelation {
 public:
  explicit ResidualCorrelation(const BankConfig& config) : active_(config.any_residual_correlation()) {
    if (!active_) return;
    const int modes = config.num_modes();
    const int m = static_cast<int>(config.measurement.h.rows());
    rho_.resize(static_cast<std::size_t>(modes));
    for (int j = 0; j < modes; ++j)
      rho_[static_cast<std::size_t>(j)] = config.modes[static_cast<std::size_t>(j)].residual_correlation;
    last_.setZero(m, modes);
    last_rows_.assign(static_cast<std::size_t>(modes) * static_cast<std::size_t>(m), -1);
    last_size_.assign(static_cast<std::size_t>(modes), 0);
    steps_since_.assign(static_cast<std::size_t>(modes), 0);
    remembers_.assign(static_cast<std::size_t>(modes), false);
    conditional_d2_.setZero(modes);
  }

  // Whether any mode's innovations are correlated; when not, nothing here runs.
  bool active() const { return active_; }

  // Every mode forgets (the first step, a restart from the prior).
  void forget_all() {
    if (active_) std::fill(remembers_.begin(), remembers_.end(), false);
  }
  void forget(int j) {
    if (active_) remembers_[static_cast<std::size_t>(j)] = false;
  }
  // One more filter step since each mode's last remembered innovation.
  void advance() {
    if (!active_) return;
    for (int& g : steps_since_) g = std::min(g + 1, 1 << 20);  // bounded: a count, not a clock
  }

  // Mode j updated with the rows rows[0..k) and whitened innovation
  // whitened[0..k) (L^-1 nu), Gaussian log density `gaussian` and NIS `nis`:
  // returns its log density conditioned on its last innovation, and
  // remembers this one. Sets conditional_d2(j).
  template <typename Rows, typename Whitened>
  double condition(int j, const Rows& rows, int k, const Whitened& whitened, double gaussian, double nis) {
    const std::size_t mode = static_cast<std::size_t>(j);
    const double rho = rho_[mode];
    conditional_d2_[j] = nis;
    if (rho == 0.0) return gaussian;  // independent: exactly the Gaussian density
    const std::size_t m = static_cast<std::size_t>(last_.rows());
    int* last_rows = &last_rows_[mode * m];
    bool same_rows = remembers_[mode] && last_size_[mode] == k;
    for (int a = 0; same_rows && a < k; ++a) same_rows = last_rows[a] == rows[static_cast<std::size_t>(a)];
    double result = gaussian;
    if (same_rows) {
      const double lag = std::pow(rho, steps_since_[mode]);
      const double spread = 1.0 - lag * lag;
      double d2 = 0.0;
      for (int a = 0; a < k; ++a) {
        const double v = whitened[a] - lag * last_(a, j);
        d2 += v * v;
      }
      d2 /= spread;
      conditional_d2_[j] = d2;
      result = gaussian + 0.5 * nis - 0.5 * d2 - 0.5 * k * std::log(spread);
    }
    for (int a = 0; a < k; ++a) {
      last_(a, j) = whitened[a];
      last_rows[a] = rows[static_cast<std::size_t>(a)];
    }
    last_size_[mode] = k;
    steps_since_[mode] = 0;
    remembers_[mode] = true;
    return result;
  }

  // Each mode's memory (ImmCheckpoint); none when inactive.
  std::vector<InnovationMemory> memory() const {
    std::vector<InnovationMemory> out;
    if (!active_) return out;
    const std::size_t m = static_cast<std::size_t>(last_.rows());
    for (std::size_t j = 0; j < rho_.size(); ++j) {
      InnovationMemory mode;
      mode.remembers = remembers_[j];
      mode.steps_since = steps_since_[j];
      for (int a = 0; a < last_size_[j]; ++a) {
        mode.rows.push_back(last_rows_[j * m + static_cast<std::size_t>(a)]);
        mode.whitened.push_back(last_(a, static_cast<Eigen::Index>(j)));
      }
      out.push_back(std::move(mode));
    }
    return out;
  }
  // From memory() of a bank of the same modes and measurement rows (checked
  // by Imm::restore); an empty one forgets all.
  void restore(const std::vector<InnovationMemory>& memory) {
    if (!active_) return;
    forget_all();
    const std::size_t m = static_cast<std::size_t>(last_.rows());
    for (std::size_t j = 0; j < memory.size() && j < rho_.size(); ++j) {
      const InnovationMemory& mode = memory[j];
      const int k = static_cast<int>(std::min(mode.rows.size(), m));
      for (int a = 0; a < k; ++a) {
        last_rows_[j * m + static_cast<std::size_t>(a)] = mode.rows[static_cast<std::size_t>(a)];
        last_(a, static_cast<Eigen::Index>(j)) = mode.whitened[static_cast<std::size_t>(a)];
      }
      last_size_[j] = k;
      steps_since_[j] = mode.steps_since;
      remembers_[j] = mode.remembers;
    }
  }

  // The squared distance of mode j's last conditioned innovation from its
  // conditional mean, in units of its conditional covariance (the NIS when
  // unconditioned): what a Student-t density scores.
  double conditional_d2(int j) const { return conditional_d2_[j]; }

 private:
  bool active_;
  std::vector<double> rho_;
  Eigen::MatrixXd last_;          // column j: mode j's last whitened innovation
  std::vector<int> last_rows_;    // per mode, m entries: the rows it measured
  std::vector<int> last_size_;    // per mode, how many
  std::vector<int> steps_since_;  // per mode, filter steps since it
  std::vector<bool> remembers_;
  Eigen::VectorXd conditional_d2_;
};

}  // namespace internal
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_RESIDUAL_CORRELATION_H_
