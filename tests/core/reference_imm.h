// ReferenceImm: an IMM written out by hand for one known bank, with fixed-size
// Eigen types throughout and the motion model's equations inlined, the way an
// engineer would write a filter for a single robot. It is independent of the
// library (it shares nothing with core/, only the plugins' equations, written
// out again below), so it serves twice:
//
//  * tests/core/imm_test.cc runs the engine and this filter side by side and
//    requires agreement to 1e-10 at the sizes the engine's fixed-size kernels
//    cover (2 and 3 states, angles across +-pi, partial measurements);
//  * tests/benchmarks/ times both in the same run, and the engine's time as a
//    multiple of this one is the figure docs/performance.md reports.
//
// The mathematics are the textbook's (Bar-Shalom, Li and Kirubarajan 2001,
// 11.6.6) with the engine's documented choices (docs/engine.md): c_j in eq. 9,
// log-sum-exp, a probability floor, Joseph form, Q = Q_c dt, and angles mixed
// per target around its heaviest component (the direct form of eq. 6-7). It
// assumes well-behaved data: no rejected modes, t increasing.
#ifndef SKIDIMM_TESTS_CORE_REFERENCE_IMM_H_
#define SKIDIMM_TESTS_CORE_REFERENCE_IMM_H_

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/StdVector>
#include <array>
#include <cmath>
#include <limits>
#include <vector>

namespace skidimm_test {

// An angle in [-pi, pi): no division for the usual case, already in range.
inline double reference_wrap(double angle) {
  constexpr double kPi = 3.14159265358979323846;
  if (angle >= -kPi && angle < kPi) return angle;
  return angle - 2.0 * kPi * std::floor((angle + kPi) / (2.0 * kPi));
}

// d/dt [V, omega] = A [V, omega] + B [phi_dot_L, phi_dot_R], forward Euler (paper eq. 2).
struct LtcReferenceModel {
  static constexpr int kStates = 2;
  static constexpr int kInputs = 2;
  Eigen::Matrix2d a;
  Eigen::Matrix2d b;
  static bool is_angle(int) { return false; }
  void predict(const Eigen::Vector2d& x, const Eigen::Vector2d& u, double dt, Eigen::Vector2d* next,
               Eigen::Matrix2d* f) const {
    *next = x + (a * x + b * u) * dt;
    *f = Eigen::Matrix2d::Identity() + a * dt;
  }
};

// Pose [X, Y, theta] with slip constants k, m (paper eq. 3); sin and cos once.
struct StcReferenceModel {
  static constexpr int kStates = 3;
  static constexpr int kInputs = 2;
  double k = 1.0, m = 1.0, r = 1.0, b = 1.0;
  static bool is_angle(int i) { return i == 2; }
  void predict(const Eigen::Vector3d& x, const Eigen::Vector2d& u, double dt, Eigen::Vector3d* next,
               Eigen::Matrix3d* f) const {
    const double forward = r * (u[0] + u[1]) / 2.0;
    const double yaw_rate = r * (u[1] - u[0]) / b;
    const double s = std::sin(x[2]), c = std::cos(x[2]);
    (*next)[0] = x[0] + k * c * forward * dt;
    (*next)[1] = x[1] + k * s * forward * dt;
    (*next)[2] = reference_wrap(x[2] + m * yaw_rate * dt);
    *f << 1.0, 0.0, -k * s * forward * dt,  //
        0.0, 1.0, k * c * forward * dt,     //
        0.0, 0.0, 1.0;
  }
};

template <typename Model, int kMeasurements>
class ReferenceImm {
 public:
  static constexpr int N = Model::kStates;
  static constexpr int M = kMeasurements;
  using State = Eigen::Matrix<double, N, 1>;
  using Covariance = Eigen::Matrix<double, N, N>;
  using Input = Eigen::Matrix<double, Model::kInputs, 1>;
  using Measurement = Eigen::Matrix<double, M, 1>;
  using ObservationMatrix = Eigen::Matrix<double, M, N>;
  using NoiseMatrix = Eigen::Matrix<double, M, M>;

  ReferenceImm(std::vector<Model> models, std::vector<Covariance> q_intensity, const ObservationMatrix& h,
               const NoiseMatrix& r, std::array<bool, M> measures_angle, const State& x0, const Covariance& p0,
               const Eigen::VectorXd& mu0, double floor)
      : models_(std::move(models)),
        q_(q_intensity.begin(), q_intensity.end()),
        h_(h),
        r_(r),
        measures_angle_(measures_angle),
        x0_(x0),
        p0_(p0),
        mu0_(mu0),
        floor_(floor) {
    const int modes = num_modes();
    x_.resize(modes);
    p_.resize(modes);
    mixed_x_.resize(modes);
    mixed_p_.resize(modes);
    c_.resize(modes);
    log_likelihood_.resize(modes);
    log_posterior_.resize(modes);
    weights_.resize(modes);
    reset();
  }

