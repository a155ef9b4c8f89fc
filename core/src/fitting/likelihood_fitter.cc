#include "skidimm/fitting/likelihood_fitter.h"

#include <ceres/gradient_problem.h>
#include <ceres/gradient_problem_solver.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <sstream>
#include <unordered_map>
#include <utility>

#include "bounded_median.h"
#include "skidimm/covariance.h"
#include "skidimm/measurement_model.h"
#include "skidimm/sdk/angles.h"
#include "solver_progress.h"

namespace skidimm {
namespace fitting {

namespace {

constexpr double kLog2Pi = 1.8378770664093454835606594728112;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInfinity = std::numeric_limits<double>::infinity();
using ProcessNoise = LikelihoodFitOptions::ProcessNoise;

// cbrt(eps) balances truncation and round-off for central differences, as in
// sdk/numeric_jacobian.h.
double difference_step(double value) {
  static const double relative = std::cbrt(std::numeric_limits<double>::epsilon());
  return relative * std::max(1.0, std::abs(value));
}

std::string number(double value) {
  std::ostringstream out;
  out.precision(6);
  out << value;
  return out.str();
}

// ---------------------------------------------------------------------------
// What the sensitivities are taken with respect to, in natural units: the
// mode's free model parameters, then entries of Q, then diagonal entries of R.

struct Parameterization {
  std::vector<int> model_index;                // index in the model's flat parameter vector
  std::vector<std::pair<int, int>> q_entries;  // (i, j), i >= j: Q_ij and Q_ji move together
  std::vector<int> r_entries;                  // components c of R_cc

  int num_model() const { return static_cast<int>(model_index.size()); }
  int num_q() const { return static_cast<int>(q_entries.size()); }
  int num_r() const { return static_cast<int>(r_entries.size()); }
  int size() const { return num_model() + num_q() + num_r(); }
};

Parameterization parameterization_of(const sdk::MotionModel& model, int state_dim, int measurement_dim,
                                     const LikelihoodFitOptions& options) {
  Parameterization par;
  if (options.fit_model_parameters) {
    const auto& info = model.parameter_info();
    for (std::size_t i = 0; i < info.size(); ++i) {
      if (info[i].scope == sdk::ParameterScope::kMode) par.model_index.push_back(static_cast<int>(i));
    }
  }
  for (int i = 0; i < state_dim; ++i) {
    if (options.process_noise == ProcessNoise::kDiagonal) par.q_entries.emplace_back(i, i);
    if (options.process_noise == ProcessNoise::kFull) {
      for (int j = 0; j <= i; ++j) par.q_entries.emplace_back(i, j);
    }
  }
  if (options.fit_measurement_noise) {
    for (int c = 0; c < measurement_dim; ++c) par.r_entries.push_back(c);
  }
  return par;
}

std::string q_name(int i, int j) { return "Q[" + std::to_string(i) + "," + std::to_string(j) + "]"; }
std::string r_name(int c) { return "R[" + std::to_string(c) + "," + std::to_string(c) + "]"; }

std::vector<std::string> names_of(const Parameterization& par, const sdk::MotionModel& model) {
  std::vector<std::string> names;
  for (int i : par.model_index) names.push_back(model.parameter_info()[static_cast<std::size_t>(i)].name);
  for (const auto& [i, j] : par.q_entries) names.push_back(q_name(i, j));
  for (int c : par.r_entries) names.push_back(r_name(c));
  return names;
}

// The symmetric basis matrix of entry (i, j): d Q / d Q_ij.
Eigen::MatrixXd basis(int n, int i, int j) {
  Eigen::MatrixXd e = Eigen::MatrixXd::Zero(n, n);
  e(i, j) = e(j, i) = 1.0;
  return e;
}

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

// ---------------------------------------------------------------------------
// The mode's filter, with its sensitivities.

struct Accumulator {
  double nll = 0.0;
  int measured_rows = 0;
  int residuals = 0;
  Eigen::VectorXd sum_squares, sum_nis, counts;  // per measurement component
  Eigen::VectorXd gradient;                      // natural parameters
  Eigen::MatrixXd information;                   // BHHH, when wanted
  bool want_information = false;
  bool keep_rows = false;
  std::vector<Eigen::VectorXd> row_terms;
  // Instead of keeping them, each row's term as it comes (log: the index of
  // the log in the evaluation), NaN for rows that add none.
  std::function<void(std::size_t log, int row, double term)> row_sink;
  std::size_t log = 0;
  bool used_numeric = false;

  Accumulator(int measurement_dim, int num_parameters, bool information, bool rows)
      : want_information(information), keep_rows(rows) {
    sum_squares = sum_nis = counts = Eigen::VectorXd::Zero(measurement_dim);
    gradient = Eigen::VectorXd::Zero(num_parameters);
    if (information) this->information = Eigen::MatrixXd::Zero(num_parameters, num_parameters);
  }
};

// Runs ExtendedKalmanFilter's arithmetic (ekf.cc), in the same order so the
// values agree to round-off, with Imm's handling of time and missing data
// (imm.cc), and, with derivatives, the forward sensitivity recursion:
//
// predict (F, Qd and f at the prior x; dF = F_theta + sum_i F_x_i dx_i):
//   dx- = F dx + df/dtheta
//   dP- = F dP F' + dF P F' + F P dF' + dQd
// update (v = H' S^-1 nu, M = S^-1 - S^-1 nu nu' S^-1, A = I - K H):
//   dl  = -v' dx- + 1/2 <H' M H, dP-> + 1/2 <M, dR>       (l = the row's NLL term)
//   dx+ = A (dx- + dP- v) - K dR S^-1 nu
//   dP+ = A dP- A' + K dR K'
// The last line is the derivative of the Joseph form: it is stationary in K
// at the optimal gain (d/dK [(I-KH)P(I-KH)' + KRK'] = 2 (K S - P H') = 0), so
// dK drops out. dK does appear in dx+ and is folded into the dP- v term
// (dK nu = (dP- H' - K dS) S^-1 nu). These are the sensitivity equations of
// Gupta and Mehra (1974) for the EKF's recursion as the engine computes it.
class SensitivityFilter {
 public:
  // `use` and `observe` go to StepDifferentiator (nullptr: everything computed).
  SensitivityFilter(const BankConfig& config, sdk::MotionModel* model, const Parameterization& par,
                    const Eigen::MatrixXd& q_intensity, const Eigen::MatrixXd& r, bool derivatives,
                    bool numeric_derivatives, const StepStructure* use = nullptr, StepStructure* observe = nullptr)
      : config_(config),
        model_(model),
        par_(par),
        q_intensity_(q_intensity),
        measurement_(config.measurement.h, r, config.measurement.is_angle),
        derivatives_(derivatives) {
    n_ = model->state_dim();
    num_ = par.size();
    const int m = measurement_.measurement_dim();
    selection_ = measurement_.make_selection();
    for (int i = 0; i < n_; ++i) is_angle_.push_back(model->is_angle(i));
    f_.resize(n_, n_);
    qd_.resize(n_, n_);
    fp_.resize(n_, n_);
    x_next_.resize(n_);
    i_kh_.resize(n_, n_);
    innovation_.resize(m);
    whitened_.resize(m);
    s_diagonal_.resize(m);
    hp_.resize(m, n_);
    s_.resize(m, m);
    gain_.resize(n_, m);
    kr_.resize(n_, m);
    if (derivatives_) {
      differentiator_ = std::make_unique<StepDifferentiator>(model, par, numeric_derivatives, use, observe);
      dx_.resize(n_, num_);
      dx_next_.resize(n_, num_);
      d_p_.resize(static_cast<Eigen::Index>(num_) * n_, n_);
      d_p_next_.resize(d_p_.rows(), n_);
      d_f_.resize(d_p_.rows(), n_);
      d_q_.resize(d_p_.rows(), n_);
      tall_.resize(d_p_.rows(), n_);
      w_.resize(n_, n_);
      product_.resize(n_, n_);
      pv_.resize(d_p_.rows());
      s_inverse_.resize(m, m);
      m_.resize(m, m);
      hm_.resize(n_, m);
      hmh_.resize(n_, n_);
      v_.resize(n_);
      row_gradient_.resize(num_);
      r_position_.assign(static_cast<std::size_t>(m), -1);
      rows_used_.assign(static_cast<std::size_t>(n_), true);
      f_marked_.assign(static_cast<std::size_t>(num_), false);
      q_marked_.assign(static_cast<std::size_t>(num_), false);
    }
  }

