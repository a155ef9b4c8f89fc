// The matrix exponential and its Fréchet derivative, without heap allocation.
//
// matrix_exponential(A) is Higham's scaling and squaring with a diagonal Padé
// approximant of degree 3, 5, 7, 9 or 13 chosen from ||A||_1 (N. J. Higham,
// "The scaling and squaring method for the matrix exponential revisited",
// SIAM J. Matrix Anal. Appl. 26(4), 2005, Algorithm 2.3, also behind Eigen's
// unsupported MatrixFunctions): degree and scaling are chosen so that, in
// exact arithmetic, the approximant's backward error is at most the unit
// roundoff relative to ||A||.
//
// matrix_exponential_frechet(X, E) is L(X, E) = d/dh expm(X + h E) at h = 0,
// the upper-right block of expm([[X, E], [0, X]]) (Higham, "Functions of
// Matrices", SIAM 2008, Theorem 3.6 / eq. 10.15).
//
// Every matrix is an Eigen matrix with a dynamic size and a compile-time
// maximum, BoundedMatrix<kMaxSize>: it lives on the stack, so the filter's
// hot path never touches the heap. The stack cost is about 12 matrices of
// kMaxSize^2 doubles (kMaxSize = 26: about 65 KB).
#ifndef SKIDIMM_PLUGINS_LINEAR_FEATURES_MATRIX_EXPONENTIAL_H_
#define SKIDIMM_PLUGINS_LINEAR_FEATURES_MATRIX_EXPONENTIAL_H_

#include <Eigen/Core>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>

