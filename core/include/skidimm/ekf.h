// ExtendedKalmanFilter: the model-matched filter of one IMM mode (paper,
// section IV-3), with its own preallocated workspace.
//
//   predict:  x- = f(x, u, dt),  P- = F P F' + Q(dt)          F = df/dx
//   update:   nu = z - H x- (angles wrapped),  S = H P- H' + R
//             K = P- H' S^-1 (Cholesky solve, never an inverse)
//             x+ = x- + K nu,  P+ = (I-KH) P- (I-KH)' + K R K'  (Joseph form)
//             log Lambda = -1/2 (nu' S^-1 nu + log det(2 pi S))   (paper eq. 8)
//
// A linear model is the special case of a constant F. The Joseph form keeps P
// symmetric positive semidefinite under round-off, where P - KHP does not.
// After construction no member allocates.
//
// predict_fixed() and update_fixed() below are the same filter for a state
// of N and a measurement of K components known at compile time, on Eigen
// fixed-size types the caller owns: what the IMM's fixed-size kernels run
// (imm.h). They call the model through the same three virtuals (jacobian,
// process_noise, predict, in that order, at the prior state) and agree with
// ExtendedKalmanFilter to round-off (tests/core/ekf_test.cc).
#ifndef SKIDIMM_EKF_H_
#define SKIDIMM_EKF_H_

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "skidimm/covariance.h"
#include "skidimm/measurement_model.h"
#include "skidimm/sdk/angles.h"
#include "skidimm/sdk/motion_model.h"

namespace skidimm {

struct UpdateResult {
  bool ok = false;              // false: S not positive definite or result non-finite
  bool gated = false;           // nis was above the gate: x and P were left as predicted
  // log N(nu; 0, S); when gated, the density at the gate's boundary,
  // -1/2 (gate + log det(2 pi S)): the most a gated measurement can score.
  double log_likelihood = 0.0;
  double nis = 0.0;  // nu' S^-1 nu, chi-square with size() dof if consistent
};

class ExtendedKalmanFilter {
 public:
  // `model` must outlive the filter. q_intensity: the mode's continuous-time Q.
  ExtendedKalmanFilter(const sdk::MotionModel& model, Eigen::MatrixXd q_intensity, int measurement_dim);

  Eigen::VectorXd& state() { return x_; }
  const Eigen::VectorXd& state() const { return x_; }
  Eigen::MatrixXd& covariance() { return p_; }
  const Eigen::MatrixXd& covariance() const { return p_; }

  // Propagates state() and covariance() by dt with input u. Returns false if
  // the model fails or produces non-finite values (state is then unspecified).
  bool predict(const Eigen::Ref<const Eigen::VectorXd>& u, double dt);

  // Corrects state() and covariance() with the selected measurement, unless
  // its NIS is above `gate` (then only the result is written, gated).
  UpdateResult update(const SelectedMeasurement& measurement, double gate = std::numeric_limits<double>::infinity());

  // Wraps the angle components of a state in place.
  void wrap_angles(Eigen::Ref<Eigen::VectorXd> x) const;
  bool is_angle(int i) const { return is_angle_[i]; }

 private:
  const sdk::MotionModel& model_;
  Eigen::MatrixXd q_intensity_;
  std::vector<bool> is_angle_;

