// Fitting by likelihood, its second part: the derivatives of one prediction
// step from the model at the prior state, in the parameters of
// likelihood_parameterization.h (analytic where the plugin gives them,
// bounded finite differences where not). Private to the fitting library.
#ifndef SKIDIMM_CORE_SRC_FITTING_STEP_DERIVATIVES_H_
#define SKIDIMM_CORE_SRC_FITTING_STEP_DERIVATIVES_H_

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "likelihood_parameterization.h"

namespace skidimm {
namespace fitting {
namespace internal {
// Internal linkage, as when these parts were one file: likelihood_fitter.cc
// is the one translation unit that includes them.
namespace {

// ---------------------------------------------------------------------------
// Derivatives of one prediction step from the model, at the prior state.

// Finite-difference weights in one parameter that stay inside its bounds:
// central where both neighbours are feasible, otherwise the second-order
// one-sided formula (-3 f(0) + 4 f(h) - f(2h)) / 2h (or its mirror), so a
// parameter next to a bound keeps an O(h^2) derivative.
struct Stencil {
  std::vector<double> offsets;  // 0 means the nominal value
  std::vector<double> weights;
};

bool stencil_for(double value, double lower, double upper, Stencil* s) {
  const double h = difference_step(value);
  if (value - h >= lower && value + h <= upper) {
    *s = {{h, -h}, {0.5 / h, -0.5 / h}};
  } else if (value + 2.0 * h <= upper) {
    *s = {{0.0, h, 2.0 * h}, {-1.5 / h, 2.0 / h, -0.5 / h}};
  } else if (value - 2.0 * h >= lower) {
    *s = {{0.0, -h, -2.0 * h}, {1.5 / h, -2.0 / h, 0.5 / h}};
  } else {
    return false;  // a range narrower than 2h
  }
  return true;
}

// Stacked derivative matrices: block p (rows p n .. p n + n - 1) is
// d M / d parameter_p. Blocks that came out exactly zero are flagged and
// skipped by the recursion (a linear model's F does not depend on x or B).
struct Stack {
  Eigen::MatrixXd blocks;
  std::vector<bool> zero;
  void resize(int count, int n) {
    blocks.setZero(static_cast<Eigen::Index>(count) * n, n);
    zero.assign(static_cast<std::size_t>(count), true);
  }
  auto block(int p, int n) { return blocks.middleRows(static_cast<Eigen::Index>(p) * n, n); }
  auto block(int p, int n) const { return blocks.middleRows(static_cast<Eigen::Index>(p) * n, n); }
  void flag(int p, int n) { zero[static_cast<std::size_t>(p)] = (block(p, n).array() == 0.0).all(); }
};

// Which derivatives of a step the model makes non-zero, as observed at every
// row of the logs at some parameters, so that the model calls for the others
// can be skipped (a linear model's F depends neither on x nor on B); and
// whether F and Qd stay the same when x and u change (a linear model's do),
// in which case a step's derivatives in the parameters and in Q depend on dt
// alone and are cached by dt within an evaluation. The fitter observes at
// the start and again, computing everything, at each solution; if the
// second sees more than the first, it solves again (fit_group()).
struct StepStructure {
  std::vector<bool> f_x, q_x;          // d F / d x_i, d Qd / d x_i seen non-zero
  std::vector<bool> f_theta, q_theta;  // d F / d theta_p, d Qd / d theta_p seen non-zero
  bool static_step = true;

