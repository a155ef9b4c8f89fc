// Exact zero-order-hold discretisation of a linear system
//
//   dx/dt = A x + w,   w = B u + c held constant over the step,
//
// over a step of dt seconds:
//
//   x+  = Phi x + Gamma w,   Phi = expm(A dt),   Gamma = int_0^dt expm(A s) ds,
//   Qd  = int_0^dt expm(A s) Q expm(A s)' ds    (process noise of intensity Q),
//
// and the derivatives of x+ with respect to A and w that fitting needs.
// Exact means: no truncation in dt, so a fast stable state (A = -50 /s) at a
// slow filter rate (dt = 0.5 s) lands on its steady state instead of
// overshooting as forward Euler would (|1 + a dt| = 24 there).
//
// Two forms of A, chosen by the bank:
//  * diagonal (a vector a): every quantity in closed form, element-wise;
//  * full (n x n): matrix exponentials (matrix_exponential.h) of augmented
//    matrices: C. F. Van Loan, "Computing integrals involving the matrix
//    exponential", IEEE Trans. Autom. Control 23(3), 1978.
//
// Nothing here allocates: every matrix is bounded by kMaxZohStates.
#ifndef SKIDIMM_PLUGINS_LINEAR_FEATURES_ZERO_ORDER_HOLD_H_
#define SKIDIMM_PLUGINS_LINEAR_FEATURES_ZERO_ORDER_HOLD_H_

#include <Eigen/Core>
#include <cmath>
#include <limits>
#include <utility>

#include "linear_features/matrix_exponential.h"

namespace skidimm {
namespace plugins {

// The largest state dimension the full form supports. Sets the stack
// matrices' size: the parameter Jacobian's block exponentials are
// 2 (n + 1) = 26 wide, about 65 KB of stack per call.
inline constexpr int kMaxZohStates = 12;

using ZohVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxZohStates, 1>;
using ZohMatrix = BoundedMatrix<kMaxZohStates>;
using ZohAugmentedMatrix = BoundedMatrix<kMaxZohStates + 1>;  // [[A, w], [0, 0]]
using ZohVanLoanMatrix = BoundedMatrix<2 * kMaxZohStates>;    // [[-A, Q], [0, A']]

// --- Scalar (diagonal A) closed forms ---

// int_0^dt e^{a s} ds = (e^{a dt} - 1) / a, by expm1 so that it tends to dt
// without cancellation as a dt -> 0. T is double or a Ceres jet (the tests
// and benchmarks differentiate the step by jets to compare with the
// hand-written derivatives; at a = 0 a jet's derivative in a is lost, one
// reason those are hand-written).
template <typename T>
T exp_integral(const T& a, double dt) noexcept {
  using std::expm1;
  const T z = a * dt;
  return z == 0.0 ? T(dt) : T(expm1(z) / a);
}

// One state of a diagonal A over the step:
//   x+ = e^{a dt} x + (int_0^dt e^{a s} ds) w = phi x + gamma w.
// The factors depend on the rate and the step alone, so states that share a
// rate share them (LinearFeatures::predict computes them once per run of
// equal rates). Each of T (the state), R (the rate a) and W (the drive w) is
// double or a Ceres jet, as a function model's predict sees them
// (skidimm/sdk/function_model.h): a rate held fixed stays a double.
// f(v), computed again only when v differs from the last argument: banks
// usually give every feature the same rate (a held-fixed A), so the loops
// over the states or their pairs of a diagonal A call the same exponential
// with the same argument n or n (n + 1) / 2 times in a row (expm1 was 8% of
// `skidimm tune`'s profile). Same arguments, same values. A NaN argument is
// never equal to the last one, so it is always recomputed.
template <typename F>
class SameArgumentOnce {
 public:
  explicit SameArgumentOnce(F f) : f_(f) {}
  const auto& operator()(double v) {
    if (!(v == last_)) {
      last_ = v;
      value_ = f_(v);
    }
    return value_;
  }

