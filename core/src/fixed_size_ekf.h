// The filter of ExtendedKalmanFilter (skidimm/engine/ekf.h) for a state of N
// and a measurement of K components known at compile time, on Eigen
// fixed-size types the caller owns: what the IMM's fixed-size kernels run
// (imm_kernel.h). predict_fixed() and update_fixed() call the model through
// the same three virtuals (jacobian, process_noise, predict, in that order,
// at the prior state) and agree with ExtendedKalmanFilter to round-off
// (tests/core/ekf_test.cc); the kernels may keep the first two's results
// (StepMatrices) for models whose F and Qd depend on dt only.
#ifndef SKIDIMM_CORE_SRC_FIXED_SIZE_EKF_H_
#define SKIDIMM_CORE_SRC_FIXED_SIZE_EKF_H_

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>

#include "all_finite.h"
#include "skidimm/engine/ekf.h"
#include "skidimm/engine/measurement_model.h"
#include "skidimm/sdk/angles.h"
#include "skidimm/sdk/motion_model.h"

namespace skidimm {

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
#pragma GCC unroll 16
  for (int j = 1; j < N; ++j) {
#pragma GCC unroll 16
    for (int i = 0; i < j; ++i) {
      const double mean = 0.5 * ((*m)(i, j) + (*m)(j, i));
      (*m)(i, j) = mean;
      (*m)(j, i) = mean;
    }
  }
}

// A step's F (the model's Jacobian) and Qd (its process noise), with
// whether F is diagonal. Stored in at least two doubles each: GCC 12 sees the
// plugin's packet stores into a 1 x 1 matrix as out of bounds.
template <int N>
struct StepMatrices {
  static constexpr int kStorage = N * N < 2 ? 2 : N * N;
  alignas(16) double f_storage[kStorage];
  alignas(16) double q_storage[kStorage];
  bool diagonal = false;

  Eigen::Map<Eigen::Matrix<double, N, N>> f() { return Eigen::Map<Eigen::Matrix<double, N, N>>(f_storage); }
  Eigen::Map<Eigen::Matrix<double, N, N>> q() { return Eigen::Map<Eigen::Matrix<double, N, N>>(q_storage); }
  Eigen::Map<const Eigen::Matrix<double, N, N>> f() const {
    return Eigen::Map<const Eigen::Matrix<double, N, N>>(f_storage);
  }
  Eigen::Map<const Eigen::Matrix<double, N, N>> q() const {
    return Eigen::Map<const Eigen::Matrix<double, N, N>>(q_storage);
  }
};

// F and Qd of `model` at the prior state for a step of dt; q_intensity is the
// mode's continuous-time Q. False if the model fails.
template <int N>
bool compute_step_matrices(const sdk::MotionModel& model, const Eigen::Matrix<double, N, N>& q_intensity,
                           const Eigen::Ref<const Eigen::VectorXd>& prior, const Eigen::Ref<const Eigen::VectorXd>& u,
                           double dt, StepMatrices<N>* m) {
  {
    Eigen::Ref<Eigen::MatrixXd> f_out(m->f());
    if (!model.jacobian(prior, u, dt, f_out)) return false;
    Eigen::Ref<Eigen::MatrixXd> q_out(m->q());
    if (!model.process_noise(q_intensity, prior, u, dt, q_out)) return false;
  }
  // A diagonal F (decoupled states: linear_features with a diagonal A) scales
  // P's rows and columns: the same two roundings per entry as the products,
  // so the same result to the bit, in n^2 instead of 2 n^3. Worth its check
  // from 5 states on.
  const auto f = m->f();
  bool diagonal = N >= 5;
  for (int j = 0; j < N && diagonal; ++j) {
    for (int i = 0; i < N; ++i) diagonal = diagonal && (i == j || f(i, j) == 0.0);
  }
  m->diagonal = diagonal;
  return true;
}

