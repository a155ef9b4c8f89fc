// The models a bank's modes had with each fit's parameter covariance, kept
// for when the same fit is applied again. Private to the fitting library
// (tuned_settings.cc, tuning.cc).
#ifndef SKIDIMM_CORE_SRC_FITTING_KEPT_COVARIANCE_MODELS_H_
#define SKIDIMM_CORE_SRC_FITTING_KEPT_COVARIANCE_MODELS_H_

#include <Eigen/Core>
#include <map>
#include <utility>

#include "skidimm/config/bank.h"

namespace skidimm {
namespace fitting {
namespace internal {

// A tuner applies each fold's fit once per candidate setting, and each time
// wrapping a mode's model in its fitted covariance (working out Sigma's
// blocks and the rows each moves) gave the same model: 4% of a BorealTC
// tune. One per bank, as the models it keeps wrap that bank's models.
class KeptCovarianceModels {
 public:
  // set_fitted_parameter_covariance(bank, mode, covariance), with the model
  // kept from the last time `covariance` (the same matrix, at the same
  // address) was applied to this mode when it still wraps the bank's model
  // and holds those very values.
  void set(Bank* bank, int mode, const Eigen::MatrixXd& covariance);

 private:
  // The covariance entries the kept models hold, at most about 16 MB of them
  // (a search's folds times the bank's modes: for the BorealTC bank 370
  // models of 36 x 36), past which all are let go at once.
  static constexpr Eigen::Index kMostEntries = Eigen::Index{1} << 21;
  std::map<std::pair<const Eigen::MatrixXd*, int>, ModelHandle> kept_;
  Eigen::Index entries_ = 0;
};

}  // namespace internal
}  // namespace fitting
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_FITTING_KEPT_COVARIANCE_MODELS_H_
