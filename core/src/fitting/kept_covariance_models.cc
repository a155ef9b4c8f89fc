#include "kept_covariance_models.h"

#include <cstddef>

#include "parameter_noise.h"
#include "skidimm/engine/parameter_uncertainty.h"

namespace skidimm {
namespace fitting {
namespace internal {

void KeptCovarianceModels::set(Bank* bank, int mode, const Eigen::MatrixXd& covariance) {
  const std::size_t j = static_cast<std::size_t>(mode);
  if (covariance.size() == 0) {
    set_fitted_parameter_covariance(bank, mode, covariance);
    return;
  }
  const sdk::MotionModel* model = skidimm::internal::model_under_parameter_uncertainty(*bank->models[j]);
  if (model == nullptr) model = bank->models[j].get();
  const auto key = std::make_pair(&covariance, mode);
  const auto found = kept_.find(key);
  if (found != kept_.end()) {
    const ModelHandle& kept = found->second;
    const Eigen::MatrixXd& kept_covariance = parameter_covariance_of(*kept);
    if (skidimm::internal::model_under_parameter_uncertainty(*kept) == model &&
        kept_covariance.rows() == covariance.rows() && kept_covariance.cols() == covariance.cols() &&
        kept_covariance == covariance) {
      bank->models[j] = kept;
      bank->config.modes[j].parameter_covariance = covariance;
      return;
    }
  }
  set_fitted_parameter_covariance(bank, mode, covariance);
  if (entries_ + covariance.size() > kMostEntries) {
    kept_.clear();
    entries_ = 0;
  }
  ModelHandle& kept = kept_[key];
  if (kept) entries_ -= parameter_covariance_of(*kept).size();  // replaced: its entries are no longer held
  entries_ += covariance.size();
  kept = bank->models[j];
}

}  // namespace internal
}  // namespace fitting
}  // namespace skidimm