  Eigen::VectorXd x_;
  Eigen::MatrixXd p_;
  // Workspace.
  Eigen::VectorXd x_next_;
  Eigen::MatrixXd f_;
  Eigen::MatrixXd q_;
  Eigen::MatrixXd fp_;
  Eigen::VectorXd innovation_;
  Eigen::VectorXd whitened_;
  Eigen::MatrixXd hp_;    // H P-          (k x n)
  Eigen::MatrixXd s_;     // S, then its Cholesky factor
  Eigen::MatrixXd gain_;  // K             (n x k)
  Eigen::MatrixXd i_kh_;  // I - K H       (n x n)
  Eigen::MatrixXd kr_;    // K R           (n x k)
};

// ---------------------------------------------------------------- fixed sizes

// Bit i set: component i is an angle (wraps at +-pi).
using AngleMask = std::uint32_t;

// sdk::wrap_angle, returning angles already in [-pi, pi) unchanged without a
// division: the same result, except within an ulp of the seam.
inline double wrap_angle_fast(double angle) {
  return angle >= -sdk::kPi && angle < sdk::kPi ? angle : sdk::wrap_angle(angle);
}

template <int N>
void wrap_angles_fixed(AngleMask angles, Eigen::Matrix<double, N, 1>* x) {
  if (angles == 0) return;
  for (int i = 0; i < N; ++i) {
    if (angles >> i & 1u) (*x)[i] = wrap_angle_fast((*x)[i]);
  }
}

// m = (m + m') / 2 for a fixed-size square matrix: symmetrize()'s values,
// unrolled.
template <int N>
inline void symmetrize_fixed(Eigen::Matrix<double, N, N>* m) {
  for (int j = 1; j < N; ++j) {
    for (int i = 0; i < j; ++i) {
      const double mean = 0.5 * ((*m)(i, j) + (*m)(j, i));
      (*m)(i, j) = mean;
      (*m)(j, i) = mean;
    }
  }
}

template <int R, int C>
bool all_finite(const Eigen::Matrix<double, R, C>& m) {
  bool finite = true;
  for (int i = 0; i < R * C; ++i) finite = finite && std::isfinite(m.data()[i]);
  return finite;
}

// Propagates x, P by dt with input u through `model`; q_intensity is the
// mode's continuous-time Q. Returns false if the model fails or the result is
// not finite (x, P are then unspecified).
template <int N>
bool predict_fixed(const sdk::MotionModel& model, const Eigen::Matrix<double, N, N>& q_intensity, AngleMask angles,
                   const Eigen::Ref<const Eigen::VectorXd>& u, double dt, Eigen::Matrix<double, N, 1>* x,
                   Eigen::Matrix<double, N, N>* p) {
  // Outputs of the model in storage of at least two doubles: GCC 12 sees the
  // plugin's packet stores into a 1 x 1 matrix as out of bounds.
  constexpr int kStorage = N * N < 2 ? 2 : N * N;
  alignas(16) double f_storage[kStorage];
  alignas(16) double q_storage[kStorage];
  alignas(16) double next_storage[N < 2 ? 2 : N];
  Eigen::Map<Eigen::Matrix<double, N, N>> f(f_storage);
  Eigen::Map<Eigen::Matrix<double, N, N>> q(q_storage);
  Eigen::Map<Eigen::Matrix<double, N, 1>> next(next_storage);
  // F and Q are evaluated at the prior state, before x is overwritten.
  {
    Eigen::Ref<Eigen::MatrixXd> f_out(f);
    if (!model.jacobian(*x, u, dt, f_out)) return false;
  }
  {
    Eigen::Ref<Eigen::MatrixXd> q_out(q);
    if (!model.process_noise(q_intensity, *x, u, dt, q_out)) return false;
  }
  {
    Eigen::Ref<Eigen::VectorXd> next_out(next);
    if (!model.predict(*x, u, dt, next_out)) return false;
  }
  *x = next;
  wrap_angles_fixed<N>(angles, x);
  const Eigen::Matrix<double, N, N> fp = f * *p;
  p->noalias() = fp * f.transpose();
  *p += q;
  symmetrize_fixed<N>(p);
  return all_finite(*x) && all_finite(*p);
}

// S = L L' in place (the lower triangle), for small fixed K, with the
// reciprocals of L's diagonal in *inverse_diagonal (solves then multiply).
// False if S is not positive definite (a pivot <= 0 or NaN), as Eigen::LLT
// reports it.
template <int K>
bool cholesky_in_place(Eigen::Matrix<double, K, K>* s, Eigen::Matrix<double, K, 1>* inverse_diagonal) {
  for (int j = 0; j < K; ++j) {
    double pivot = (*s)(j, j);
    for (int k = 0; k < j; ++k) pivot -= (*s)(j, k) * (*s)(j, k);
    if (!(pivot > 0.0)) return false;
    pivot = std::sqrt(pivot);
    (*s)(j, j) = pivot;
    const double inverse = 1.0 / pivot;
    (*inverse_diagonal)[j] = inverse;
    for (int i = j + 1; i < K; ++i) {
      double v = (*s)(i, j);
      for (int k = 0; k < j; ++k) v -= (*s)(i, k) * (*s)(j, k);
      (*s)(i, j) = v * inverse;
    }
  }
  return true;
}

// b <- L^-1 b for the factor cholesky_in_place() left in l.
template <int K, int C>
void forward_substitute(const Eigen::Matrix<double, K, K>& l, const Eigen::Matrix<double, K, 1>& inverse_diagonal,
                        Eigen::Matrix<double, K, C>* b) {
  for (int c = 0; c < C; ++c) {
    for (int i = 0; i < K; ++i) {
      double v = (*b)(i, c);
      for (int k = 0; k < i; ++k) v -= l(i, k) * (*b)(k, c);
      (*b)(i, c) = v * inverse_diagonal[i];
    }
  }
}

// b <- L'^-1 b.
template <int K, int C>
void back_substitute(const Eigen::Matrix<double, K, K>& l, const Eigen::Matrix<double, K, 1>& inverse_diagonal,
                     Eigen::Matrix<double, K, C>* b) {
  for (int c = 0; c < C; ++c) {
    for (int i = K - 1; i >= 0; --i) {
      double v = (*b)(i, c);
      for (int k = i + 1; k < K; ++k) v -= l(k, i) * (*b)(k, c);
      (*b)(i, c) = v * inverse_diagonal[i];
    }
  }
}

// Corrects x, P with a measurement z = H x + v, v ~ N(0, R) of K components;
// bit a of z_angles: row a measures an angle. A measurement whose NIS is
// above `gate` is not applied (result.gated).
template <int N, int K>
UpdateResult update_fixed(const Eigen::Matrix<double, K, 1>& z, const Eigen::Matrix<double, K, N>& h,
                          const Eigen::Matrix<double, K, K>& r, AngleMask z_angles, AngleMask state_angles,
                          Eigen::Matrix<double, N, 1>* x, Eigen::Matrix<double, N, N>* p,
                          double gate = std::numeric_limits<double>::infinity()) {
  constexpr double kLog2Pi = 1.8378770664093454835606594728112;
  UpdateResult result;
  Eigen::Matrix<double, K, 1> nu = z;
  nu.noalias() -= h * *x;
  wrap_angles_fixed<K>(z_angles, &nu);
  Eigen::Matrix<double, K, N> hp;
  hp.noalias() = h * *p;
  Eigen::Matrix<double, K, K> s = r;
  s.noalias() += hp * h.transpose();
  symmetrize_fixed<K>(&s);
  // In-place Cholesky: S = L L'.
  Eigen::Matrix<double, K, 1> inverse_diagonal;
  if (!cholesky_in_place<K>(&s, &inverse_diagonal)) return result;
  Eigen::Matrix<double, K, 1> whitened = nu;
  forward_substitute<K, 1>(s, inverse_diagonal, &whitened);  // L^-1 nu
  result.nis = whitened.squaredNorm();                       // nu' S^-1 nu
  // log det S = 2 sum log L_aa: one log of the product while it is safely
  // inside double's range (always, for real sensors), the sum otherwise.
  double product = 1.0;
  for (int a = 0; a < K; ++a) product *= s(a, a);
  double log_det = 0.0;
  if (product > 1e-280 && product < 1e280) {
    log_det = std::log(product);
  } else {
    for (int a = 0; a < K; ++a) log_det += std::log(s(a, a));
  }
  if (result.nis > gate) {
    result.gated = true;
    result.log_likelihood = -0.5 * (gate + 2.0 * log_det + K * kLog2Pi);
    result.ok = std::isfinite(result.log_likelihood);
    return result;
  }
  result.log_likelihood = -0.5 * (result.nis + 2.0 * log_det + K * kLog2Pi);
  // K' = S^-1 H P-   (S and P- symmetric), solved in place over H P-.
  forward_substitute<K, N>(s, inverse_diagonal, &hp);
  back_substitute<K, N>(s, inverse_diagonal, &hp);
  const Eigen::Matrix<double, N, K> gain = hp.transpose();
  x->noalias() += gain * nu;
  wrap_angles_fixed<N>(state_angles, x);
  Eigen::Matrix<double, N, N> i_kh = Eigen::Matrix<double, N, N>::Identity();
  i_kh.noalias() -= gain * h;
  const Eigen::Matrix<double, N, N> ikh_p = i_kh * *p;
  p->noalias() = ikh_p * i_kh.transpose();
  const Eigen::Matrix<double, N, K> kr = gain * r;
  p->noalias() += kr * gain.transpose();
  symmetrize_fixed<N>(p);
  result.ok = std::isfinite(result.log_likelihood) && all_finite(*x) && all_finite(*p);
  return result;
}

}  // namespace skidimm

#endif  // SKIDIMM_EKF_H_