  void reset(int n, int num_model) {
    f_x.assign(static_cast<std::size_t>(n), false);
    q_x.assign(static_cast<std::size_t>(n), false);
    f_theta.assign(static_cast<std::size_t>(num_model), false);
    q_theta.assign(static_cast<std::size_t>(num_model), false);
    static_step = true;
  }
  // Everything `other` saw is allowed for here.
  bool covers(const StepStructure& other) const {
    auto subset = [](const std::vector<bool>& small, const std::vector<bool>& large) {
      for (std::size_t i = 0; i < small.size(); ++i) {
        if (small[i] && !large[i]) return false;
      }
      return true;
    };
    return subset(other.f_x, f_x) && subset(other.q_x, q_x) && subset(other.f_theta, f_theta) &&
           subset(other.q_theta, q_theta) && (other.static_step || !static_step);
  }
  void merge(const StepStructure& other) {
    for (std::size_t i = 0; i < f_x.size(); ++i) f_x[i] = f_x[i] || other.f_x[i];
    for (std::size_t i = 0; i < q_x.size(); ++i) q_x[i] = q_x[i] || other.q_x[i];
    for (std::size_t i = 0; i < f_theta.size(); ++i) f_theta[i] = f_theta[i] || other.f_theta[i];
    for (std::size_t i = 0; i < q_theta.size(); ++i) q_theta[i] = q_theta[i] || other.q_theta[i];
    static_step = static_step && other.static_step;
  }
};

// The derivatives of one prediction step that the sensitivity recursion
// needs from the model, at the prior state x:
//   g        d f / d theta: parameter_jacobian(), or differences of predict();
//   f_x, q_x d F / d x_i, d Qd / d x_i: central differences of jacobian() and
//            process_noise() in x (second derivatives of f the SDK does not
//            expose);
//   f_theta, q_theta  d F / d theta_p, d Qd / d theta_p: differences of
//            jacobian() and process_noise() in each parameter (Stencil);
//   q_q      d Qd / d Q_ij = process_noise(E_ij) (linear in the intensity).
class StepDifferentiator {
 public:
  // `use`: skip what it marks as never non-zero and cache static steps by dt
  // (nullptr: compute everything). `observe`: compute everything and record
  // what is non-zero into it (nullptr: do not).
  StepDifferentiator(sdk::MotionModel* model, const Parameterization& par, bool numeric_derivatives,
                     const StepStructure* use, StepStructure* observe)
      : model_(model), par_(par), numeric_(numeric_derivatives), use_(use), observe_(observe) {
    n_ = model->state_dim();
    const auto& info = model->parameter_info();
    base_.resize(static_cast<Eigen::Index>(info.size()));
    model->get_parameters(base_);
    perturbed_ = base_;
    full_g_.resize(n_, base_.size());
    g.resize(n_, par.num_model());
    f_theta.resize(par.num_model(), n_);
    q_theta.resize(par.num_model(), n_);
    f_x.resize(n_, n_);
    q_x.resize(n_, n_);
    q_q.resize(par.num_q(), n_);
    f_work_.resize(n_, n_);
    q_work_.resize(n_, n_);
    x_work_.resize(n_);
    for (const auto& [i, j] : par.q_entries) q_basis_.push_back(basis(n_, i, j));
    stencils_.resize(static_cast<std::size_t>(par.num_model()));
    for (int p = 0; p < par.num_model(); ++p) {
      const int k = par.model_index[static_cast<std::size_t>(p)];
      const sdk::ParameterInfo& pi = info[static_cast<std::size_t>(k)];
      if (!stencil_for(base_[k], pi.lower_bound, pi.upper_bound, &stencils_[static_cast<std::size_t>(p)])) {
        stencil_failure_ = "parameter '" + pi.name + "' has a range too narrow to differentiate";
      }
    }
  }