  // Adds the log's terms to *acc. False at the first failure, described in
  // *failure as "<source>: row <r> (t = ... s): <why>".
  bool run(const Trajectory& t, Accumulator* acc, std::string* failure) {
    Eigen::VectorXd x = config_.initial_state;
    Eigen::MatrixXd p = config_.initial_covariance;
    if (derivatives_) {
      dx_.setZero();
      d_p_.setZero();
    }
    Eigen::VectorXd terms;
    if (acc->keep_rows) terms = Eigen::VectorXd::Constant(t.size(), kNaN);
    bool initialized = false;
    double last_t = 0.0;
    Eigen::VectorXd held_input = Eigen::VectorXd::Zero(t.u.rows());
    std::string why;
    for (int k = 0; k < t.size(); ++k) {
      const double time = t.t[static_cast<std::size_t>(k)];
      // The IMM ignores such rows entirely (rejected_input, rejected_time).
      if (!t.u.col(k).allFinite() || !std::isfinite(time)) continue;
      if (initialized && !(time > last_t)) continue;
      if (initialized && !predict(held_input, time - last_t, &x, &p, &why)) {
        return fail(t, k, why, failure, acc, &terms);
      }
      measurement_.select(t.z.col(k), &selection_);
      if (selection_.size > 0) {
        double term = 0.0;
        if (!update(&x, &p, acc, &term, &why)) return fail(t, k, why, failure, acc, &terms);
        if (acc->keep_rows) terms[k] = term;
        if (acc->row_sink) acc->row_sink(acc->log, k, term);
      }
      held_input = t.u.col(k);
      last_t = time;
      initialized = true;
    }
    if (acc->keep_rows) acc->row_terms.push_back(terms);
    if (differentiator_ && differentiator_->used_numeric) acc->used_numeric = true;
    return true;
  }

 private:
  bool fail(const Trajectory& t, int k, const std::string& why, std::string* failure, Accumulator* acc,
            Eigen::VectorXd* terms) {
    *failure = t.source + ": row " + std::to_string(k + 1) + " (t = " + number(t.t[static_cast<std::size_t>(k)]) +
               " s): " + why;
    if (acc->keep_rows) {
      (*terms)[k] = kInfinity;
      acc->row_terms.push_back(*terms);
    }
    if (acc->row_sink) acc->row_sink(acc->log, k, kInfinity);
    return false;
  }

  void wrap(Eigen::VectorXd* x) const {
    for (int i = 0; i < n_; ++i) {
      if (is_angle_[static_cast<std::size_t>(i)]) (*x)[i] = sdk::wrap_angle((*x)[i]);
    }
  }

  // ExtendedKalmanFilter::predict(), operation for operation.
  bool predict(const Eigen::VectorXd& u, double dt, Eigen::VectorXd* x, Eigen::MatrixXd* p, std::string* why) {
    // F and Qd at the prior state, before x is overwritten.
    if (!model_->jacobian(*x, u, dt, f_)) return set(why, "the model's jacobian() failed");
    if (!model_->process_noise(q_intensity_, *x, u, dt, qd_)) return set(why, "the model's process_noise() failed");
    if (!model_->predict(*x, u, dt, x_next_)) return set(why, "the model's predict() failed");
    if (derivatives_ && !predict_sensitivities(*x, u, dt, *p, why)) return false;
    *x = x_next_;
    wrap(x);
    fp_.noalias() = f_ * *p;
    p->noalias() = fp_ * f_.transpose();
    *p += qd_;
    symmetrize(*p);
    if (!x->allFinite() || !p->allFinite()) return set(why, "the prediction is not finite");
    return true;
  }

  bool predict_sensitivities(const Eigen::VectorXd& x, const Eigen::VectorXd& u, double dt, const Eigen::MatrixXd& p,
                             std::string* why) {
    const int n = n_, nm = par_.num_model(), nq = par_.num_q();
    for (int i = 0; i < n; ++i) rows_used_[static_cast<std::size_t>(i)] = !(dx_.row(i).array() == 0.0).all();
    StepDifferentiator& d = *differentiator_;
    if (!d.compute(x, u, dt, q_intensity_, f_, qd_, x_next_, rows_used_, why)) return false;

    // dx- = F dx + df/dtheta
    dx_next_.noalias() = f_ * dx_;
    dx_next_.leftCols(nm) += d.g;

    // dF_q = F_theta_q + sum_i F_x_i dx_iq, and likewise dQd_q (plus the
    // basis response for Q's own entries). Only marked blocks are non-zero.
    std::fill(f_marked_.begin(), f_marked_.end(), false);
    std::fill(q_marked_.begin(), q_marked_.end(), false);
    for (int q = 0; q < nm; ++q) {
      const std::size_t sq = static_cast<std::size_t>(q);
      if (!d.f_theta.zero[sq]) {
        block(d_f_, q) = d.f_theta.block(q, n);
        f_marked_[sq] = true;
      }
      if (!d.q_theta.zero[sq]) {
        block(d_q_, q) = d.q_theta.block(q, n);
        q_marked_[sq] = true;
      }
    }
    for (int e = 0; e < nq; ++e) {
      if (d.q_q.zero[static_cast<std::size_t>(e)]) continue;
      block(d_q_, nm + e) = d.q_q.block(e, n);
      q_marked_[static_cast<std::size_t>(nm + e)] = true;
    }
    for (int i = 0; i < n; ++i) {
      const bool f_zero = d.f_x.zero[static_cast<std::size_t>(i)], q_zero = d.q_x.zero[static_cast<std::size_t>(i)];
      if (f_zero && q_zero) continue;
      for (int q = 0; q < num_; ++q) {
        const double s = dx_(i, q);
        if (s == 0.0) continue;
        if (!f_zero) add_marked(&d_f_, &f_marked_, q, s, d.f_x.block(i, n));
        if (!q_zero) add_marked(&d_q_, &q_marked_, q, s, d.q_x.block(i, n));
      }
    }

    // dP- = F dP F' + dF P F' + (dF P F')' + dQd. F dP F' for every block at
    // once: tall_ = [dP_q F'] stacked; each block transposed is F dP_q (dP_q
    // is symmetric), and that times F' is F dP_q F'.
    tall_.noalias() = d_p_ * f_.transpose();
    transpose_blocks(&tall_);
    d_p_next_.noalias() = tall_ * f_.transpose();
    w_.noalias() = p * f_.transpose();
    for (int q = 0; q < num_; ++q) {
      auto b = block(d_p_next_, q);
      if (f_marked_[static_cast<std::size_t>(q)]) {
        product_.noalias() = block(d_f_, q) * w_;
        b += product_;
        b += product_.transpose();
      }
      if (q_marked_[static_cast<std::size_t>(q)]) b += block(d_q_, q);
      symmetrize(b);
    }
    dx_.swap(dx_next_);
    d_p_.swap(d_p_next_);
    return true;
  }

  // ExtendedKalmanFilter::update(), operation for operation, on the same
  // kind of workspace, so the values agree with the engine's to round-off.
  bool update(Eigen::VectorXd* x, Eigen::MatrixXd* p, Accumulator* acc, double* term, std::string* why) {
    const int k = selection_.size;
    auto h = selection_.h.topRows(k);
    auto r = selection_.r.topLeftCorner(k, k);
    auto nu = innovation_.head(k);
    nu.noalias() = selection_.z.head(k) - h * *x;
    for (int a = 0; a < k; ++a) {
      if (selection_.is_angle[static_cast<std::size_t>(a)]) nu[a] = sdk::wrap_angle(nu[a]);
    }
    auto hp = hp_.topRows(k);
    hp.noalias() = h * *p;
    auto s = s_.topLeftCorner(k, k);
    s.noalias() = hp * h.transpose();
    s += r;
    symmetrize(s);
    s_diagonal_.head(k) = s.diagonal();
    Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>> llt(s);  // in place: s becomes L
    if (llt.info() != Eigen::Success) return set(why, "the innovation covariance S is not positive definite");
    auto whitened = whitened_.head(k);
    whitened = nu;
    llt.solveInPlace(whitened);  // S^-1 nu
    const double nis = nu.dot(whitened);
    const double log_det = 2.0 * s.diagonal().array().log().sum();
    const double log_likelihood = -0.5 * (nis + log_det + k * kLog2Pi);
    llt.solveInPlace(hp);  // K' = S^-1 H P-
    auto gain = gain_.leftCols(k);
    gain = hp.transpose();

    if (derivatives_) update_sensitivities(h, llt, gain, acc);

    x->noalias() += gain * nu;
    wrap(x);
    i_kh_.setIdentity();
    i_kh_.noalias() -= gain * h;
    fp_.noalias() = i_kh_ * *p;
    p->noalias() = fp_ * i_kh_.transpose();
    auto kr = kr_.leftCols(k);
    kr.noalias() = gain * r;
    p->noalias() += kr * gain.transpose();
    symmetrize(*p);
    if (!std::isfinite(log_likelihood) || !x->allFinite() || !p->allFinite()) {
      return set(why, "the update is not finite");
    }

    *term = -log_likelihood;
    acc->nll += *term;
    acc->measured_rows += 1;
    acc->residuals += k;
    for (int a = 0; a < k; ++a) {
      const int c = selection_.rows[static_cast<std::size_t>(a)];
      acc->sum_squares[c] += nu[a] * nu[a];
      acc->sum_nis[c] += nu[a] * nu[a] / s_diagonal_[a];
      acc->counts[c] += 1.0;
    }
    return true;
  }

