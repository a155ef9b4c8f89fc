// Student-t scoring of a mode's innovation, for the mode probabilities
// (`likelihood_dof` in a bank, docs/engine.md "Heavy-tailed likelihood").
//
// A mode's filter scores its innovation nu (k components, covariance S) with
// the Gaussian density. Under the Student-t density with nu_t degrees of
// freedom and scale S,
//
//   log t(nu) = lgamma((nu_t + k)/2) - lgamma(nu_t/2) - k/2 log(nu_t pi)
//               - 1/2 log det S - (nu_t + k)/2 log(1 + d2/nu_t),    d2 = nu' S^-1 nu,
//
// whose -1/2 log det S is that of the Gaussian density. So the Student-t value
// follows from the Gaussian one and d2 alone:
//
//   log t = log N + d2/2 - (nu_t + k)/2 log1p(d2/nu_t)
//           + lgamma((nu_t + k)/2) - lgamma(nu_t/2) - k/2 log(nu_t/2).
//
// Why: the Gaussian log density falls with d2 without bound, so when every
// mode explains a step badly (a run unlike any the modes were fitted on, a
// bump) the mode whose prediction is least wrong wins by a margin that grows
// with the square of the miss, and one such step can make the filter sure of
// it. The Student-t density falls only with log d2: a mode far off is scored
// as far off, but being farther off costs little more. Near the prediction
// the two agree (as nu_t grows, log t -> log N). Each mode's state update is
// the Kalman update as before; only the evidence that moves the mode
// probabilities changes. Private to the engine.
#ifndef SKIDIMM_CORE_SRC_STUDENT_T_LIKELIHOOD_H_
#define SKIDIMM_CORE_SRC_STUDENT_T_LIKELIHOOD_H_

#include <cmath>
#include <vector>

namespace skidimm {
namespace internal {

class StudentTLikelihood {
 public:
  // dof: the degrees of freedom nu_t > 0, or 0 for the Gaussian density (no
  // change). max_components: the most innovation components a step can have.
  StudentTLikelihood(double dof, int max_components) : dof_(dof) {
    if (dof_ <= 0.0) return;
    constant_.resize(static_cast<std::size_t>(max_components) + 1);
    for (int k = 0; k <= max_components; ++k) {
      constant_[static_cast<std::size_t>(k)] =
          std::lgamma(0.5 * (dof_ + k)) - std::lgamma(0.5 * dof_) - 0.5 * k * std::log(0.5 * dof_);
    }
  }

  bool gaussian() const { return dof_ <= 0.0; }

  // The Student-t log density of an innovation of k components whose
  // Gaussian log density is `gaussian` at squared Mahalanobis distance d2.
  double operator()(double gaussian, double d2, int k) const {
    if (gaussian_or_empty(k)) return gaussian;
    return gaussian + 0.5 * d2 - 0.5 * (dof_ + k) * std::log1p(d2 / dof_) + constant_[static_cast<std::size_t>(k)];
  }

 private:
  bool gaussian_or_empty(int k) const { return dof_ <= 0.0 || k <= 0; }

  double dof_;
  std::vector<double> constant_;  // per k, the terms that do not depend on d2
};

}  // namespace internal
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_STUDENT_T_LIKELIHOOD_H_