  // Fills the members below at (x, u, dt). `f`, `qd`, `x_next` are the
  // nominal values the filter computed. `dx_rows_used[i]` false: no
  // sensitivity flows through x_i, so its partials are not needed.
  bool compute(const Eigen::VectorXd& x, const Eigen::VectorXd& u, double dt, const Eigen::MatrixXd& q_intensity,
               const Eigen::MatrixXd& f, const Eigen::MatrixXd& qd, const Eigen::VectorXd& x_next,
               const std::vector<bool>& dx_rows_used, std::string* why) {
    if (!stencil_failure_.empty()) return fail(why, stencil_failure_);
    const int nm = par_.num_model();
    const bool observing = observe_ != nullptr;
    // d f / d theta: exact from the plugin where it has it.
    bool exact = false;
    if (!numeric_ && nm > 0 && model_->parameter_jacobian(x, u, dt, full_g_)) {
      exact = full_g_.allFinite();
      for (int p = 0; exact && p < nm; ++p) g.col(p) = full_g_.col(par_.model_index[static_cast<std::size_t>(p)]);
    }
    if (!exact && nm > 0) used_numeric = true;

    // A static step's derivatives in theta and Q depend on dt alone. While
    // observing, each row is checked (as long as every row so far was static).
    if (observing && observe_->static_step && !check_static(x, u, dt, q_intensity, f, qd, why)) return false;
    const bool cacheable = observing ? observe_->static_step : use_ != nullptr && use_->static_step;
    std::uint64_t key = 0;
    std::memcpy(&key, &dt, sizeof key);
    const auto cached = cacheable ? cache_.find(key) : cache_.end();
    const bool hit = cached != cache_.end();

    // d F / d x_i and d Qd / d x_i.
    for (int i = 0; i < n_; ++i) {
      const std::size_t si = static_cast<std::size_t>(i);
      f_x.zero[si] = q_x.zero[si] = true;
      // A static step has none.
      const bool need_f = !cacheable && (observing || (dx_rows_used[si] && (use_ == nullptr || use_->f_x[si])));
      const bool need_q = !cacheable && (observing || (dx_rows_used[si] && (use_ == nullptr || use_->q_x[si])));
      if (!need_f && !need_q) continue;
      const double h = difference_step(x[i]);
      auto fb = f_x.block(i, n_);
      auto qb = q_x.block(i, n_);
      for (const double sign : {1.0, -1.0}) {
        x_work_ = x;
        x_work_[i] = x[i] + sign * h;
        if ((need_f && !model_->jacobian(x_work_, u, dt, f_work_)) ||
            (need_q && !model_->process_noise(q_intensity, x_work_, u, dt, q_work_))) {
          return fail(why, "the model failed at a perturbed state (differences of F and Q in x)");
        }
        if (need_f) {
          if (sign > 0) {
            fb = f_work_;
          } else {
            fb -= f_work_;
          }
        }
        if (need_q) {
          if (sign > 0) {
            qb = q_work_;
          } else {
            qb -= q_work_;
          }
        }
      }
      if (need_f) {
        fb /= 2.0 * h;
        f_x.flag(i, n_);
      }
      if (need_q) {
        qb /= 2.0 * h;
        q_x.flag(i, n_);
      }
    }

    // d F / d theta, d Qd / d theta (and d f / d theta without an exact
    // parameter Jacobian): differences in each parameter, at x held fixed.
    bool perturbed = false;
    for (int p = 0; p < nm; ++p) {
      const std::size_t sp = static_cast<std::size_t>(p);
      const int k = par_.model_index[sp];
      const bool need_f = !hit && (observing || use_ == nullptr || use_->f_theta[sp]);
      const bool need_q = !hit && (observing || use_ == nullptr || use_->q_theta[sp]);
      const bool need_g = !exact;
      if (hit) {
        f_theta.zero[sp] = cached->second.f_theta.zero[sp];
        q_theta.zero[sp] = cached->second.q_theta.zero[sp];
        if (!f_theta.zero[sp]) f_theta.block(p, n_) = cached->second.f_theta.block(p, n_);
        if (!q_theta.zero[sp]) q_theta.block(p, n_) = cached->second.q_theta.block(p, n_);
      } else {
        f_theta.zero[sp] = q_theta.zero[sp] = true;
      }
      if (!need_f && !need_q && !need_g) continue;
      const Stencil& s = stencils_[sp];
      auto fb = f_theta.block(p, n_);
      auto qb = q_theta.block(p, n_);
      if (need_f) fb.setZero();
      if (need_q) qb.setZero();
      if (need_g) g.col(p).setZero();
      for (std::size_t a = 0; a < s.offsets.size(); ++a) {
        const double w = s.weights[a];
        if (s.offsets[a] == 0.0) {  // the nominal values; x_next - x_next adds nothing to g
          if (need_f) fb += w * f;
          if (need_q) qb += w * qd;
          continue;
        }
        perturbed_[k] = base_[k] + s.offsets[a];
        perturbed = true;
        if (!model_->set_parameters(perturbed_, nullptr)) {
          perturbed_[k] = base_[k];
          restore();
          return fail(why, "the model rejected parameter '" + name(k) + "' perturbed by " + number(s.offsets[a]) +
                               " for differences");
        }
        const bool ok = (!need_f || model_->jacobian(x, u, dt, f_work_)) &&
                        (!need_q || model_->process_noise(q_intensity, x, u, dt, q_work_)) &&
                        (!need_g || model_->predict(x, u, dt, x_work_));
        perturbed_[k] = base_[k];
        if (!ok) {
          restore();
          return fail(why, "the model failed with parameter '" + name(k) + "' perturbed");
        }
        if (need_f) fb += w * f_work_;
        if (need_q) qb += w * q_work_;
        if (need_g) {
          // Differences of angle components are wrapped, relative to the
          // nominal prediction, so that a step across +-pi is not a 2 pi jump.
          for (int r = 0; r < n_; ++r) {
            double d = x_work_[r] - x_next[r];
            if (model_->is_angle(r)) d = sdk::wrap_angle(d);
            g(r, p) += w * d;
          }
        }
      }
      if (need_f) f_theta.flag(p, n_);
      if (need_q) q_theta.flag(p, n_);
    }
    if (perturbed && !restore()) return fail(why, "the model rejected its own parameters back");

    // d Qd / d Q_ij = process_noise(E_ij): process_noise() is linear in the
    // intensity (checked once by check_linear_in_intensity()).
    for (int e = 0; e < par_.num_q(); ++e) {
      const std::size_t se = static_cast<std::size_t>(e);
      if (hit) {
        q_q.zero[se] = cached->second.q_q.zero[se];
        if (!q_q.zero[se]) q_q.block(e, n_) = cached->second.q_q.block(e, n_);
        continue;
      }
      if (!model_->process_noise(q_basis_[se], x, u, dt, q_work_)) {
        return fail(why, "the model's process_noise() failed for a basis matrix of Q");
      }
      q_q.block(e, n_) = q_work_;
      q_q.flag(e, n_);
    }
    const bool finite = g.allFinite() && f_theta.blocks.allFinite() && q_theta.blocks.allFinite() &&
                        f_x.blocks.allFinite() && q_x.blocks.allFinite() && q_q.blocks.allFinite();
    if (!finite) return fail(why, "a derivative of the model is not finite");

    if (observing) record();
    if (cacheable && !hit && cache_.size() < kMaxCachedSteps) cache_.emplace(key, Cached{f_theta, q_theta, q_q});
    return true;
  }