// Propagates x, P by dt with input u through `model`, given the step's F and
// Qd at the prior state. Returns false if the model fails or the result is
// not finite (x, P are then unspecified).
template <int N>
bool propagate_fixed(const sdk::MotionModel& model, const StepMatrices<N>& m, AngleMask angles,
                     const Eigen::Ref<const Eigen::VectorXd>& u, double dt, Eigen::Matrix<double, N, 1>* x,
                     Eigen::Matrix<double, N, N>* p) {
  alignas(16) double next_storage[N < 2 ? 2 : N];
  Eigen::Map<Eigen::Matrix<double, N, 1>> next(next_storage);
  {
    const Eigen::Ref<const Eigen::VectorXd> prior(*x);
    Eigen::Ref<Eigen::VectorXd> next_out(next);
    if (!model.predict(prior, u, dt, next_out)) return false;
  }
  *x = next;
  wrap_angles_fixed<N>(angles, x);
  const auto f = m.f();
  if (m.diagonal) {
    // (f_ii p_ij) f_jj, a column at a time.
    const Eigen::Matrix<double, N, 1> scale = f.diagonal();
    for (int j = 0; j < N; ++j) p->col(j) = scale.cwiseProduct(p->col(j)) * f(j, j);
  } else if constexpr (N <= 4) {
    const Eigen::Matrix<double, N, N> fp = f * *p;
    p->noalias() = fp * f.transpose();
  } else {
    // Coefficient by coefficient: from 8 Eigen would take these for large
    // products and pack them for its blocked kernel.
    const Eigen::Matrix<double, N, N> fp = f.lazyProduct(*p);
    p->noalias() = fp.lazyProduct(f.transpose());
  }
  *p += m.q();
  symmetrize_fixed<N>(p);
  return internal::all_finite(*x) && internal::all_finite(*p);
}

