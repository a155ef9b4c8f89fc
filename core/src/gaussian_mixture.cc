#include "gaussian_mixture.h"

#include "skidimm/sdk/angles.h"

namespace skidimm {

void weighted_mean(const std::vector<bool>& angle_mask, const Eigen::Ref<const Eigen::VectorXd>& weights,
                   const Eigen::Ref<const Eigen::MatrixXd>& means, Eigen::Ref<Eigen::VectorXd> mean,
                   Eigen::Ref<Eigen::MatrixXd> deviations) {
  const Eigen::Index n = means.rows();
  Eigen::Index heaviest = 0;
  weights.maxCoeff(&heaviest);
  for (Eigen::Index d = 0; d < n; ++d) {
    if (angle_mask[static_cast<std::size_t>(d)]) {
      // Average the wrapped offsets from the heaviest component's angle.
      const double reference = means(d, heaviest);
      double offset = 0.0;
      for (Eigen::Index i = 0; i < weights.size(); ++i) {
        offset += weights[i] * sdk::wrap_angle(means(d, i) - reference);
      }
      mean[d] = sdk::wrap_angle(reference + offset);
      for (Eigen::Index i = 0; i < weights.size(); ++i) {
        deviations(d, i) = sdk::wrap_angle(means(d, i) - mean[d]);
      }
    } else {
      mean[d] = means.row(d).dot(weights);
      deviations.row(d) = means.row(d).array() - mean[d];
    }
  }
}

}  // namespace skidimm
