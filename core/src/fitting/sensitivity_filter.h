// Fitting by likelihood, its third part: the mode's filter over its logs,
// carrying the sensitivities of its state, covariance and innovations, so
// that one pass gives the negative log-likelihood and its gradient. Private
// to the fitting library.
#ifndef SKIDIMM_CORE_SRC_FITTING_SENSITIVITY_FILTER_H_
#define SKIDIMM_CORE_SRC_FITTING_SENSITIVITY_FILTER_H_

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

#include "covariance.h"
#include "skidimm/config/bank.h"
#include "skidimm/engine/measurement_model.h"
#include "skidimm/fitting/trajectory.h"
#include "step_derivatives.h"

namespace skidimm {
namespace fitting {
namespace internal {
// Internal linkage, as when these parts were one file: likelihood_fitter.cc
// is the one translation unit that includes them.
namespace {

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
                                    bool numeric_derivatives, bool information, bool rows,
                                    const StepStructure* use = nullptr, StepStructure* observe = nullptr,
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

}  // namespace
}  // namespace internal
}  // namespace fitting
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_FITTING_SENSITIVITY_FILTER_H_