 private:
  F f_;
  double last_ = std::numeric_limits<double>::quiet_NaN();
  decltype(std::declval<F&>()(0.0)) value_{};
};

template <typename R>
struct DiagonalZoh {
  R phi, gamma;
  template <typename T, typename W>
  T step(const T& x, const W& w) const noexcept {
    return phi * x + gamma * w;
  }
};

template <typename R>
DiagonalZoh<R> diagonal_zoh(const R& a, double dt) noexcept {
  using std::exp;
  return {exp(a * dt), exp_integral(a, dt)};
}

// diagonal_zoh(rate, dt), computed again only when (rate, dt) differs from
// this thread's last call: a filter's steps and a fit's windows repeat one
// step size, and banks give every state one rate (a held-fixed A), so the
// predictions of a run reuse one exp and one expm1 (they were 3% of a
// BorealTC tune). Same arguments, same values; a NaN is always recomputed.
inline const DiagonalZoh<double>& last_diagonal_zoh(double rate, double dt) noexcept {
  thread_local double last_rate = std::numeric_limits<double>::quiet_NaN();
  thread_local double last_dt = std::numeric_limits<double>::quiet_NaN();
  thread_local DiagonalZoh<double> last{};
  if (!(rate == last_rate && dt == last_dt)) {
    last_rate = rate;
    last_dt = dt;
    last = diagonal_zoh(rate, dt);
  }
  return last;
}

// last_diagonal_zoh() over the rows of one call, asked again only when a
// row's rate differs from the row before's. Banks give every state one rate,
// and in a plugin loaded at run time each access to a thread_local is a call
// (__tls_get_addr): three per row cost a BorealTC tune 4% of its time.
class RowsZoh {
 public:
  explicit RowsZoh(double dt) noexcept : dt_(dt) {}
  const DiagonalZoh<double>& operator()(double rate) noexcept {
    if (!(rate == rate_)) {  // a NaN rate: every time, as last_diagonal_zoh()
      zoh_ = last_diagonal_zoh(rate, dt_);
      rate_ = rate;
    }
    return zoh_;
  }