  int num_modes() const { return static_cast<int>(models_.size()); }

  void reset() {
    for (int j = 0; j < num_modes(); ++j) {
      x_[j] = x0_;
      p_[j] = p0_;
    }
    mu_ = mu0_;
    x_combined_ = x0_;
    p_combined_ = p0_;
    first_ = true;
  }

  // `transition`: p_ij for this step (row from, column to). NaN in z: not measured.
  void step(double t, const Input& u, const Measurement& z, const Eigen::MatrixXd& transition) {
    const int modes = num_modes();
    const double dt = t - last_t_;
    if (first_) {
      c_ = mu_;
    } else {
      c_.noalias() = transition.transpose() * mu_;
      for (int j = 0; j < modes; ++j) {
        for (int i = 0; i < modes; ++i) weights_[i] = c_[j] > 0.0 ? transition(i, j) * mu_[i] / c_[j] : mu_[i];
        mix(weights_, x_, p_, &mixed_x_[j], &mixed_p_[j]);
      }
      for (int j = 0; j < modes; ++j) {
        Covariance f;
        models_[j].predict(mixed_x_[j], held_u_, dt, &x_[j], &f);
        p_[j] = f * mixed_p_[j] * f.transpose() + q_[j] * dt;
        p_[j] = 0.5 * (p_[j] + p_[j].transpose()).eval();
      }
    }
    int present = 0;
    for (int a = 0; a < M; ++a) present += std::isfinite(z[a]) ? 1 : 0;
    for (int j = 0; j < modes; ++j) {
      log_likelihood_[j] = present == M ? update_full(z, &x_[j], &p_[j]) : present > 0 ? update_partial(z, &x_[j], &p_[j]) : 0.0;
    }
    for (int j = 0; j < modes; ++j) {
      log_posterior_[j] = std::log(c_[j]) + (present > 0 ? log_likelihood_[j] : 0.0);
    }
    const double largest = log_posterior_.maxCoeff();
    for (int j = 0; j < modes; ++j) mu_[j] = std::exp(log_posterior_[j] - largest);
    mu_ /= mu_.sum();
    if (floor_ > 0.0) {
      mu_ = mu_.cwiseMax(floor_);
      mu_ /= mu_.sum();
    }
    mix(mu_, x_, p_, &x_combined_, &p_combined_);
    first_ = false;
    last_t_ = t;
    held_u_ = u;
  }

  const Eigen::VectorXd& mode_probabilities() const { return mu_; }
  const State& mode_state(int j) const { return x_[j]; }
  const Covariance& mode_covariance(int j) const { return p_[j]; }
  double log_likelihood(int j) const { return log_likelihood_[j]; }
  const State& state() const { return x_combined_; }
  const Covariance& covariance() const { return p_combined_; }

 private:
  using States = std::vector<State, Eigen::aligned_allocator<State>>;
  using Covariances = std::vector<Covariance, Eigen::aligned_allocator<Covariance>>;

  // Moment matching of eq. 6-7 and 10-11, angles around the heaviest component.
  static void mix(const Eigen::VectorXd& w, const States& x, const Covariances& p, State* mean, Covariance* cov) {
    const int modes = static_cast<int>(w.size());
    Eigen::Index heaviest = 0;
    w.maxCoeff(&heaviest);
    for (int d = 0; d < N; ++d) {
      double sum = 0.0;
      if (Model::is_angle(d)) {
        const double reference = x[heaviest][d];
        for (int i = 0; i < modes; ++i) sum += w[i] * reference_wrap(x[i][d] - reference);
        (*mean)[d] = reference_wrap(reference + sum);
      } else {
        for (int i = 0; i < modes; ++i) sum += w[i] * x[i][d];
        (*mean)[d] = sum;
      }
    }
    cov->setZero();
    for (int i = 0; i < modes; ++i) {
      State d = x[i] - *mean;
      for (int k = 0; k < N; ++k) {
        if (Model::is_angle(k)) d[k] = reference_wrap(d[k]);
      }
      *cov += w[i] * (p[i] + d * d.transpose());
    }
    *cov = 0.5 * (*cov + cov->transpose()).eval();
  }