  template <typename H, typename Llt, typename Gain>
  void update_sensitivities(const H& h, const Llt& llt, const Gain& gain, Accumulator* acc) {
    const int n = n_, k = selection_.size, nm = par_.num_model(), nq = par_.num_q();
    const auto whitened = whitened_.head(k);
    // S^-1 from its Cholesky factor (k is at most the measurement dimension),
    // for the trace terms; M = S^-1 - w w' with w = S^-1 nu.
    auto s_inverse = s_inverse_.topLeftCorner(k, k);
    s_inverse.setIdentity();
    llt.solveInPlace(s_inverse);
    auto m = m_.topLeftCorner(k, k);
    m = s_inverse;
    m.noalias() -= whitened * whitened.transpose();
    auto hm = hm_.leftCols(k);
    hm.noalias() = h.transpose() * m;
    hmh_.noalias() = hm * h;
    v_.noalias() = h.transpose() * whitened;
    i_kh_.setIdentity();
    i_kh_.noalias() -= gain * h;

    // Where each fitted R entry sits in this row's selection (-1: not measured).
    std::fill(r_position_.begin(), r_position_.end(), -1);
    for (int a = 0; a < k; ++a) r_position_[static_cast<std::size_t>(selection_.rows[static_cast<std::size_t>(a)])] = a;

    // dl = -v' dx- + 1/2 <H' M H, dP-> (+ 1/2 M_aa for R_cc)
    row_gradient_.noalias() = -(dx_.transpose() * v_);
    for (int q = 0; q < num_; ++q) row_gradient_[q] += 0.5 * block(d_p_, q).cwiseProduct(hmh_).sum();
    for (int e = 0; e < par_.num_r(); ++e) {
      const int a = r_position_[static_cast<std::size_t>(par_.r_entries[static_cast<std::size_t>(e)])];
      if (a >= 0) row_gradient_[nm + nq + e] += 0.5 * m(a, a);
    }

    // dx+ = A (dx- + dP- v) - K dR S^-1 nu
    pv_.noalias() = d_p_ * v_;
    dx_ += Eigen::Map<const Eigen::MatrixXd>(pv_.data(), n, num_);
    dx_next_.noalias() = i_kh_ * dx_;
    // dP+ = A dP- A' + K dR K'
    tall_.noalias() = d_p_ * i_kh_.transpose();
    transpose_blocks(&tall_);
    d_p_next_.noalias() = tall_ * i_kh_.transpose();
    for (int e = 0; e < par_.num_r(); ++e) {
      const int a = r_position_[static_cast<std::size_t>(par_.r_entries[static_cast<std::size_t>(e)])];
      if (a < 0) continue;
      const int q = nm + nq + e;
      dx_next_.col(q) -= gain.col(a) * whitened[a];
      block(d_p_next_, q) += gain.col(a) * gain.col(a).transpose();
    }
    for (int q = 0; q < num_; ++q) {
      auto b = block(d_p_next_, q);
      symmetrize(b);
    }
    dx_.swap(dx_next_);
    d_p_.swap(d_p_next_);

    acc->gradient += row_gradient_;
    if (acc->want_information) {
      acc->information.selfadjointView<Eigen::Lower>().rankUpdate(row_gradient_);
    }
  }

  Eigen::Block<Eigen::MatrixXd> block(Eigen::MatrixXd& stacked, int q) const {
    return stacked.middleRows(static_cast<Eigen::Index>(q) * n_, n_);
  }
  // Adds s * value to block q of *stacked, which holds garbage until marked.
  template <typename Value>
  void add_marked(Eigen::MatrixXd* stacked, std::vector<bool>* marked, int q, double s, const Value& value) const {
    auto b = block(*stacked, q);
    if ((*marked)[static_cast<std::size_t>(q)]) {
      b += s * value;
    } else {
      b = s * value;
      (*marked)[static_cast<std::size_t>(q)] = true;
    }
  }
  void transpose_blocks(Eigen::MatrixXd* stacked) const {
    for (int q = 0; q < num_; ++q) block(*stacked, q).transposeInPlace();
  }
  static bool set(std::string* why, const std::string& message) {
    *why = message;
    return false;
  }

  const BankConfig& config_;
  sdk::MotionModel* model_;
  const Parameterization& par_;
  Eigen::MatrixXd q_intensity_;
  MeasurementModel measurement_;
  bool derivatives_;
  int n_ = 0;
  int num_ = 0;
  std::vector<bool> is_angle_;
  SelectedMeasurement selection_;
  std::unique_ptr<StepDifferentiator> differentiator_;
  // Workspace of the filter (as in ExtendedKalmanFilter).
  Eigen::MatrixXd f_, qd_, fp_, i_kh_;
  Eigen::VectorXd x_next_, innovation_, whitened_, s_diagonal_;
  Eigen::MatrixXd hp_, s_, gain_, kr_;
  // Workspace of the sensitivities.
  Eigen::MatrixXd dx_, dx_next_;      // n x num: column q = dx / d parameter_q
  Eigen::MatrixXd d_p_, d_p_next_;    // stacked: block q = dP / d parameter_q
  Eigen::MatrixXd d_f_, d_q_, tall_;  // stacked
  Eigen::MatrixXd w_, product_, s_inverse_, m_, hm_, hmh_;
  Eigen::VectorXd pv_, v_, row_gradient_;
  std::vector<int> r_position_;
  std::vector<bool> rows_used_, f_marked_, q_marked_;
};

// One mode's logs through its filter at the given Q and R.
struct ModeEvaluation {
  Accumulator acc;
  std::string failure;
  bool ok() const { return failure.empty(); }
};

ModeEvaluation evaluate_mode(const BankConfig& config, sdk::MotionModel* model,
                             const std::vector<const Trajectory*>& logs, const Parameterization& par,
                             const Eigen::MatrixXd& q, const Eigen::MatrixXd& r, bool derivatives,
                             bool numeric_derivatives, bool information, bool rows, const StepStructure* use = nullptr,
                             StepStructure* observe = nullptr,
                             std::function<void(std::size_t, int, double)> row_sink = {}) {
  const int m = static_cast<int>(config.measurement.h.rows());
  ModeEvaluation out{Accumulator(m, derivatives ? par.size() : 0, derivatives && information, rows), {}};
  out.acc.row_sink = std::move(row_sink);
  SensitivityFilter filter(config, model, par, q, r, derivatives, numeric_derivatives, use, observe);
  for (std::size_t l = 0; l < logs.size(); ++l) {
    out.acc.log = l;
    if (!filter.run(*logs[l], &out.acc, &out.failure)) {
      out.acc.nll = kInfinity;
      break;
    }
  }
  if (derivatives && information) {
    const Eigen::MatrixXd lower = out.acc.information;  // rankUpdate() filled the lower triangle
    out.acc.information = lower.selfadjointView<Eigen::Lower>();
  }
  return out;
}

LikelihoodEvaluation to_evaluation(const ModeEvaluation& e) {
  LikelihoodEvaluation out;
  out.negative_log_likelihood = e.acc.nll;
  out.measured_rows = e.acc.measured_rows;
  out.residuals = e.acc.residuals;
  const Eigen::Index m = e.acc.counts.size();
  out.rmse.resize(m);
  out.mean_nis.resize(m);
  for (Eigen::Index c = 0; c < m; ++c) {
    const double count = e.acc.counts[c];
    out.rmse[c] = count > 0 ? std::sqrt(e.acc.sum_squares[c] / count) : kNaN;
    out.mean_nis[c] = count > 0 ? e.acc.sum_nis[c] / count : kNaN;
  }
  out.row_terms = e.acc.row_terms;
  out.failure = e.failure;
  return out;
}

std::vector<const Trajectory*> pointers(const ModeLogs& data) {
  std::vector<const Trajectory*> out;
  for (const Trajectory& t : data.logs) out.push_back(&t);
  return out;
}

void check_mode(const Bank& bank, int mode) {
  if (mode < 0 || mode >= bank.config.num_modes()) {
    throw FitError("mode index " + std::to_string(mode) + " is not a mode of the bank (it has " +
                   std::to_string(bank.config.num_modes()) + ")");
  }
}

// ---------------------------------------------------------------------------
// Feasibility transforms: the solver's coordinates phi -> natural values.

// A model parameter: logistic between two bounds, exponential off one,
// identity without.
struct Bounded {
  double lower = -kInfinity, upper = kInfinity;

