// X = A^-1 B in place from Eigen's LDLT of A, for matrices of up to 4 x 4: the
// smoother's gain J' = (P^ji)^-1 F P, 16^2 times a step for a 16-mode bank.
// Private to the engine.
#ifndef SKIDIMM_CORE_SRC_LDLT_SOLVE_H_
#define SKIDIMM_CORE_SRC_LDLT_SOLVE_H_

#include <Eigen/Cholesky>
#include <cmath>
#include <limits>

namespace skidimm {
namespace internal {

// *b = A^-1 *b, from `ldlt` = LDLT(A) (P' L D L' P = A), in the operations
// and order of Eigen's LDLT::solve (Eigen/src/Cholesky/LDLT.h): P B, the unit
// lower solve column-oriented, D's pseudo-inverse (a pivot at or below the
// smallest normal double gives 0), the unit upper solve row-oriented (each
// row's sum of the known components, then subtracted), P' X. Eigen sends
// even a fixed 3 x 3 right-hand side through its general blocked triangular
// solver, packing included, which was a tenth of a 16-mode bank's smoothing;
// these loops unroll at fixed sizes and allocate nothing. The same to the bit
// up to 4 x 4 (tests/core/ldlt_solve_test.cc), where Eigen's solver works on
// one panel; on larger matrices its blocked update sums in another order.
template <typename Ldlt, typename Matrix>
void ldlt_solve_in_place(const Ldlt& ldlt, Eigen::MatrixBase<Matrix>* b) {
  Eigen::MatrixBase<Matrix>& x = *b;
  const auto& factors = ldlt.matrixLDLT();  // L below the diagonal, D on it
  const auto& transpositions = ldlt.transpositionsP();
  const Eigen::Index n = x.rows();
  for (Eigen::Index k = 0; k < n; ++k) {
    const Eigen::Index j = transpositions.coeff(k);
    if (j != k) x.row(k).swap(x.row(j));
  }
  for (Eigen::Index c = 0; c < x.cols(); ++c) {
    for (Eigen::Index k = 0; k < n; ++k) {
      const double known = x(k, c);
      for (Eigen::Index i = k + 1; i < n; ++i) x(i, c) -= known * factors(i, k);
    }
    for (Eigen::Index i = 0; i < n; ++i) {
      const double d = factors(i, i);
      x(i, c) = std::abs(d) > std::numeric_limits<double>::min() ? x(i, c) / d : 0.0;
    }
    for (Eigen::Index i = n - 1; i >= 0; --i) {
      double known = 0.0;
      for (Eigen::Index m = i + 1; m < n; ++m) known += factors(m, i) * x(m, c);
      x(i, c) -= known;
    }
  }
  for (Eigen::Index k = n - 1; k >= 0; --k) {
    const Eigen::Index j = transpositions.coeff(k);
    if (j != k) x.row(k).swap(x.row(j));
  }
}

}  // namespace internal
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_LDLT_SOLVE_H_
