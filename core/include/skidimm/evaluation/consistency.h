// Filter consistency: is the normalized innovation squared (NIS) of a mode's
// filter, while that mode is in effect, what its covariances claim?
//
// For a consistent filter each NIS is chi-square with as many degrees of
// freedom as measured components, so the sum over N steps with total dof D is
// chi-square(D); the mean per dof should lie within the 95% interval
// [chi2_{0.025}(D) / D, chi2_{0.975}(D) / D]. Above it the filter is
// overconfident (its covariance too small), below it underconfident.
#ifndef SKIDIMM_EVALUATION_CONSISTENCY_H_
#define SKIDIMM_EVALUATION_CONSISTENCY_H_

namespace skidimm {
namespace evaluation {

// Quantile p of the chi-square distribution with k degrees of freedom
// (Wilson-Hilferty; within 1% of the exact value for k >= 5).
double chi_square_quantile(double p, double degrees_of_freedom);

struct NisAccumulator {
  double sum = 0.0;  // sum of NIS
  double dof = 0.0;  // sum of measured components
  long steps = 0;

  void add(double nis, int measured) {
    sum += nis;
    dof += measured;
    ++steps;
  }
  void merge(const NisAccumulator& o) {
    sum += o.sum;
    dof += o.dof;
    steps += o.steps;
  }
  double mean_per_dof() const { return dof > 0 ? sum / dof : 0.0; }
  double lower_bound() const { return dof > 0 ? chi_square_quantile(0.025, dof) / dof : 0.0; }
  double upper_bound() const { return dof > 0 ? chi_square_quantile(0.975, dof) / dof : 0.0; }
  // "consistent", "overconfident" (NIS too large) or "underconfident".
  const char* verdict() const;
};

}  // namespace evaluation
}  // namespace skidimm

#endif  // SKIDIMM_EVALUATION_CONSISTENCY_H_
