#include "skidimm/engine/ekf.h"

#include <Eigen/Cholesky>
#include <cmath>
#include <utility>

#include "covariance.h"
#include "skidimm/sdk/angles.h"

namespace skidimm {

namespace {
constexpr double kLog2Pi = 1.8378770664093454835606594728112;

bool is_diagonal(const Eigen::MatrixXd& m) {
  for (Eigen::Index j = 0; j < m.cols(); ++j) {
    for (Eigen::Index i = 0; i < m.rows(); ++i) {
      if (i != j && m(i, j) != 0.0) return false;
    }
  }
  return true;
}

}  // namespace

ExtendedKalmanFilter::ExtendedKalmanFilter(const sdk::MotionModel& model, Eigen::MatrixXd q_intensity,
                                           int measurement_dim)
    : model_(model), q_intensity_(std::move(q_intensity)) {
  const int n = model.state_dim();
  const int m = measurement_dim;
  for (int i = 0; i < n; ++i) is_angle_.push_back(model.is_angle(i));
  x_ = Eigen::VectorXd::Zero(n);
  p_ = Eigen::MatrixXd::Identity(n, n);
  x_next_.resize(n);
  f_.resize(n, n);
  q_.resize(n, n);
  fp_.resize(n, n);
  innovation_.resize(m);
  whitened_.resize(m);
  whitened_innovation_.resize(m);
  hp_.resize(m, n);
  s_.resize(m, m);
  gain_.resize(n, m);
  i_kh_.resize(n, n);
  kr_.resize(n, m);
}

void ExtendedKalmanFilter::wrap_angles(Eigen::Ref<Eigen::VectorXd> x) const {
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    if (is_angle_[i]) x[i] = sdk::wrap_angle(x[i]);
  }
}

bool ExtendedKalmanFilter::predict(const Eigen::Ref<const Eigen::VectorXd>& u, double dt) {
  // F and Q are evaluated at the prior state, before x_ is overwritten.
  if (!model_.jacobian(x_, u, dt, f_)) return false;
  if (!model_.process_noise(q_intensity_, x_, u, dt, q_)) return false;
  if (!model_.predict(x_, u, dt, x_next_)) return false;
  x_ = x_next_;
  wrap_angles(x_);
  // Structure the products would spend most of their time on, taken
  // directly: a diagonal F (decoupled states, e.g. linear_features with a
  // diagonal A) scales P's rows and columns. Each entry is then the same two
  // roundings as in the product, so the result is the same to the bit.
  if (is_diagonal(f_)) {
    const Eigen::Index n = p_.rows();
    for (Eigen::Index j = 0; j < n; ++j) {
      for (Eigen::Index i = 0; i < n; ++i) p_(i, j) = (f_(i, i) * p_(i, j)) * f_(j, j);
    }
  } else {
    fp_.noalias() = f_ * p_;
    p_.noalias() = fp_ * f_.transpose();
  }
  p_ += q_;
  symmetrize(p_);
  return x_.allFinite() && p_.allFinite();
}

Eigen::Ref<const Eigen::VectorXd> ExtendedKalmanFilter::whitened_innovation() {
  auto whitened = whitened_innovation_.head(last_size_);
  whitened = innovation_.head(last_size_);
  // The in-place LLT of update() left L in the lower triangle of s_.
  s_.topLeftCorner(last_size_, last_size_).triangularView<Eigen::Lower>().solveInPlace(whitened);
  return whitened;
}

UpdateResult ExtendedKalmanFilter::update(const SelectedMeasurement& measurement, double gate) {
  UpdateResult result;
  const int k = measurement.size;
  if (k == 0) {
    result.ok = true;
    return result;
  }
  auto h = measurement.h.topRows(k);
  auto nu = innovation_.head(k);
  nu.noalias() = measurement.z.head(k) - h * x_;
  for (int a = 0; a < k; ++a) {
    if (measurement.is_angle[a]) nu[a] = sdk::wrap_angle(nu[a]);
  }

  // H P- and H P- H': rows and columns of P- when H picks states (the same
  // numbers as the products, which add only exact zeros to them).
  auto hp = hp_.topRows(k);
  auto s = s_.topLeftCorner(k, k);
  if (measurement.picks_states) {
    for (int a = 0; a < k; ++a) hp.row(a) = p_.row(measurement.picked_state[static_cast<std::size_t>(a)]);
    for (int b = 0; b < k; ++b) s.col(b) = hp.col(measurement.picked_state[static_cast<std::size_t>(b)]);
  } else {
    hp.noalias() = h * p_;
    s.noalias() = hp * h.transpose();
  }
  s += measurement.r.topLeftCorner(k, k);
  symmetrize(s);

  // In-place Cholesky on the workspace: S = L L'.
  Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>> llt(s);
  if (llt.info() != Eigen::Success) return result;
  last_size_ = k;

  auto whitened = whitened_.head(k);
  whitened = nu;
  llt.solveInPlace(whitened);  // S^-1 nu
  result.nis = nu.dot(whitened);
  const double log_det = 2.0 * s.diagonal().array().log().sum();
  if (result.nis > gate) {
    result.gated = true;
    result.log_likelihood = -0.5 * (gate + log_det + k * kLog2Pi);
    result.ok = std::isfinite(result.log_likelihood);
    return result;
  }
  result.log_likelihood = -0.5 * (result.nis + log_det + k * kLog2Pi);

  // K' = S^-1 H P-   (S and P- symmetric), solved in place over H P-.
  llt.solveInPlace(hp);
  auto gain = gain_.leftCols(k);
  gain = hp.transpose();

  x_.noalias() += gain * nu;
  wrap_angles(x_);

  i_kh_.setIdentity();
  if (measurement.picks_states) {
    for (int a = 0; a < k; ++a) i_kh_.col(measurement.picked_state[static_cast<std::size_t>(a)]) -= gain.col(a);
  } else {
    i_kh_.noalias() -= gain * h;
  }
  fp_.noalias() = i_kh_ * p_;
  p_.noalias() = fp_ * i_kh_.transpose();
  auto kr = kr_.leftCols(k);
  kr.noalias() = gain * measurement.r.topLeftCorner(k, k);
  p_.noalias() += kr * gain.transpose();
  symmetrize(p_);

  result.ok = std::isfinite(result.log_likelihood) && x_.allFinite() && p_.allFinite();
  return result;
}

}  // namespace skidimm