  bool used_numeric = false;
  Eigen::MatrixXd g;  // d f / d theta, n x num_model
  Stack f_theta, q_theta, f_x, q_x, q_q;

 private:
  struct Cached {
    Stack f_theta, q_theta, q_q;
  };
  // Enough for a log on a fixed grid (one dt) or a few rates; a log whose
  // every dt differs gains nothing from the cache and does not grow it.
  static constexpr std::size_t kMaxCachedSteps = 64;

  // Records what this step made non-zero.
  void record() {
    StepStructure& o = *observe_;
    for (int i = 0; i < n_; ++i) {
      const std::size_t si = static_cast<std::size_t>(i);
      o.f_x[si] = o.f_x[si] || !f_x.zero[si];
      o.q_x[si] = o.q_x[si] || !q_x.zero[si];
    }
    for (std::size_t p = 0; p < o.f_theta.size(); ++p) {
      o.f_theta[p] = o.f_theta[p] || !f_theta.zero[p];
      o.q_theta[p] = o.q_theta[p] || !q_theta.zero[p];
    }
  }

  // Clears observe_->static_step if F or Qd move when x and u move together
  // by a small step in every component (of unequal sizes, so that no
  // dependence cancels). Qd of Q's basis matrices is taken to follow Qd: it
  // is linear in Q (check_linear_in_intensity()).
  bool check_static(const Eigen::VectorXd& x, const Eigen::VectorXd& u, double dt, const Eigen::MatrixXd& q_intensity,
                    const Eigen::MatrixXd& f, const Eigen::MatrixXd& qd, std::string* why) {
    x_work_ = x;
    for (int i = 0; i < n_; ++i) x_work_[i] += difference_step(x[i]) * (1.0 + 0.37 * i);
    u_work_ = u;
    for (Eigen::Index j = 0; j < u.size(); ++j) u_work_[j] += difference_step(u[j]) * (1.0 + 0.29 * j);
    if (!model_->jacobian(x_work_, u_work_, dt, f_work_) ||
        !model_->process_noise(q_intensity, x_work_, u_work_, dt, q_work_)) {
      return fail(why, "the model failed at a perturbed state and input");
    }
    observe_->static_step = f_work_ == f && q_work_ == qd;
    return true;
  }