  template <int K>
  double update(const Eigen::Matrix<double, K, 1>& z, const Eigen::Matrix<double, K, N>& h,
                const Eigen::Matrix<double, K, K>& r, const std::array<bool, K>& angle, State* x, Covariance* p) const {
    Eigen::Matrix<double, K, 1> nu = z - h * *x;
    for (int a = 0; a < K; ++a) {
      if (angle[a]) nu[a] = reference_wrap(nu[a]);
    }
    const Eigen::Matrix<double, K, N> hp = h * *p;
    Eigen::Matrix<double, K, K> s = hp * h.transpose() + r;
    s = 0.5 * (s + s.transpose()).eval();
    // Cholesky by hand: Eigen's LLT::solve goes through its general
    // triangular solver, slow for 2 x 2 and 3 x 3.
    Eigen::Matrix<double, K, K> l = Eigen::Matrix<double, K, K>::Zero();
    for (int j = 0; j < K; ++j) {
      double d = s(j, j);
      for (int k = 0; k < j; ++k) d -= l(j, k) * l(j, k);
      l(j, j) = std::sqrt(d);
      for (int i = j + 1; i < K; ++i) {
        double v = s(i, j);
        for (int k = 0; k < j; ++k) v -= l(i, k) * l(j, k);
        l(i, j) = v / l(j, j);
      }
    }
    const auto solve = [&l](auto b) {  // (L L')^-1 b
      for (int c = 0; c < b.cols(); ++c) {
        for (int i = 0; i < K; ++i) {
          for (int k = 0; k < i; ++k) b(i, c) -= l(i, k) * b(k, c);
          b(i, c) /= l(i, i);
        }
        for (int i = K - 1; i >= 0; --i) {
          for (int k = i + 1; k < K; ++k) b(i, c) -= l(k, i) * b(k, c);
          b(i, c) /= l(i, i);
        }
      }
      return b;
    };
    const Eigen::Matrix<double, K, 1> whitened = solve(nu);
    const Eigen::Matrix<double, N, K> gain = solve(hp).transpose();
    double log_det = 0.0;
    for (int a = 0; a < K; ++a) log_det += 2.0 * std::log(l(a, a));
    *x += gain * nu;
    for (int d = 0; d < N; ++d) {
      if (Model::is_angle(d)) (*x)[d] = reference_wrap((*x)[d]);
    }
    const Covariance i_kh = Covariance::Identity() - gain * h;
    *p = i_kh * *p * i_kh.transpose() + gain * r * gain.transpose();
    *p = 0.5 * (*p + p->transpose()).eval();
    return -0.5 * (nu.dot(whitened) + log_det + K * 1.8378770664093454835606594728112);
  }

  double update_full(const Measurement& z, State* x, Covariance* p) const {
    return update<M>(z, h_, r_, measures_angle_, x, p);
  }

  // Rows present only (a 10 Hz GPS in a 50 Hz log): the same update on the
  // selected rows, in dynamic storage bounded by M (no heap).
  double update_partial(const Measurement& z, State* x, Covariance* p) const {
    using Z = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, M, 1>;
    using H = Eigen::Matrix<double, Eigen::Dynamic, N, 0, M, N>;
    using R = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, M, M>;
    std::array<int, M> rows{};
    int k = 0;
    for (int a = 0; a < M; ++a) {
      if (std::isfinite(z[a])) rows[k++] = a;
    }
    Z zs(k);
    H hs(k, N);
    R rs(k, k);
    for (int a = 0; a < k; ++a) {
      zs[a] = z[rows[a]];
      hs.row(a) = h_.row(rows[a]);
      for (int b = 0; b < k; ++b) rs(a, b) = r_(rows[a], rows[b]);
    }
    Z nu = zs - hs * *x;
    for (int a = 0; a < k; ++a) {
      if (measures_angle_[rows[a]]) nu[a] = reference_wrap(nu[a]);
    }
    const Eigen::Matrix<double, Eigen::Dynamic, N, 0, M, N> hp = hs * *p;
    R s = hp * hs.transpose() + rs;
    s = 0.5 * (s + s.transpose()).eval();
    const Eigen::LLT<R> llt(s);
    const Z whitened = llt.solve(nu);
    const Eigen::Matrix<double, N, Eigen::Dynamic, 0, N, M> gain = llt.solve(hp).transpose();
    double log_det = 0.0;
    for (int a = 0; a < k; ++a) log_det += 2.0 * std::log(llt.matrixLLT()(a, a));
    *x += gain * nu;
    for (int d = 0; d < N; ++d) {
      if (Model::is_angle(d)) (*x)[d] = reference_wrap((*x)[d]);
    }
    const Covariance i_kh = Covariance::Identity() - gain * hs;
    *p = i_kh * *p * i_kh.transpose() + gain * rs * gain.transpose();
    *p = 0.5 * (*p + p->transpose()).eval();
    return -0.5 * (nu.dot(whitened) + log_det + k * 1.8378770664093454835606594728112);
  }

  std::vector<Model> models_;
  Covariances q_;
  ObservationMatrix h_;
  NoiseMatrix r_;
  std::array<bool, M> measures_angle_;
  State x0_;
  Covariance p0_;
  Eigen::VectorXd mu0_;
  double floor_;

  States x_;
  Covariances p_;
  States mixed_x_;
  Covariances mixed_p_;
  Eigen::VectorXd mu_, c_, log_likelihood_, log_posterior_, weights_;
  State x_combined_;
  Covariance p_combined_;
  Input held_u_ = Input::Zero();
  bool first_ = true;
  double last_t_ = 0.0;
};

}  // namespace skidimm_test

#endif  // SKIDIMM_TESTS_CORE_REFERENCE_IMM_H_