namespace skidimm {
namespace plugins {

template <int kMaxSize>
using BoundedMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxSize, kMaxSize>;

// Maximum absolute column sum, the norm Higham's degree thresholds use.
template <typename Derived>
double one_norm(const Eigen::MatrixBase<Derived>& a) noexcept {
  double norm = 0.0;
  for (Eigen::Index c = 0; c < a.cols(); ++c) norm = std::fmax(norm, a.col(c).cwiseAbs().sum());
  return norm;
}

namespace internal {

// theta_m: the largest ||A||_1 for which the degree-m Padé approximant is
// accurate to the unit roundoff (Higham 2005, Table 2.3).
inline constexpr double kPadeTheta3 = 1.495585217958292e-2;
inline constexpr double kPadeTheta5 = 2.539398330063230e-1;
inline constexpr double kPadeTheta7 = 9.504178996162932e-1;
inline constexpr double kPadeTheta9 = 2.097847961257068e0;
inline constexpr double kPadeTheta13 = 5.371920351148152e0;

// Numerator coefficients b_0..b_m of the [m/m] Padé approximant of exp; the
// denominator is the numerator at -A (Higham 2005, eq. 2.4 and Algorithm 2.3).
inline constexpr double kPade3[] = {120.0, 60.0, 12.0, 1.0};
inline constexpr double kPade5[] = {30240.0, 15120.0, 3360.0, 420.0, 30.0, 1.0};
inline constexpr double kPade7[] = {17297280.0, 8648640.0, 1995840.0, 277200.0, 25200.0, 1512.0, 56.0, 1.0};
inline constexpr double kPade9[] = {17643225600.0, 8821612800.0, 2075673600.0, 302702400.0, 30270240.0,
                                    2162160.0,     110880.0,     3960.0,       90.0,        1.0};
inline constexpr double kPade13[] = {64764752532480000.0,
                                     32382376266240000.0,
                                     7771770303897600.0,
                                     1187353796428800.0,
                                     129060195264000.0,
                                     10559470521600.0,
                                     670442572800.0,
                                     33522128640.0,
                                     1323241920.0,
                                     40840800.0,
                                     960960.0,
                                     16380.0,
                                     182.0,
                                     1.0};

// U (odd part) and V (even part) of the degree-m numerator, m in {3, 5, 7, 9}:
//   U = A sum_k b_{2k+1} A^{2k},  V = sum_k b_{2k} A^{2k}.
template <int kMaxSize>
void pade_low_degree(const BoundedMatrix<kMaxSize>& a, const double* b, int degree, BoundedMatrix<kMaxSize>* u,
                     BoundedMatrix<kMaxSize>* v) noexcept {
  using Matrix = BoundedMatrix<kMaxSize>;
  const Eigen::Index n = a.rows();
  Matrix a2, power, odd;
  a2.noalias() = a * a;
  power = a2;
  odd = b[1] * Matrix::Identity(n, n) + b[3] * a2;
  *v = b[0] * Matrix::Identity(n, n) + b[2] * a2;
  for (int k = 4; k <= degree; k += 2) {  // power = A^k
    Matrix next;
    next.noalias() = power * a2;
    power = next;
    *v += b[k] * power;
    odd += b[k + 1] * power;
  }
  u->noalias() = a * odd;
}

// The degree-13 U and V with the six products of Higham 2005, eq. 2.4.
template <int kMaxSize>
void pade13(const BoundedMatrix<kMaxSize>& a, BoundedMatrix<kMaxSize>* u, BoundedMatrix<kMaxSize>* v) noexcept {
  using Matrix = BoundedMatrix<kMaxSize>;
  const double* b = kPade13;
  const Eigen::Index n = a.rows();
  Matrix a2, a4, a6, inner, odd;
  a2.noalias() = a * a;
  a4.noalias() = a2 * a2;
  a6.noalias() = a4 * a2;
  inner = b[13] * a6 + b[11] * a4 + b[9] * a2;
  odd.noalias() = a6 * inner;
  odd += b[7] * a6 + b[5] * a4 + b[3] * a2 + b[1] * Matrix::Identity(n, n);
  u->noalias() = a * odd;
  inner = b[12] * a6 + b[10] * a4 + b[8] * a2;
  v->noalias() = a6 * inner;
  *v += b[6] * a6 + b[4] * a4 + b[2] * a2 + b[0] * Matrix::Identity(n, n);
}

}  // namespace internal

// *result = expm(a) for a square `a`. Returns false if `a` or the result is
// not finite (an unstable system over a long step overflows).
template <int kMaxSize>
bool matrix_exponential(const BoundedMatrix<kMaxSize>& a, BoundedMatrix<kMaxSize>* result) noexcept {
  using Matrix = BoundedMatrix<kMaxSize>;
  const double norm = one_norm(a);
  if (!a.allFinite() || !std::isfinite(norm)) return false;
  Matrix u, v;
  int squarings = 0;
  if (norm <= internal::kPadeTheta3) {
    internal::pade_low_degree(a, internal::kPade3, 3, &u, &v);
  } else if (norm <= internal::kPadeTheta5) {
    internal::pade_low_degree(a, internal::kPade5, 5, &u, &v);
  } else if (norm <= internal::kPadeTheta7) {
    internal::pade_low_degree(a, internal::kPade7, 7, &u, &v);
  } else if (norm <= internal::kPadeTheta9) {
    internal::pade_low_degree(a, internal::kPade9, 9, &u, &v);
  } else {
    // Scale by an exact power of two so that ||A / 2^s||_1 <= theta_13 (s >= 0:
    // between theta_9 and theta_13 degree 13 needs no scaling).
    squarings = std::max(0, static_cast<int>(std::ceil(std::log2(norm / internal::kPadeTheta13))));
    const Matrix scaled = a * std::ldexp(1.0, -squarings);
    internal::pade13(scaled, &u, &v);
  }
  // r_m(A) = (V - U)^{-1} (V + U), by an LU solve, never an inverse.
  const Matrix denominator = v - u;
  const Eigen::PartialPivLU<Matrix> lu(denominator);
  const Matrix numerator = v + u;
  *result = lu.solve(numerator);
  for (int i = 0; i < squarings; ++i) {
    Matrix squared;
    squared.noalias() = *result * *result;
    *result = squared;
  }
  return result->allFinite();
}

// *exp_x = expm(x) and *derivative = L(x, e), the Fréchet derivative of expm
// at x in the direction e (both square, the same size, 2 * size <= kMaxBlock).
// L is linear in e, so e is rescaled to the norm of x before the block
// exponential: the number of squarings then follows x alone.
template <int kMaxSize, int kMaxBlock = 2 * kMaxSize>
bool matrix_exponential_frechet(const BoundedMatrix<kMaxSize>& x, const BoundedMatrix<kMaxSize>& e,
                                BoundedMatrix<kMaxSize>* exp_x, BoundedMatrix<kMaxSize>* derivative) noexcept {
  static_assert(kMaxBlock >= 2 * kMaxSize, "the block matrix [[X, E], [0, X]] is twice the size of X");
  const Eigen::Index n = x.rows();
  const double e_norm = one_norm(e);
  if (e_norm == 0.0 || !std::isfinite(e_norm)) {
    derivative->setZero(n, n);
    return e_norm == 0.0 && matrix_exponential(x, exp_x);
  }
  const double x_norm = one_norm(x);
  const double scale = (x_norm > 0.0 ? x_norm : 1.0) / e_norm;
  BoundedMatrix<kMaxBlock> block = BoundedMatrix<kMaxBlock>::Zero(2 * n, 2 * n);
  block.topLeftCorner(n, n) = x;
  block.topRightCorner(n, n) = e * scale;
  block.bottomRightCorner(n, n) = x;
  BoundedMatrix<kMaxBlock> exp_block;
  if (!matrix_exponential(block, &exp_block)) return false;
  *exp_x = exp_block.topLeftCorner(n, n);
  *derivative = exp_block.topRightCorner(n, n) / scale;
  return derivative->allFinite();
}

}  // namespace plugins
}  // namespace skidimm

#endif  // SKIDIMM_PLUGINS_LINEAR_FEATURES_MATRIX_EXPONENTIAL_H_