  std::string name(int k) const { return model_->parameter_info()[static_cast<std::size_t>(k)].name; }
  bool restore() { return model_->set_parameters(base_, nullptr); }
  static bool fail(std::string* why, const std::string& message) {
    *why = message;
    return false;
  }

  sdk::MotionModel* model_;
  const Parameterization& par_;
  bool numeric_;
  const StepStructure* use_;
  StepStructure* observe_;
  int n_ = 0;
  Eigen::VectorXd base_, perturbed_;
  Eigen::MatrixXd full_g_, f_work_, q_work_;
  Eigen::VectorXd x_work_, u_work_;
  std::vector<Eigen::MatrixXd> q_basis_;
  std::vector<Stencil> stencils_;
  std::string stencil_failure_;
  std::unordered_map<std::uint64_t, Cached> cache_;
};

// process_noise(Q) = sum_ij Q_ij process_noise(E_ij), to round-off: what
// d Qd / d Q = process_noise(E) relies on.
bool check_linear_in_intensity(const sdk::MotionModel& model, const Eigen::MatrixXd& q, const Eigen::VectorXd& x,
                                      const Eigen::VectorXd& u, double dt, std::string* why) {
  const int n = model.state_dim();
  Eigen::MatrixXd whole(n, n), sum = Eigen::MatrixXd::Zero(n, n), part(n, n);
  if (!model.process_noise(q, x, u, dt, whole)) {
    *why = "process_noise() failed";
    return false;
  }
  const Eigen::MatrixXd symmetric = 0.5 * (q + q.transpose());
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j <= i; ++j) {
      if (symmetric(i, j) == 0.0) continue;
      if (!model.process_noise(basis(n, i, j), x, u, dt, part)) {
        *why = "process_noise() failed for a basis matrix of Q";
        return false;
      }
      sum += symmetric(i, j) * part;
    }
  }
  const double scale = std::max(whole.cwiseAbs().maxCoeff(), std::numeric_limits<double>::min());
  if ((sum - whole).cwiseAbs().maxCoeff() > 1e-8 * scale) {
    *why =
        "the model's process_noise() is not linear in the intensity Q (process_noise(Q) differs from the sum of "
        "Q_ij process_noise(E_ij) by " +
        number((sum - whole).cwiseAbs().maxCoeff() / scale) +
        " relative); the likelihood fitter differentiates Q through that linearity, as every discretisation of "
        "white noise has it; keep the bank's Q (process noise kKeep)";
    return false;
  }
  return true;
}

}  // namespace
}  // namespace internal
}  // namespace fitting
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_FITTING_STEP_DERIVATIVES_H_