  double natural(double phi) const {
    const bool low = std::isfinite(lower), high = std::isfinite(upper);
    if (low && high) return lower + (upper - lower) / (1.0 + std::exp(-phi));
    if (low) return lower + std::exp(phi);
    if (high) return upper - std::exp(phi);
    return phi;
  }
  double derivative(double phi) const {  // d natural / d phi
    const bool low = std::isfinite(lower), high = std::isfinite(upper);
    if (low && high) {
      const double sigma = 1.0 / (1.0 + std::exp(-phi));
      return (upper - lower) * sigma * (1.0 - sigma);
    }
    if (low) return std::exp(phi);
    if (high) return -std::exp(phi);
    return 1.0;
  }
  double coordinate(double value) const {
    const bool low = std::isfinite(lower), high = std::isfinite(upper);
    if (low && high) return std::log((value - lower) / (upper - value));
    if (low) return std::log(value - lower);
    if (high) return std::log(upper - value);
    return value;
  }
  // A start on or outside a bound is moved just inside it: the transforms
  // reach the bounds only at infinity.
  double inside(double value) const {
    const bool low = std::isfinite(lower), high = std::isfinite(upper);
    if (low && high) {
      const double margin = 1e-6 * (upper - lower);
      return std::clamp(value, lower + margin, upper - margin);
    }
    if (low) return std::max(value, lower + 1e-6 * std::max(1.0, std::abs(lower)));
    if (high) return std::min(value, upper - 1e-6 * std::max(1.0, std::abs(upper)));
    return value;
  }
  // Within 1e-5 of the range (two bounds) or 1e-6 of the bound's scale (one).
  bool near_bound(double value) const {
    const bool low = std::isfinite(lower), high = std::isfinite(upper);
    if (low && high) return value - lower <= 1e-5 * (upper - lower) || upper - value <= 1e-5 * (upper - lower);
    if (low) return value - lower <= 1e-6 * std::max(1.0, std::abs(lower));
    if (high) return upper - value <= 1e-6 * std::max(1.0, std::abs(upper));
    return false;
  }
};

// One mode of the problem.
struct ModeBlock {
  int mode = 0;
  sdk::MotionModel* model = nullptr;
  std::vector<const Trajectory*> logs;
  Parameterization par;
  std::vector<Bounded> bounds;       // per free model parameter
  Eigen::VectorXd start_parameters;  // the model's full vector at the start
  Eigen::MatrixXd fixed_q;           // kKeep: the bank's Q
  ProcessNoise q_form = ProcessNoise::kDiagonal;
  int offset = 0;  // of its coordinates in the solver's vector
  int num_q_coordinates = 0;
  std::vector<int> local_to_global;   // its natural parameters' coordinates: [model, q, r]
  std::vector<std::string> warnings;  // about its start
};

// The solver's vector: per mode [model parameters, Q coordinates], then R.
// Natural values of a mode and d natural / d coordinates.
struct NaturalValues {
  Eigen::VectorXd parameters;  // the model's full vector
  Eigen::MatrixXd q;
  Eigen::MatrixXd jacobian;  // natural (par order) x local coordinates [model, q, r]
};

int q_coordinates(ProcessNoise form, int n) {
  switch (form) {
    case ProcessNoise::kKeep:
      return 0;
    case ProcessNoise::kDiagonal:
      return n;
    case ProcessNoise::kFull:
      return n * (n + 1) / 2;
  }
  return 0;
}

// Q from its coordinates: diagonal q_i = exp(phi_i); full Q = L L' with L
// lower triangular (row by row, i >= j), L_ii = exp(phi).
Eigen::MatrixXd q_from(ProcessNoise form, int n, const double* phi, Eigen::MatrixXd* cholesky) {
  Eigen::MatrixXd q = Eigen::MatrixXd::Zero(n, n);
  if (form == ProcessNoise::kDiagonal) {
    for (int i = 0; i < n; ++i) q(i, i) = std::exp(phi[i]);
  } else if (form == ProcessNoise::kFull) {
    Eigen::MatrixXd l = Eigen::MatrixXd::Zero(n, n);
    int at = 0;
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j <= i; ++j, ++at) l(i, j) = i == j ? std::exp(phi[at]) : phi[at];
    }
    q.noalias() = l * l.transpose();
    symmetrize(q);
    if (cholesky != nullptr) *cholesky = l;
  }
  return q;
}

class Problem {
 public:
  Problem(const BankConfig& config, std::vector<ModeBlock> blocks, bool fit_r, int r_offset, bool numeric)
      : config_(config), blocks_(std::move(blocks)), fit_r_(fit_r), r_offset_(r_offset), numeric_(numeric) {
    size_ = r_offset_ + (fit_r_ ? static_cast<int>(config.measurement.h.rows()) : 0);
  }

  int size() const { return size_; }
  const std::vector<ModeBlock>& blocks() const { return blocks_; }

  NaturalValues natural(const ModeBlock& b, const double* phi) const {
    NaturalValues v;
    const int nm = b.par.num_model(), nq = b.par.num_q(), nr = b.par.num_r();
    const int n = config_.state_dim();
    v.parameters = b.start_parameters;
    v.jacobian = Eigen::MatrixXd::Zero(b.par.size(), nm + b.num_q_coordinates + nr);
    for (int p = 0; p < nm; ++p) {
      const double c = phi[b.offset + p];
      v.parameters[b.par.model_index[static_cast<std::size_t>(p)]] = b.bounds[static_cast<std::size_t>(p)].natural(c);
      v.jacobian(p, p) = b.bounds[static_cast<std::size_t>(p)].derivative(c);
    }
    const double* q_phi = phi + b.offset + nm;
    if (b.q_form == ProcessNoise::kKeep) {
      v.q = b.fixed_q;
    } else if (b.q_form == ProcessNoise::kDiagonal) {
      v.q = q_from(b.q_form, n, q_phi, nullptr);
      for (int i = 0; i < n; ++i) v.jacobian(nm + i, nm + i) = v.q(i, i);
    } else {
      Eigen::MatrixXd l;
      v.q = q_from(b.q_form, n, q_phi, &l);
      // d Q / d L_ac = E_ac L' + L E_ca; times L_aa on the (log) diagonal.
      int coordinate = 0;
      for (int a = 0; a < n; ++a) {
        for (int c = 0; c <= a; ++c, ++coordinate) {
          Eigen::MatrixXd d = Eigen::MatrixXd::Zero(n, n);
          d.row(a) += l.col(c).transpose();  // E_ac L': row a gets row c of L', i.e. column c of L
          d.col(a) += l.col(c);              // L E_ca: column a gets column c of L
          if (a == c) d *= l(a, a);
          for (int e = 0; e < nq; ++e) {
            const auto& [i, j] = b.par.q_entries[static_cast<std::size_t>(e)];
            v.jacobian(nm + e, nm + coordinate) = d(i, j);
          }
        }
      }
    }
    for (int e = 0; e < nr; ++e) {
      v.jacobian(nm + nq + e, nm + b.num_q_coordinates + e) = std::exp(phi[r_offset_ + e]);
    }
    return v;
  }

  Eigen::MatrixXd r(const double* phi) const {
    if (!fit_r_) return config_.measurement.r;
    const Eigen::Index m = config_.measurement.h.rows();
    Eigen::MatrixXd out = Eigen::MatrixXd::Zero(m, m);
    for (Eigen::Index c = 0; c < m; ++c) out(c, c) = std::exp(phi[r_offset_ + c]);
    return out;
  }

  // Sets every mode's model to phi and evaluates. With `derivatives`, also
  // d cost / d phi; with `information`, each mode's BHHH information in
  // natural units (modes[j].acc) and the whole in phi (information_phi).
  // `use` / `observe`: one StepStructure per block, or nullptr (see
  // StepDifferentiator).
  struct Result {
    double cost = 0.0;
    Eigen::VectorXd gradient;
    Eigen::MatrixXd information_phi;
    std::vector<ModeEvaluation> modes;
    std::vector<NaturalValues> natural;
    std::string failure;
    bool used_numeric = false;
  };