 private:
  double dt_;
  double rate_ = std::numeric_limits<double>::quiet_NaN();
  DiagonalZoh<double> zoh_{};
};

template <typename T, typename R, typename W>
T diagonal_zoh_step(const T& x, const R& a, const W& w, double dt) noexcept {
  return diagonal_zoh(a, dt).template step<T>(x, w);
}

// d/da int_0^dt e^{a s} ds = int_0^dt s e^{a s} ds = dt^2 g(a dt) with
// g(z) = (1 + (z - 1) e^z) / z^2 = sum_{k>=2} (k - 1) z^{k-2} / k!, which
// is 1/2 at z = 0. The direct form loses about -log10|z| digits, so below
// |z| = 1 the series is summed instead (25 terms: below 1e-25 there).
inline double exp_integral_derivative(double a, double dt) noexcept {
  const double z = a * dt;
  double g = 0.0;
  if (std::abs(z) < 1.0) {
    double term = 0.5;  // z^{k-2} / k! at k = 2
    for (int k = 2; k < 27; ++k) {
      g += (k - 1) * term;
      term *= z / (k + 1);
    }
  } else {
    g = (z * std::exp(z) - std::expm1(z)) / (z * z);
  }
  return dt * dt * g;
}

// --- Full A ---

namespace internal {

// x+ is linear in w, so the augmented column carries w / ||w||_inf: a large
// input then does not inflate the norm that sets the number of squarings.
inline double column_scale(const ZohVector& w) noexcept {
  const double norm = w.size() > 0 ? w.cwiseAbs().maxCoeff() : 0.0;
  return norm > 0.0 ? norm : 1.0;
}

// dt [[A, w / scale], [0, 0]].
inline ZohAugmentedMatrix augmented(const ZohMatrix& a, const ZohVector& w, double scale, double dt) noexcept {
  const Eigen::Index n = a.rows();
  ZohAugmentedMatrix m = ZohAugmentedMatrix::Zero(n + 1, n + 1);
  m.topLeftCorner(n, n) = a * dt;
  m.topRightCorner(n, 1) = w * (dt / scale);
  return m;
}

// Largest ||A h||_1 of the Van Loan step before doubling (below).
inline constexpr double kVanLoanMaxNorm = 0.5;

}  // namespace internal

// x+ = Phi x + Gamma w from expm(dt [[A, w], [0, 0]]) = [[Phi, Gamma w], [0, 1]].
inline bool zoh_step(const ZohMatrix& a, const ZohVector& x, const ZohVector& w, double dt,
                     ZohVector* x_next) noexcept {
  const Eigen::Index n = a.rows();
  const double scale = internal::column_scale(w);
  ZohAugmentedMatrix exp_m;
  if (!matrix_exponential(internal::augmented(a, w, scale, dt), &exp_m)) return false;
  x_next->noalias() = exp_m.topLeftCorner(n, n) * x;
  *x_next += exp_m.topRightCorner(n, 1) * scale;
  return x_next->allFinite();
}

// Phi = expm(A dt), the exact state Jacobian of zoh_step.
inline bool zoh_transition(const ZohMatrix& a, double dt, ZohMatrix* phi) noexcept {
  return matrix_exponential(ZohMatrix(a * dt), phi);
}

// Gamma = int_0^dt expm(A s) ds, the top-right block of expm(dt [[A, I], [0, 0]]);
// what the input and offset columns need when A is held fixed.
inline bool zoh_gamma(const ZohMatrix& a, double dt, ZohMatrix* gamma) noexcept {
  const Eigen::Index n = a.rows();
  ZohVanLoanMatrix block = ZohVanLoanMatrix::Zero(2 * n, 2 * n);
  block.topLeftCorner(n, n) = a * dt;
  block.topRightCorner(n, n) = ZohMatrix::Identity(n, n) * dt;
  ZohVanLoanMatrix exp_block;
  if (!matrix_exponential(block, &exp_block)) return false;
  *gamma = exp_block.topRightCorner(n, n);
  return gamma->allFinite();
}

// Qd = int_0^dt expm(A s) Q expm(A s)' ds, symmetric.
//
// Van Loan: expm(h [[-A, Q], [0, A']]) = [[., F12], [0, F22]] gives
// Qd(h) = F22' F12. Over a long step of a fast stable A that block holds
// expm(-A dt), which overflows (e^{50 * 15} > DBL_MAX) or loses all digits to
// cancellation. So Van Loan runs on a short step h = dt / 2^s with
// ||A h||_1 <= 1/2, and the doubling
//   Qd(2h) = Qd(h) + Phi(h) Qd(h) Phi(h)',   Phi(2h) = Phi(h)^2
// reaches dt adding positive semidefinite terms only: no cancellation, and
// no overflow unless the system itself grows out of range.
inline bool zoh_process_noise(const ZohMatrix& a, const ZohMatrix& q, double dt, ZohMatrix* qd) noexcept {
  const Eigen::Index n = a.rows();
  // Qd is linear in Q: work with Q / ||Q|| so its size does not set the scaling.
  const double q_norm = one_norm(q);
  if (q_norm == 0.0) {
    qd->setZero(n, n);
    return true;
  }
  const double a_norm = one_norm(a) * dt;
  if (!std::isfinite(a_norm)) return false;
  const int doublings = a_norm > internal::kVanLoanMaxNorm
                            ? static_cast<int>(std::ceil(std::log2(a_norm / internal::kVanLoanMaxNorm)))
                            : 0;
  const double h = std::ldexp(dt, -doublings);
  ZohVanLoanMatrix block = ZohVanLoanMatrix::Zero(2 * n, 2 * n);
  block.topLeftCorner(n, n) = -a * h;
  block.topRightCorner(n, n) = q * (h / q_norm);
  block.bottomRightCorner(n, n) = a.transpose() * h;
  ZohVanLoanMatrix exp_block;
  if (!matrix_exponential(block, &exp_block)) return false;
  ZohMatrix phi = exp_block.bottomRightCorner(n, n).transpose();
  ZohMatrix noise, product;
  noise.noalias() = phi * exp_block.topRightCorner(n, n);
  for (int i = 0; i < doublings; ++i) {
    product.noalias() = phi * noise;
    noise.noalias() += product * phi.transpose();
    product.noalias() = phi * phi;
    phi = product;
  }
  // Symmetrize: the products above are symmetric only to rounding.
  *qd = (noise + noise.transpose()) * (0.5 * q_norm);
  return qd->allFinite();
}

// The derivatives of zoh_step's x+ with respect to A and to w:
//   d_a(k, r n + c) = d x+_k / d A(r, c)   (n x n^2, A row-major),
//   gamma = d x+ / d w = Gamma             (n x n).
// With M = dt [[A, w/s], [0, 0]] and z = [x; s] (s = column_scale(w)),
// x+_k = e_k' expm(M) z, and for E = e_r e_c'
//   d x+_k / d A(r, c) = dt e_k' L(M, E) z
//                      = dt int_0^1 expm(M (1 - tau))_{k r} (expm(M tau) z)_c dtau
//                      = dt L(M', e_k z')_{r c},
// using L(X, E) = int_0^1 expm(X (1 - tau)) E expm(X tau) dtau,
// so one Fréchet derivative per output k (n block exponentials of size
// 2 (n + 1)) gives a whole row of d_a, instead of one per entry of A (n^2).
// Its last column is the derivative with respect to w: Gamma_{k r} =
// (dt / s) L(M', e_k z')_{r n}.
inline bool zoh_step_derivatives(const ZohMatrix& a, const ZohVector& x, const ZohVector& w, double dt,
                                 Eigen::Ref<Eigen::MatrixXd> d_a, ZohMatrix* gamma) noexcept {
  const Eigen::Index n = a.rows();
  const double scale = internal::column_scale(w);
  const ZohAugmentedMatrix m_transposed = internal::augmented(a, w, scale, dt).transpose();
  ZohAugmentedMatrix direction, exp_m, frechet;
  gamma->resize(n, n);
  for (Eigen::Index k = 0; k < n; ++k) {
    direction.setZero(n + 1, n + 1);
    direction.row(k).head(n) = x.transpose();  // e_k z', z = [x; scale]
    direction(k, n) = scale;
    if (!matrix_exponential_frechet(m_transposed, direction, &exp_m, &frechet)) return false;
    for (Eigen::Index r = 0; r < n; ++r) {
      for (Eigen::Index c = 0; c < n; ++c) d_a(k, r * n + c) = dt * frechet(r, c);
      (*gamma)(k, r) = dt / scale * frechet(r, n);
    }
  }
  return d_a.allFinite() && gamma->allFinite();
}

}  // namespace plugins
}  // namespace skidimm

#endif  // SKIDIMM_PLUGINS_LINEAR_FEATURES_ZERO_ORDER_HOLD_H_