// Propagates x, P by dt with input u through `model`; q_intensity is the
// mode's continuous-time Q. F and Qd are evaluated at the prior state, before
// x is overwritten. Returns false if the model fails or the result is not
// finite (x, P are then unspecified).
template <int N>
bool predict_fixed(const sdk::MotionModel& model, const Eigen::Matrix<double, N, N>& q_intensity, AngleMask angles,
                   const Eigen::Ref<const Eigen::VectorXd>& u, double dt, Eigen::Matrix<double, N, 1>* x,
                   Eigen::Matrix<double, N, N>* p) {
  StepMatrices<N> m;
  return compute_step_matrices<N>(model, q_intensity, *x, u, dt, &m) &&
         propagate_fixed<N>(model, m, angles, u, dt, x, p);
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
// above `gate` is not applied (result.gated). `whitened_innovation`, when
// given, receives L^-1 nu (S = L L').
//
// `h_is_identity`: H is I (K = N, every state measured directly, as the
// bundled banks' are when every row is present). The products with H are
// then copies and I - K H is I - K: the same numbers as the products (each
// sums one exact term and exact zeros; at most the sign of a zero differs),
// for about a third of a 3-state update's products.
template <int N, int K>
UpdateResult update_fixed(const Eigen::Matrix<double, K, 1>& z, const Eigen::Matrix<double, K, N>& h,
                          const Eigen::Matrix<double, K, K>& r, AngleMask z_angles, AngleMask state_angles,
                          Eigen::Matrix<double, N, 1>* x, Eigen::Matrix<double, N, N>* p,
                          double gate = std::numeric_limits<double>::infinity(),
                          Eigen::Matrix<double, K, 1>* whitened_innovation = nullptr, bool h_is_identity = false) {
  constexpr double kLog2Pi = 1.8378770664093454835606594728112;
  UpdateResult result;
  Eigen::Matrix<double, K, 1> nu = z;
  Eigen::Matrix<double, K, N> hp;
  Eigen::Matrix<double, K, K> s = r;
  bool identity = false;
  if constexpr (K == N) {
    identity = h_is_identity;
    if (identity) {
      nu -= *x;
      hp = *p;
      s += *p;
    }
  }
  if (!identity) {
    nu.noalias() -= h * *x;
    hp.noalias() = h * *p;
    s.noalias() += hp * h.transpose();
  }
  wrap_angles_fixed<K>(z_angles, &nu);
  symmetrize_fixed<K>(&s);
  // In-place Cholesky: S = L L'.
  Eigen::Matrix<double, K, 1> inverse_diagonal;
  if (!cholesky_in_place<K>(&s, &inverse_diagonal)) return result;
  Eigen::Matrix<double, K, 1> whitened = nu;
  forward_substitute<K, 1>(s, inverse_diagonal, &whitened);  // L^-1 nu
  result.nis = whitened.squaredNorm();                       // nu' S^-1 nu
  if (whitened_innovation != nullptr) *whitened_innovation = whitened;
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
  if constexpr (K == N) {
    if (identity) i_kh -= gain;
  }
  if (!identity) i_kh.noalias() -= gain * h;
  const Eigen::Matrix<double, N, N> ikh_p = i_kh * *p;
  p->noalias() = ikh_p * i_kh.transpose();
  const Eigen::Matrix<double, N, K> kr = gain * r;
  p->noalias() += kr * gain.transpose();
  symmetrize_fixed<N>(p);
  result.ok = std::isfinite(result.log_likelihood) && internal::all_finite(*x) && internal::all_finite(*p);
  return result;
}

// ------------------------------------------- fixed states, any measurement rows

// Workspace of update_selected() for N states and measurements of up to m
// rows: sized once, so updates allocate nothing.
template <int N>
struct SelectedUpdateWorkspace {
  using Columns = Eigen::Matrix<double, N, Eigen::Dynamic>;
  explicit SelectedUpdateWorkspace(int m) : gain(N, m), kr(N, m), s(m, m), nu(m), whitened(m), inverse_diagonal(m) {}
  Columns gain;              // P- H', then W = P- H' L'^-1 (S = L L'), then K = W L^-1 for the Joseph form (N x k)
  Columns kr;                // K R (N x k), the Joseph form's
  Eigen::MatrixXd s;         // S, then its Cholesky factor (k x k)
  Eigen::VectorXd nu;        // the innovation (k)
  Eigen::VectorXd whitened;  // L^-1 nu (k), left for the caller (correlated innovations read it)
  Eigen::VectorXd inverse_diagonal;   // the reciprocals of L's diagonal (k)
  Eigen::Matrix<double, N, N> i_kh;   // I - K H, the Joseph form's
  Eigen::Matrix<double, N, N> ikh_p;  // (I - K H) P-, the Joseph form's
};

// update_selected() keeps P- - W W' where the measurement leaves every
// variance more than 2^-26 of its prior: the subtraction, whose round-off is
// about eps P-_ii / P+_ii relative to P+_ii, then keeps at least half of
// double's 52 bits. A measurement more precise than that against the
// prediction (a bank's 1e-15 next to 1e15) gets the Joseph form, whose
// round-off does not grow with the ratio and which stays positive.
inline constexpr double kLeastRemainingVariance = 1.0 / (1 << 26);

// P+ = (I - K H) P- (I - K H)' + K R K' (Joseph form) for update_selected(),
// from W = P- H' L'^-1 in *gain (N x k) and S's Cholesky factor L in `l`
// (lower triangle, reciprocal diagonal in `inverse_diagonal`); *gain ends as K.
template <int N, typename Gain, typename Factor, typename Diagonal>
void joseph_update(const SelectedMeasurement& m, int k, const Factor& l, const Diagonal& inverse_diagonal,
                   Gain* gain_io, Eigen::Matrix<double, N, N>* p, SelectedUpdateWorkspace<N>* w) {
  Gain& gain = *gain_io;
  // K L = W, a column at a time.
  for (int c = k - 1; c >= 0; --c) {
    for (int a = c + 1; a < k; ++a) gain.col(c) -= gain.col(a) * l(a, c);
    gain.col(c) *= inverse_diagonal[c];
  }
  auto& i_kh = w->i_kh;
  i_kh.setIdentity();
  for (int a = 0; a < k; ++a) {
    if (m.picks_states) {
      i_kh.col(m.picked_state[static_cast<std::size_t>(a)]) -= gain.col(a);
    } else {
      for (int j = 0; j < N; ++j) i_kh.col(j) -= gain.col(a) * m.h(a, j);
    }
  }
  auto& kr = w->kr;
  for (int b = 0; b < k; ++b) {
    kr.col(b) = gain.col(b) * m.r(b, b);
    for (int a = 0; a < k; ++a) {
      const double r_ab = m.r(a, b);
      if (a != b && r_ab != 0.0) kr.col(b) += gain.col(a) * r_ab;  // none for a diagonal R, the common case
    }
  }
  // Column by column, each held in registers while its sum runs.
  auto& ikh_p = w->ikh_p;
  for (int j = 0; j < N; ++j) {
    Eigen::Matrix<double, N, 1> column = i_kh.col(0) * (*p)(0, j);
    for (int c = 1; c < N; ++c) column += i_kh.col(c) * (*p)(c, j);
    ikh_p.col(j) = column;
  }
  for (int j = 0; j < N; ++j) {
    Eigen::Matrix<double, N, 1> column = ikh_p.col(0) * i_kh(j, 0);
    for (int c = 1; c < N; ++c) column += ikh_p.col(c) * i_kh(j, c);
    for (int a = 0; a < k; ++a) column += kr.col(a) * gain(j, a);
    p->col(j) = column;
  }
  symmetrize_fixed<N>(p);
}

// Column j of P- - W W' from row j down (the N - j entries of the lower
// triangle), held in registers while its k products are subtracted in
// order; true if the difference keeps more than kLeastRemainingVariance of
// the variance P-_jj (the share the measurement explains is cancelled).
template <int N, int K, int J, typename Gain>
bool subtract_outer_product_column(const Eigen::Matrix<double, N, N>& p, const Gain& w, int rows,
                                   Eigen::Matrix<double, N, N>* updated) {
  constexpr int kRows = N - J;
  const int k = K > 0 ? K : rows;
  // Maps of the columns' tails, rather than blocks of p, w and *updated:
  // their types depend on the length alone, so the N lengths are N sets of
  // Eigen expression types shared by every N, K and gain storage, where
  // blocks made a set for each (which made this function most of the time
  // the compiler spent instantiating update_selected()). The same packets
  // either way.
  // (Eigen stores a gain of one row, N = 1, row-major: its columns are one
  // entry each.)
  static_assert(N == 1 || (!Gain::IsRowMajor && Gain::InnerStrideAtCompileTime == 1),
                "a column of the gain must be contiguous for its tail to be mapped");
  using Column = Eigen::Matrix<double, kRows, 1>;
  Column column = Eigen::Map<const Column>(&p(J, J));
  for (int a = 0; a < k; ++a) column -= Eigen::Map<const Column>(&w(J, a)) * w(J, a);
  Eigen::Map<Column>(&(*updated)(J, J)) = column;
  return column[0] > kLeastRemainingVariance * p(J, J);
}

// The lower triangle of P- - W W' into *updated, a column of compile-time
// length at a time (half the products of whole columns at 9 states); whether
// every variance stays well conditioned.
template <int N, int K, typename Gain, int... J>
bool subtract_outer_product_lower(const Eigen::Matrix<double, N, N>& p, const Gain& w, int k,
                                  Eigen::Matrix<double, N, N>* updated, std::integer_sequence<int, J...>) {
  // Every column, without stopping at the first ill-conditioned one.
  return (static_cast<int>(subtract_outer_product_column<N, K, J>(p, w, k, updated)) & ... & 1) != 0;
}

// The update of update_fixed() for N states known at compile time and the k
// rows of `m` (MeasurementModel::select()), any k: what the IMM runs for
// banks of more than 4 states or measurement rows (BorealTC's 9 features,
// stc_traction's 3 states and 6 rows). Everything of size N is a column of
// fixed size (the compiler unrolls and vectorizes it), each sum in index
// order. The covariance is updated as P- - W W' with W = P- H' L'^-1 (S =
// L L'), a third of the Joseph form's products at 9 states (the update is
// where a BorealTC tune spends most of its time); the Joseph form is kept for
// measurements that explain nearly all of a variance (kLeastRemainingVariance,
// joseph_update()). Agrees with ExtendedKalmanFilter's Joseph form to
// round-off (tests/core/ekf_test.cc).
//
// K > 0: the rows are K, known at compile time: loops of fixed length over
// matrices of fixed size on the stack, which the compiler keeps in registers
// (a store into a heap workspace could alias every pointer, so it reloads
// them). The triangular loops (S, its factor, the solves) are unrolled whole
// (#pragma GCC unroll): once the outer index is a constant, so is every
// inner bound, and the loop overhead of the short inner sums goes. 0: m.size
// rows, over the workspace. The same operations in the same order either way.
template <int N, int K>
UpdateResult update_selected_rows(const SelectedMeasurement& m, AngleMask state_angles, Eigen::Matrix<double, N, 1>* x,
                                  Eigen::Matrix<double, N, N>* p, SelectedUpdateWorkspace<N>* w, double gate);

// update_selected_rows()'s steps over the storage it gives: `gain` (N x k:
// P- H', then W), `s` (k x k: S, then L), `nu`, `inverse_diagonal` (k), and
// `whitened` (k: L^-1 nu, always the workspace's, which the caller reads).
template <int N, int K, typename Gain, typename Square, typename Vector>
UpdateResult update_rows_in(const SelectedMeasurement& m, AngleMask state_angles, Eigen::Matrix<double, N, 1>* x,
                            Eigen::Matrix<double, N, N>* p, SelectedUpdateWorkspace<N>* w, double gate, Gain& gain,
                            Square& s, Vector& nu, Eigen::VectorXd& whitened, Vector& inverse_diagonal) {
  constexpr double kLog2Pi = 1.8378770664093454835606594728112;
  UpdateResult result;
  const int k = K > 0 ? K : m.size;
  if (k == 0) {
    result.ok = true;
    return result;
  }
  const bool picks = m.picks_states;
  // nu = z - H x;  P- H' (into gain);  S = H P- H' + R.
  for (int a = 0; a < k; ++a) {
    double predicted = 0.0;
    if (picks) {
      const int picked = m.picked_state[static_cast<std::size_t>(a)];
      predicted = (*x)[picked];
      gain.col(a) = p->col(picked);
    } else {
      for (int i = 0; i < N; ++i) predicted += m.h(a, i) * (*x)[i];
      gain.col(a).setZero();
      for (int i = 0; i < N; ++i) gain.col(a) += p->col(i) * m.h(a, i);
    }
    const double v = m.z[a] - predicted;
    nu[a] = m.is_angle[static_cast<std::size_t>(a)] ? wrap_angle_fast(v) : v;
  }
#pragma GCC unroll 16
  for (int b = 0; b < k; ++b) {
#pragma GCC unroll 16
    for (int a = b; a < k; ++a) {
      double hph = 0.0;
      if (picks) {
        hph = gain(m.picked_state[static_cast<std::size_t>(a)], b);
      } else {
        for (int i = 0; i < N; ++i) hph += m.h(a, i) * gain(i, b);
      }
      s(a, b) = hph + 0.5 * (m.r(a, b) + m.r(b, a));
    }
  }
#pragma GCC unroll 16
  // In-place Cholesky of the lower triangle, S = L L', with L's reciprocal diagonal.
  for (int j = 0; j < k; ++j) {
    double pivot = s(j, j);
    for (int c = 0; c < j; ++c) pivot -= s(j, c) * s(j, c);
    if (!(pivot > 0.0)) return result;
    pivot = std::sqrt(pivot);
    s(j, j) = pivot;
    const double inverse = 1.0 / pivot;
    inverse_diagonal[j] = inverse;
#pragma GCC unroll 16
    for (int i = j + 1; i < k; ++i) {
      double v = s(i, j);
      for (int c = 0; c < j; ++c) v -= s(i, c) * s(j, c);
      s(i, j) = v * inverse;
    }
  }
  // NIS = |L^-1 nu|^2, log det S = 2 sum log L_aa (one log of the product
  // while it is inside double's range, as update_fixed()).
  result.nis = 0.0;
#pragma GCC unroll 16
  for (int a = 0; a < k; ++a) {
    double v = nu[a];
    for (int c = 0; c < a; ++c) v -= s(a, c) * whitened[c];
    whitened[a] = v * inverse_diagonal[a];
    result.nis += whitened[a] * whitened[a];
  }
  double product = 1.0;
  for (int a = 0; a < k; ++a) product *= s(a, a);
  double log_det = 0.0;
  if (product > 1e-280 && product < 1e280) {
    log_det = std::log(product);
  } else {
    for (int a = 0; a < k; ++a) log_det += std::log(s(a, a));
  }
  if (result.nis > gate) {
    result.gated = true;
    result.log_likelihood = -0.5 * (gate + 2.0 * log_det + k * kLog2Pi);
    result.ok = std::isfinite(result.log_likelihood);
    return result;
  }
  result.log_likelihood = -0.5 * (result.nis + 2.0 * log_det + k * kLog2Pi);
#pragma GCC unroll 16
  // W = P- H' L'^-1, solved in place a column at a time (W L' = P- H'). The
  // gain is K = P- H' S^-1 = W L^-1, so K nu = W (L^-1 nu) and K S K' = W W'.
  // Each column is held in registers while its sum runs.
  for (int a = 0; a < k; ++a) {
    Eigen::Matrix<double, N, 1> column = gain.col(a);
    for (int c = 0; c < a; ++c) column -= gain.col(c) * s(a, c);
    gain.col(a) = column * inverse_diagonal[a];
  }
  const auto& half_gain = gain;  // W
  // x+ = x- + W L^-1 nu.
  Eigen::Matrix<double, N, 1> updated_state = *x;
  for (int a = 0; a < k; ++a) updated_state += half_gain.col(a) * whitened[a];
  *x = updated_state;
  wrap_angles_fixed<N>(state_angles, x);
  // P+ = P- - W W' (= P- - K S K'), its lower triangle column by column:
  // about N^2 k / 2 products where the Joseph form takes 2 N^3. Entry (i, j)
  // would subtract the same products in the same order as (j, i), so the
  // lower triangle copied up is the whole difference, exactly symmetric.
  Eigen::Matrix<double, N, N> updated;
  const bool well_conditioned =
      subtract_outer_product_lower<N, K>(*p, half_gain, k, &updated, std::make_integer_sequence<int, N>());
  if (well_conditioned) {
    for (int j = 1; j < N; ++j) {
      for (int i = 0; i < j; ++i) updated(i, j) = updated(j, i);
    }
    *p = updated;
  } else {
    joseph_update(m, k, s, inverse_diagonal, &gain, p, w);
  }
  result.ok = std::isfinite(result.log_likelihood) && internal::all_finite(*x) && internal::all_finite(*p);
  return result;
}

template <int N, int K>
UpdateResult update_selected_rows(const SelectedMeasurement& m, AngleMask state_angles, Eigen::Matrix<double, N, 1>* x,
                                  Eigen::Matrix<double, N, N>* p, SelectedUpdateWorkspace<N>* w, double gate) {
  if constexpr (K > 0) {
    Eigen::Matrix<double, N, K> gain;
    Eigen::Matrix<double, K, K> s;
    Eigen::Matrix<double, K, 1> nu, inverse_diagonal;
    return update_rows_in<N, K>(m, state_angles, x, p, w, gate, gain, s, nu, w->whitened, inverse_diagonal);
  } else {
    return update_rows_in<N, K>(m, state_angles, x, p, w, gate, w->gain, w->s, w->nu, w->whitened, w->inverse_diagonal);
  }
}

// update_selected_rows() for any k, with loops of fixed length when every
// row is measured (k = N, BorealTC's features measured directly).
template <int N>
UpdateResult update_selected(const SelectedMeasurement& m, AngleMask state_angles, Eigen::Matrix<double, N, 1>* x,
                             Eigen::Matrix<double, N, N>* p, SelectedUpdateWorkspace<N>* w,
                             double gate = std::numeric_limits<double>::infinity()) {
  if (m.size == N) return update_selected_rows<N, N>(m, state_angles, x, p, w, gate);
  return update_selected_rows<N, 0>(m, state_angles, x, p, w, gate);
}

}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_FIXED_SIZE_EKF_H_