  bool evaluate(const double* phi, bool derivatives, bool information, Result* out,
                const std::vector<StepStructure>* use = nullptr, std::vector<StepStructure>* observe = nullptr) const {
    out->cost = 0.0;
    if (derivatives) out->gradient = Eigen::VectorXd::Zero(size_);
    if (information) out->information_phi = Eigen::MatrixXd::Zero(size_, size_);
    out->modes.clear();
    out->natural.clear();
    const Eigen::MatrixXd r_matrix = r(phi);
    for (std::size_t j = 0; j < blocks_.size(); ++j) {
      const ModeBlock& b = blocks_[j];
      NaturalValues v = natural(b, phi);
      std::string error;
      if (!v.parameters.allFinite() || !v.q.allFinite() || !b.model->set_parameters(v.parameters, &error)) {
        out->failure = "mode '" + config_.modes[static_cast<std::size_t>(b.mode)].name +
                       "': the model rejected the parameters" + (error.empty() ? "" : ": " + error);
        return false;
      }
      ModeEvaluation e =
          evaluate_mode(config_, b.model, b.logs, b.par, v.q, r_matrix, derivatives, numeric_, information, false,
                        use != nullptr ? &(*use)[j] : nullptr, observe != nullptr ? &(*observe)[j] : nullptr);
      if (!e.ok() || !std::isfinite(e.acc.nll)) {
        out->failure = "mode '" + config_.modes[static_cast<std::size_t>(b.mode)].name +
                       "': " + (e.failure.empty() ? std::string("the likelihood is not finite") : e.failure);
        return false;
      }
      out->cost += e.acc.nll;
      out->used_numeric = out->used_numeric || e.acc.used_numeric;
      if (derivatives) {
        const Eigen::VectorXd local = v.jacobian.transpose() * e.acc.gradient;
        for (Eigen::Index i = 0; i < local.size(); ++i)
          out->gradient[b.local_to_global[static_cast<std::size_t>(i)]] += local[i];
        if (information) {
          const Eigen::MatrixXd local_information = v.jacobian.transpose() * e.acc.information * v.jacobian;
          for (Eigen::Index i = 0; i < local.size(); ++i) {
            for (Eigen::Index j = 0; j < local.size(); ++j) {
              out->information_phi(b.local_to_global[static_cast<std::size_t>(i)],
                                   b.local_to_global[static_cast<std::size_t>(j)]) += local_information(i, j);
            }
          }
        }
      }
      out->modes.push_back(std::move(e));
      out->natural.push_back(std::move(v));
    }
    if (!std::isfinite(out->cost) || (derivatives && !out->gradient.allFinite())) {
      out->failure = "the likelihood or its gradient is not finite";
      return false;
    }
    return true;
  }

  // The row whose term of the negative log-likelihood at phi is over
  // kAbsurdRowTerm above the median row's, as "<source>: row <r> (t = ... s)
  // has a term of X against a median row's Y", or "" if none is. Half a
  // normalized innovation squared of 1e12 is an innovation of a million
  // standard deviations: no sensor's noise, a corrupt cell (or starting
  // values nowhere near the logs). The fit would be that one row's.
  std::string absurd_row(const double* phi) const {
    constexpr double kAbsurdRowTerm = 0.5e12;
    const Eigen::MatrixXd r_matrix = r(phi);
    std::string worst;
    double worst_excess = kAbsurdRowTerm;
    for (const ModeBlock& b : blocks_) {
      const NaturalValues v = natural(b, phi);
      if (!b.model->set_parameters(v.parameters, nullptr)) continue;  // evaluate() reports this
      // The rows' terms stream by: the median of the finite ones, and the
      // first largest (an infinite one, where the filter failed, included).
      internal::BoundedMedian finite;
      double largest = -kInfinity;
      std::size_t largest_log = 0;
      int largest_row = 0;
      evaluate_mode(config_, b.model, b.logs, b.par, v.q, r_matrix, false, numeric_, false, /*rows=*/false, nullptr,
                    nullptr, [&](std::size_t log, int row, double term) {
                      if (std::isfinite(term)) finite.add(term);
                      if (term > largest) {
                        largest = term;
                        largest_log = log;
                        largest_row = row;
                      }
                    });
      if (finite.empty()) continue;
      const double median = finite.median();
      if (largest - median > worst_excess) {
        worst_excess = largest - median;
        const Trajectory& t = *b.logs[largest_log];
        worst = t.source + ": row " + std::to_string(largest_row + 1) + " (t = " +
                number(t.t[static_cast<std::size_t>(largest_row)]) + " s) has a term of " + number(largest) +
                " against a median row's " + number(median);
      }
    }
    return worst;
  }

 private:
  const BankConfig& config_;
  std::vector<ModeBlock> blocks_;
  bool fit_r_;
  int r_offset_;
  bool numeric_;
  int size_ = 0;
};

// Ceres' view: phi = phi_0 + T psi, with T from the information at phi_0
// (whitening()), so that LBFGS starts on a problem whose Hessian is near the
// identity.
class ScaledObjective : public ceres::FirstOrderFunction {
 public:
  // `structure`: what the model's steps were seen to depend on (nullptr:
  // compute every derivative).
  ScaledObjective(const Problem* problem, Eigen::VectorXd start, Eigen::MatrixXd transform,
                  const std::vector<StepStructure>* structure)
      : problem_(problem), start_(std::move(start)), transform_(std::move(transform)), structure_(structure) {}

  bool Evaluate(const double* psi, double* cost, double* gradient) const override {
    const Eigen::VectorXd phi = phi_of(psi);
    Problem::Result result;
    // A failure (the model rejects the values, S not positive definite, a
    // non-finite value) is a failed evaluation for the line search, never NaN.
    if (!problem_->evaluate(phi.data(), gradient != nullptr, false, &result, structure_)) return false;
    *cost = result.cost;
    if (gradient != nullptr) {
      Eigen::Map<Eigen::VectorXd>(gradient, NumParameters()).noalias() = transform_.transpose() * result.gradient;
    }
    return true;
  }
  int NumParameters() const override { return static_cast<int>(start_.size()); }

  Eigen::VectorXd phi_of(const double* psi) const {
    return start_ + transform_ * Eigen::Map<const Eigen::VectorXd>(psi, NumParameters());
  }

