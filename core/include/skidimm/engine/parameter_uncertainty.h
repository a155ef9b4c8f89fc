// Parameter uncertainty: a mode whose fitted parameters are not known exactly
// predicts less sharply where its fit saw few data.
//
// A mode's `parameter_covariance` (docs/bank-format.md) is the covariance
// Sigma of its model's flat parameter vector (parameter_info() order) as its
// fit left it. Over a step the parameters' error moves the prediction by
// G dtheta, with G = d predict / d theta at (x, u, dt) (the model's
// parameter_jacobian()), so the step's process noise becomes
//
//   Qd(x, u, dt) + G Sigma G'.
//
// For a model linear in its parameters, as linear_features is in B and c,
// G = Gamma (I kron [u' 1]) and the added term is the textbook prediction
// variance of a regression, phi(u)' (X'X)^-1 phi(u) s^2: small where the fit
// had inputs like u and growing with their distance from them (a faster
// drive than any fitted one). Without the key nothing is added and the model
// runs as it always did.
//
// The term is added by a decorator around the plugin's model, so every model
// that gives parameter_jacobian() takes it and no plugin changes.
#ifndef SKIDIMM_ENGINE_PARAMETER_UNCERTAINTY_H_
#define SKIDIMM_ENGINE_PARAMETER_UNCERTAINTY_H_

#include <Eigen/Core>
#include <string>

#include "skidimm/engine/plugin_registry.h"

namespace skidimm {

struct Bank;

// `model` with `covariance` (p x p, p = model->parameter_info().size(),
// check_parameter_covariance(); eigenvalues below zero, from rounding, are
// taken as zero) added to its process noise as above; an
// empty covariance returns the model itself. A model that is already so
// wrapped is unwrapped first, so the covariance is replaced, not stacked.
// Throws Error when the covariance does not fit the model or the model gives
// no parameter_jacobian() (checked at `dt`, the inputs zero).
ModelHandle with_parameter_uncertainty(ModelHandle model, const Eigen::MatrixXd& covariance, double dt);

// True if `covariance` can be a parameter covariance: square, finite,
// symmetric and positive semi-definite up to the rounding of a bank file
// (eigenvalues above -1e-6 of the largest). Otherwise false with the reason
// in *why.
bool check_parameter_covariance(const Eigen::MatrixXd& covariance, std::string* why);

// The covariance `model` adds (empty when it is not wrapped).
const Eigen::MatrixXd& parameter_covariance_of(const sdk::MotionModel& model);

// Sets mode j's parameter covariance in the bank's config and its model (an
// empty one removes it). Throws Error as with_parameter_uncertainty().
void set_parameter_covariance(Bank* bank, int mode, const Eigen::MatrixXd& covariance);

// As set_parameter_covariance(), for a covariance a fit has computed (the
// fit report's parameter_covariance: symmetric and positive semi-definite by
// construction) or one a loaded bank holds (checked when it was read), which
// is taken as it is: only its size is checked. A tune swaps each fold's
// covariances into its banks hundreds of times, and the eigendecompositions
// that check and clean a covariance read from a file cost more there than
// the filtering.
void set_fitted_parameter_covariance(Bank* bank, int mode, const Eigen::MatrixXd& covariance);

}  // namespace skidimm

#endif  // SKIDIMM_ENGINE_PARAMETER_UNCERTAINTY_H_