 private:
  const Problem* problem_;
  Eigen::VectorXd start_;
  Eigen::MatrixXd transform_;
  const std::vector<StepStructure>* structure_;
};

// T with T' I T = identity on the directions the information I determines:
// T = D V L^-1/2 from the eigen decomposition V L V' of D I D, D scaling I to
// unit diagonal. Eigenvalues are floored at 1e-8 of the largest, so a
// direction the start does not determine is not stretched without bound.
// With BHHH's I close to the Hessian near the optimum, LBFGS then sees a
// nearly isotropic problem.
Eigen::MatrixXd whitening(const Eigen::MatrixXd& information) {
  const Eigen::Index size = information.rows();
  Eigen::VectorXd d = Eigen::VectorXd::Ones(size);
  for (Eigen::Index i = 0; i < size; ++i) {
    const double v = information(i, i);
    if (v > 0.0 && std::isfinite(v)) d[i] = 1.0 / std::sqrt(v);
  }
  Eigen::MatrixXd scaled = d.asDiagonal() * information * d.asDiagonal();
  for (Eigen::Index i = 0; i < size; ++i) {
    if (!(information(i, i) > 0.0 && std::isfinite(information(i, i)))) {
      scaled.row(i).setZero();
      scaled.col(i).setZero();
      scaled(i, i) = 1.0;
    }
  }
  if (!scaled.allFinite()) return d.asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(scaled);
  const Eigen::VectorXd values = eigen.eigenvalues().cwiseMax(1e-8 * eigen.eigenvalues().maxCoeff());
  return d.asDiagonal() * eigen.eigenvectors() * values.cwiseSqrt().cwiseInverse().asDiagonal();
}

// "[B[0,0], B[0,1]], [B[1,0], B[1,1]]": the parameters of each direction the
// information does not determine (eigenvectors with eigenvalues below
// `threshold`). Several such directions span a space whose eigenvectors are
// any rotation of each other, so they are first brought to reduced row
// echelon form: each direction then starts at its own parameter and they
// share as few as possible, which is what a reader can act on.
std::string describe_unidentified(const Eigen::MatrixXd& vectors, const Eigen::VectorXd& values, double threshold,
                                  const std::vector<std::string>& names) {
  std::vector<Eigen::Index> null;
  for (Eigen::Index k = 0; k < values.size(); ++k) {
    if (values[k] < threshold) null.push_back(k);
  }
  Eigen::MatrixXd rows(static_cast<Eigen::Index>(null.size()), vectors.rows());
  for (std::size_t r = 0; r < null.size(); ++r)
    rows.row(static_cast<Eigen::Index>(r)) = vectors.col(null[r]).transpose();
  Eigen::Index pivot_row = 0;
  for (Eigen::Index c = 0; c < rows.cols() && pivot_row < rows.rows(); ++c) {
    Eigen::Index best = pivot_row;
    rows.col(c).segment(pivot_row, rows.rows() - pivot_row).cwiseAbs().maxCoeff(&best);
    best += pivot_row;
    if (std::abs(rows(best, c)) < 1e-6) continue;
    rows.row(pivot_row).swap(rows.row(best));
    rows.row(pivot_row) /= rows(pivot_row, c);
    for (Eigen::Index r = 0; r < rows.rows(); ++r) {
      if (r != pivot_row) rows.row(r) -= rows(r, c) * rows.row(pivot_row);
    }
    ++pivot_row;
  }
  std::string out;
  for (Eigen::Index r = 0; r < rows.rows(); ++r) {
    const double largest = rows.row(r).cwiseAbs().maxCoeff();
    std::vector<std::pair<double, std::size_t>> parts;  // (weight rounded, parameter)
    for (Eigen::Index i = 0; i < rows.cols(); ++i) {
      const double weight = std::abs(rows(r, i)) / largest;
      if (weight > 0.2) parts.emplace_back(std::round(weight * 1e6), static_cast<std::size_t>(i));
    }
    // Largest first; equal weights in the model's order.
    std::stable_sort(parts.begin(), parts.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
    std::string direction;
    for (const auto& p : parts) direction += (direction.empty() ? "" : ", ") + names[p.second];
    out += (out.empty() ? "[" : ", [") + direction + "]";
  }
  return out;
}

// The start of Q: the bank's, with a positive diagonal. A zero entry (a state
// the bank gave no process noise) starts at a tenth of the measurement
// variance per step when a row of H measures the state alone, otherwise at
// 1e-2 of the largest positive entry (1e-6 if there is none). LBFGS moves in
// log Q, so the start's scale costs a few iterations, never the fit.
Eigen::MatrixXd q_start(const BankConfig& config, const Eigen::MatrixXd& bank_q, double typical_dt, ProcessNoise form) {
  const int n = config.state_dim();
  Eigen::MatrixXd q = 0.5 * (bank_q + bank_q.transpose());
  const double largest = q.diagonal().maxCoeff();
  for (int i = 0; i < n; ++i) {
    if (q(i, i) > 0.0 && std::isfinite(q(i, i))) continue;
    double start = largest > 0.0 ? 1e-2 * largest : 1e-6;
    const Eigen::MatrixXd& h = config.measurement.h;
    for (Eigen::Index c = 0; c < h.rows(); ++c) {
      if (h(c, i) != 0.0 && h.row(c).cwiseAbs().sum() == std::abs(h(c, i))) {
        start = 0.1 * config.measurement.r(c, c) / (h(c, i) * h(c, i)) / typical_dt;
        break;
      }
    }
    q(i, i) = start;
    q.row(i).setZero();
    q.col(i).setZero();
    q(i, i) = start;
  }
  if (form == ProcessNoise::kDiagonal) return Eigen::MatrixXd(q.diagonal().asDiagonal());
  if (Eigen::LLT<Eigen::MatrixXd>(q).info() != Eigen::Success) return Eigen::MatrixXd(q.diagonal().asDiagonal());
  return q;
}

double median_step(const std::vector<const Trajectory*>& logs) {
  std::vector<double> steps;
  for (const Trajectory* t : logs) {
    for (int k = 1; k < t->size(); ++k) {
      const double dt = t->t[static_cast<std::size_t>(k)] - t->t[static_cast<std::size_t>(k) - 1];
      if (dt > 0.0 && std::isfinite(dt)) steps.push_back(dt);
    }
  }
  if (steps.empty()) return 1.0;
  std::nth_element(steps.begin(), steps.begin() + static_cast<std::ptrdiff_t>(steps.size() / 2), steps.end());
  return steps[steps.size() / 2];
}

std::string mode_name(const BankConfig& config, int mode) {
  return "mode '" + config.modes[static_cast<std::size_t>(mode)].name + "'";
}

// Fits one group of modes: one mode alone, or every mode jointly with R.
// The likelihood's filter pass and its derivatives are written for z = H x
// + v: a bank measuring model outputs is fitted with the window objective.
void refuse_outputs(const Bank& bank) {
  if (!bank.config.measurement.outputs.empty()) {
    throw FitError("the likelihood objective does not fit banks that measure model outputs (measurement.outputs: " +
                   bank.config.measurement.outputs.front() +
                   (bank.config.measurement.outputs.size() > 1 ? ", ...)" : ")") +
                   "; use the window objective (--objective window)");
  }
}

std::map<int, FitReport> fit_group(Bank* bank, const std::vector<std::pair<int, std::vector<const Trajectory*>>>& group,
                                   const LikelihoodFitOptions& options) {
  const BankConfig& config = bank->config;
  const int n = config.state_dim();
  const int m = static_cast<int>(config.measurement.h.rows());
  const std::string who = group.size() == 1 && !options.fit_measurement_noise
                              ? mode_name(config, group.front().first)
                              : "the bank's joint fit (" + std::to_string(group.size()) + " modes and R)";
  // The logs a whole-fit error is about, for its message.
  std::string logs_text;
  int listed = 0;
  for (const auto& entry : group) {
    for (const Trajectory* t : entry.second) {
      if (++listed <= 3) logs_text += (logs_text.empty() ? "" : ", ") + t->source;
    }
  }
  if (listed > 3) logs_text += " and " + std::to_string(listed - 3) + " more";
  logs_text = " (logs: " + logs_text + ")";

  // Blocks and the start.
  std::vector<ModeBlock> blocks;
  std::vector<double> start;
  std::vector<std::string> warnings_all;
  for (const auto& [mode, logs] : group) {
    ModeBlock b;
    b.mode = mode;
    b.model = bank->models[static_cast<std::size_t>(mode)].get();
    b.logs = logs;
    b.par = parameterization_of(*b.model, n, m, options);
    b.q_form = options.process_noise;
    b.num_q_coordinates = q_coordinates(options.process_noise, n);
    b.start_parameters.resize(static_cast<Eigen::Index>(b.model->parameter_info().size()));
    b.model->get_parameters(b.start_parameters);
    b.fixed_q = config.modes[static_cast<std::size_t>(mode)].q_intensity;
    const std::string name = mode_name(config, mode);
    if (b.par.size() == 0) {
      throw FitError(name + ": nothing to fit: no model parameters, Q kept and R not fitted");
    }
    b.offset = static_cast<int>(start.size());
    for (int p = 0; p < b.par.num_model(); ++p) {
      const sdk::ParameterInfo& info =
          b.model->parameter_info()[static_cast<std::size_t>(b.par.model_index[static_cast<std::size_t>(p)])];
      Bounded bound{info.lower_bound, info.upper_bound};
      b.bounds.push_back(bound);
      const double value = bound.inside(b.start_parameters[b.par.model_index[static_cast<std::size_t>(p)]]);
      start.push_back(bound.coordinate(value));
    }
    if (options.process_noise != ProcessNoise::kKeep) {
      const Eigen::MatrixXd q0 = q_start(config, b.fixed_q, median_step(logs), options.process_noise);
      if (options.process_noise == ProcessNoise::kDiagonal) {
        for (int i = 0; i < n; ++i) start.push_back(std::log(q0(i, i)));
      } else {
        const Eigen::MatrixXd l = Eigen::LLT<Eigen::MatrixXd>(q0).matrixL();
        for (int i = 0; i < n; ++i) {
          for (int j = 0; j <= i; ++j) start.push_back(i == j ? std::log(l(i, i)) : l(i, j));
        }
      }
      const Eigen::MatrixXd& bank_q = b.fixed_q;
      if (options.process_noise == ProcessNoise::kDiagonal &&
          (bank_q - Eigen::MatrixXd(bank_q.diagonal().asDiagonal())).cwiseAbs().maxCoeff() > 0.0) {
        b.warnings.push_back("the bank's Q has off-diagonal entries; a diagonal Q was fitted");
      }
    }
    blocks.push_back(std::move(b));
  }
  const int r_offset = static_cast<int>(start.size());
  if (options.fit_measurement_noise) {
    for (int c = 0; c < m; ++c) {
      const double r = config.measurement.r(c, c);
      start.push_back(std::log(r > 0.0 && std::isfinite(r) ? r : 1e-6));  // a bank R is positive definite
    }
    if ((config.measurement.r - Eigen::MatrixXd(config.measurement.r.diagonal().asDiagonal())).cwiseAbs().maxCoeff() >
        0.0) {
      warnings_all.push_back("the bank's R has off-diagonal entries; a diagonal R was fitted");
    }
  }
  for (ModeBlock& b : blocks) {
    for (int p = 0; p < b.par.num_model() + b.num_q_coordinates; ++p) b.local_to_global.push_back(b.offset + p);
    for (int e = 0; e < b.par.num_r(); ++e) b.local_to_global.push_back(r_offset + e);
  }

  // Restores the models if anything below throws.
  struct Restore {
    std::vector<std::pair<sdk::MotionModel*, Eigen::VectorXd>> saved;
    bool armed = true;
    ~Restore() {
      if (!armed) return;
      for (auto& [model, values] : saved) model->set_parameters(values, nullptr);
    }
  } restore;
  for (const ModeBlock& b : blocks) restore.saved.emplace_back(b.model, b.start_parameters);

  Problem problem(config, std::move(blocks), options.fit_measurement_noise, r_offset, options.numeric_derivatives);
  Eigen::VectorXd phi0 = Eigen::Map<const Eigen::VectorXd>(start.data(), static_cast<Eigen::Index>(start.size()));

  // The start: finite, linear in Q, and the information that scales the
  // solver's coordinates.
  for (const ModeBlock& b : problem.blocks()) {
    int measured = 0;
    for (const Trajectory* t : b.logs) {
      for (int k = 0; k < t->size(); ++k) measured += t->z.col(k).array().isFinite().any() ? 1 : 0;
    }
    if (measured == 0) {
      std::string sources;
      for (const Trajectory* t : b.logs) sources += (sources.empty() ? "" : ", ") + t->source;
      throw FitError(mode_name(config, b.mode) + ": no measured row in its logs (" + sources +
                     "): every measurement is missing");
    }
    if (options.process_noise != ProcessNoise::kKeep) {
      const NaturalValues v = problem.natural(b, phi0.data());
      if (!b.model->set_parameters(v.parameters, nullptr)) {
        throw FitError(mode_name(config, b.mode) + ": the model rejected its starting parameters");
      }
      for (const Trajectory* t : b.logs) {
        if (t->size() < 2) continue;
        std::string why;
        if (!check_linear_in_intensity(*b.model, v.q, config.initial_state, t->u.col(0), t->t[1] - t->t[0], &why)) {
          throw FitError(mode_name(config, b.mode) + ": " + why);
        }
        break;
      }
    }
  }
  // The start: finite, what the model's steps depend on (observed at every
  // row), and the information that whitens the solver's coordinates.
  auto fresh_structures = [&] {
    std::vector<StepStructure> out(problem.blocks().size());
    for (std::size_t j = 0; j < out.size(); ++j) out[j].reset(n, problem.blocks()[j].par.num_model());
    return out;
  };
  std::vector<StepStructure> structure = fresh_structures();
  Problem::Result first;
  if (!problem.evaluate(phi0.data(), true, true, &first, nullptr, &structure)) {
    throw FitError(first.failure + "; the negative log-likelihood is not finite at the starting values of " + who +
                   "; check the log's inputs and measurements there");
  }
  // Finite but absurd: a cell of 1e100 keeps every number finite, and the
  // fit would then be that row's (or fail with a misleading message).
  if (const std::string row = problem.absurd_row(phi0.data()); !row.empty()) {
    throw FitError(row + " in the negative log-likelihood at the starting values of " + who +
                   ": an absurd input or measurement there (a corrupt cell?); fix or remove that row");
  }

  // Solve, skipping the derivatives the model was seen not to have. LBFGS
  // runs on coordinates whitened by the information at its start point; a
  // first short run brings the start closer to the optimum, where the
  // information is a better Hessian, and the rest runs whitened there.
  // Every run ends with everything computed again at its solution; should
  // the model show a dependence it did not show before (a derivative that
  // vanished only at the start), the solve continues with it, and after two
  // such rounds with every derivative computed at every step.
  constexpr int kFirstRunIterations = 10;
  ceres::GradientProblemSolver::Options solver_options;
  solver_options.line_search_direction_type = ceres::LBFGS;
  // In the whitened coordinates a unit is about one standard deviation: stop
  // when the gradient says the optimum is within 1e-6 of one.
  solver_options.gradient_tolerance = 1e-6;
  solver_options.function_tolerance = 1e-13;
  solver_options.parameter_tolerance = 1e-12;
  solver_options.logging_type = ceres::SILENT;
  ceres::GradientProblemSolver::Summary summary;
  Eigen::VectorXd phi = phi0;
  const double initial_cost = first.cost;
  Problem::Result final_result = std::move(first);
  int iterations = 0;
  int structure_rounds = 0;
  for (int run = 0;; ++run) {
    const int budget = options.max_iterations - iterations;
    if (budget <= 0) break;
    const bool full = structure_rounds >= 2;
    solver_options.max_num_iterations = run == 0 ? std::min(kFirstRunIterations, budget) : budget;
    SolverProgress solver_progress(options.progress, who + " (likelihood objective)", iterations);
    solver_options.callbacks.clear();
    if (options.progress) solver_options.callbacks.push_back(&solver_progress);
    auto* objective =
        new ScaledObjective(&problem, phi, whitening(final_result.information_phi), full ? nullptr : &structure);
    ceres::GradientProblem gradient_problem(objective);  // takes ownership
    std::vector<double> psi(static_cast<std::size_t>(problem.size()), 0.0);
    ceres::Solve(solver_options, gradient_problem, psi.data(), &summary);
    iterations += std::max(0, static_cast<int>(summary.iterations.size()) - 1);
    phi = objective->phi_of(psi.data());
    std::vector<StepStructure> seen = fresh_structures();
    if (!problem.evaluate(phi.data(), true, true, &final_result, nullptr, &seen)) {
      // Ceres returns the last accepted point, which evaluated; this only
      // happens if the model is not deterministic.
      throw FitError(who + logs_text + ": the solution could not be evaluated again: " + final_result.failure);
    }
    bool covered = true;
    for (std::size_t j = 0; j < seen.size(); ++j) covered = covered && structure[j].covers(seen[j]);
    if (!covered && !full) {
      for (std::size_t j = 0; j < seen.size(); ++j) structure[j].merge(seen[j]);
      ++structure_rounds;
      continue;
    }
    if (run == 0 && summary.termination_type == ceres::NO_CONVERGENCE) continue;  // the first, short run
    break;
  }

  std::vector<std::string> warnings = warnings_all;
  if (summary.termination_type == ceres::NO_CONVERGENCE) {
    warnings.push_back("LBFGS stopped after " + std::to_string(options.max_iterations) +
                       " iterations without converging; the values are the best found");
  } else if (summary.termination_type == ceres::FAILURE) {
    warnings.push_back("LBFGS stopped early (" + summary.message + "); the values are the best found");
  }

  // The information in natural units over the group: per mode [model, Q]
  // then R, the R entries shared by every mode.
  std::vector<std::string> names;
  std::vector<std::vector<int>> natural_index;  // per mode: its par entries -> joint natural index
  int joint = 0;
  for (const ModeBlock& b : problem.blocks()) {
    std::vector<int> index;
    const std::vector<std::string> mode_names = names_of(b.par, *b.model);
    for (int p = 0; p < b.par.num_model() + b.par.num_q(); ++p) {
      index.push_back(joint++);
      names.push_back((problem.blocks().size() > 1 ? config.modes[static_cast<std::size_t>(b.mode)].name + "." : "") +
                      mode_names[static_cast<std::size_t>(p)]);
    }
    natural_index.push_back(index);
  }
  const int r_natural = joint;
  if (options.fit_measurement_noise) {
    for (int c = 0; c < m; ++c) names.push_back(r_name(c));
    joint += m;
  }
  for (std::size_t j = 0; j < problem.blocks().size(); ++j) {
    const ModeBlock& b = problem.blocks()[j];
    for (int e = 0; e < b.par.num_r(); ++e) natural_index[j].push_back(r_natural + e);
  }
  Eigen::MatrixXd information = Eigen::MatrixXd::Zero(joint, joint);
  Eigen::VectorXd values(joint);
  for (std::size_t j = 0; j < problem.blocks().size(); ++j) {
    const ModeBlock& b = problem.blocks()[j];
    const Eigen::MatrixXd& mode_information = final_result.modes[j].acc.information;
    const NaturalValues& v = final_result.natural[j];
    const std::vector<int>& index = natural_index[j];
    for (std::size_t a = 0; a < index.size(); ++a) {
      for (std::size_t c = 0; c < index.size(); ++c) {
        information(index[a], index[c]) += mode_information(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(c));
      }
    }
    for (int p = 0; p < b.par.num_model(); ++p) {
      values[index[static_cast<std::size_t>(p)]] = v.parameters[b.par.model_index[static_cast<std::size_t>(p)]];
    }
    for (int e = 0; e < b.par.num_q(); ++e) {
      const auto& [qi, qj] = b.par.q_entries[static_cast<std::size_t>(e)];
      values[index[static_cast<std::size_t>(b.par.num_model() + e)]] = v.q(qi, qj);
    }
  }
  const Eigen::MatrixXd fitted_r = problem.r(phi.data());
  for (int c = 0; c < (options.fit_measurement_noise ? m : 0); ++c) values[r_natural + c] = fitted_r(c, c);

  // Identifiability: eigenvalues of the information scaled to unit diagonal
  // (a correlation matrix), so the units of the parameters do not matter.
  Eigen::VectorXd unit = Eigen::VectorXd::Zero(joint);
  std::string unexcited;
  for (int i = 0; i < joint; ++i) {
    const double d = information(i, i);
    if (d > 0.0 && std::isfinite(d)) {
      unit[i] = 1.0 / std::sqrt(d);
    } else {
      unexcited += (unexcited.empty() ? "[" : ", [") + names[static_cast<std::size_t>(i)] + "]";
    }
  }
  const Eigen::MatrixXd scaled = unit.asDiagonal() * information * unit.asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(scaled);
  const Eigen::VectorXd eigenvalues = eigen.eigenvalues();
  const double largest = eigenvalues.maxCoeff();
  const double threshold = options.identifiability_threshold * largest;
  if (unexcited.empty()) unexcited = describe_unidentified(eigen.eigenvectors(), eigenvalues, threshold, names);
  if (!unexcited.empty() || !(largest > 0.0)) {
    throw FitError(who + logs_text + ": the logs do not identify every parameter: no information on the combinations " + unexcited +
                   "; drive maneuvers that move them (turns and speed changes), or fix them");
  }
  const double smallest = eigenvalues.minCoeff();
  // Covariance = information^-1 = D (V L^-1 V') D, from the eigen decomposition above.
  const Eigen::MatrixXd covariance =
      unit.asDiagonal() *
      (eigen.eigenvectors() * eigenvalues.cwiseInverse().asDiagonal() * eigen.eigenvectors().transpose()) *
      unit.asDiagonal();
  Eigen::VectorXd deviation = covariance.diagonal().cwiseMax(0.0).cwiseSqrt();

  // Leave the models at the solution; write R.
  for (std::size_t j = 0; j < problem.blocks().size(); ++j) {
    const ModeBlock& b = problem.blocks()[j];
    std::string error;
    if (!b.model->set_parameters(final_result.natural[j].parameters, &error)) {
      throw FitError(mode_name(config, b.mode) + ": the model rejected the fitted parameters: " + error);
    }
  }
  restore.armed = false;
  if (options.fit_measurement_noise) bank->config.measurement.r = fitted_r;

  std::map<int, FitReport> reports;
  for (std::size_t j = 0; j < problem.blocks().size(); ++j) {
    const ModeBlock& b = problem.blocks()[j];
    const std::vector<int>& index = natural_index[j];
    const LikelihoodEvaluation e = to_evaluation(final_result.modes[j]);
    const std::vector<std::string> mode_names = names_of(b.par, *b.model);
    FitReport report;
    report.warnings = b.warnings;
    report.warnings.insert(report.warnings.end(), warnings.begin(), warnings.end());
    auto estimate = [&](int p) {
      const int i = index[static_cast<std::size_t>(p)];
      return ParameterEstimate{mode_names[static_cast<std::size_t>(p)], values[i], deviation[i]};
    };
    auto check_determined = [&](const ParameterEstimate& pe) {
      if (pe.standard_deviation > std::max(std::abs(pe.value), 1e-12)) {
        report.warnings.push_back("parameter '" + pe.name + "' is poorly determined: standard deviation " +
                                  number(pe.standard_deviation) + " exceeds its value " + number(pe.value));
      }
    };
    for (int p = 0; p < b.par.num_model(); ++p) {
      const ParameterEstimate pe = estimate(p);
      report.parameters.push_back(pe);
      if (b.bounds[static_cast<std::size_t>(p)].near_bound(pe.value)) {
        report.warnings.push_back("parameter '" + pe.name + "' = " + number(pe.value) +
                                  " ended on its bound; its standard deviation is not meaningful");
      } else {
        check_determined(pe);
      }
    }
    for (int e = 0; e < b.par.num_q() + b.par.num_r(); ++e) {
      const ParameterEstimate pe = estimate(b.par.num_model() + e);
      report.noise_parameters.push_back(pe);
      check_determined(pe);
    }
    report.q_intensity = final_result.natural[j].q;
    if (options.fit_measurement_noise) report.measurement_noise = fitted_r;
    report.rmse = e.rmse;
    report.mean_nis = e.mean_nis;
    report.residuals = e.residuals;
    report.measured_rows = e.measured_rows;
    report.negative_log_likelihood = e.negative_log_likelihood;
    report.negative_log_likelihood_per_row = e.negative_log_likelihood / std::max(1, e.measured_rows);
    report.derivatives = b.par.num_model() == 0                   ? "none"
                         : final_result.modes[j].acc.used_numeric ? "numeric"
                                                                  : "autodiff";
    report.iterations = iterations;
    report.initial_cost = initial_cost;
    report.final_cost = final_result.cost;
    report.condition_number = largest / smallest;
    reports[b.mode] = report;
  }
  return reports;
}

}  // namespace

std::vector<FitReport> fit_likelihood(Bank* bank, const std::vector<ModeLogs>& data,
                                      const LikelihoodFitOptions& options) {
  if (data.empty()) throw FitError("no logs to fit");
  refuse_outputs(*bank);
  // Pool the logs of a mode listed more than once, in order of first mention.
  std::vector<std::pair<int, std::vector<const Trajectory*>>> modes;
  for (const ModeLogs& d : data) {
    check_mode(*bank, d.mode);
    auto at = std::find_if(modes.begin(), modes.end(), [&](const auto& e) { return e.first == d.mode; });
    if (at == modes.end()) {
      modes.emplace_back(d.mode, std::vector<const Trajectory*>{});
      at = modes.end() - 1;
    }
    for (const Trajectory& t : d.logs) at->second.push_back(&t);
  }
  for (const auto& [mode, logs] : modes) {
    if (logs.empty()) throw FitError(mode_name(bank->config, mode) + ": no logs given");
  }
  std::map<int, FitReport> reports;
  if (options.fit_measurement_noise) {
    reports = fit_group(bank, modes, options);
  } else {
    for (const auto& entry : modes) {
      for (auto& [mode, report] : fit_group(bank, {entry}, options)) reports[mode] = std::move(report);
    }
  }
  std::vector<FitReport> out;
  for (const ModeLogs& d : data) out.push_back(reports[d.mode]);
  return out;
}

LikelihoodEvaluation evaluate_likelihood(const Bank& bank, const ModeLogs& data) {
  check_mode(bank, data.mode);
  const Parameterization none;
  const ModeEvaluation e =
      evaluate_mode(bank.config, bank.models[static_cast<std::size_t>(data.mode)].get(), pointers(data), none,
                    bank.config.modes[static_cast<std::size_t>(data.mode)].q_intensity, bank.config.measurement.r,
                    false, false, false, true);
  return to_evaluation(e);
}

LikelihoodEvaluation evaluate_likelihood_derivatives(Bank* bank, const ModeLogs& data,
                                                     const LikelihoodFitOptions& options) {
  refuse_outputs(*bank);
  check_mode(*bank, data.mode);
  sdk::MotionModel* model = bank->models[static_cast<std::size_t>(data.mode)].get();
  const Parameterization par = parameterization_of(*model, bank->config.state_dim(),
                                                   static_cast<int>(bank->config.measurement.h.rows()), options);
  const Eigen::MatrixXd& q = bank->config.modes[static_cast<std::size_t>(data.mode)].q_intensity;
  if (par.num_q() > 0) {
    for (const Trajectory& t : data.logs) {
      if (t.size() < 2) continue;
      std::string why;
      if (!check_linear_in_intensity(*model, q, bank->config.initial_state, t.u.col(0), t.t[1] - t.t[0], &why)) {
        LikelihoodEvaluation out;
        out.negative_log_likelihood = kInfinity;
        out.failure = why;
        return out;
      }
      break;
    }
  }
  // Every derivative computed at every row, except that a step found static
  // at its row (F and Qd independent of x and u) reuses the parameter
  // derivatives of an earlier static step of the same dt.
  StepStructure observed;
  observed.reset(model->state_dim(), par.num_model());
  const ModeEvaluation e = evaluate_mode(bank->config, model, pointers(data), par, q, bank->config.measurement.r, true,
                                         options.numeric_derivatives, true, true, nullptr, &observed);
  LikelihoodEvaluation out = to_evaluation(e);
  out.parameter_names = names_of(par, *model);
  if (e.ok()) {
    out.gradient = e.acc.gradient;
    out.information = e.acc.information;
  }
  return out;
}

}  // namespace fitting
}  // namespace skidimm
