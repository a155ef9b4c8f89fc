// Fitting a motion model's parameters to logs with Ceres, for ANY plugin.
//
// The fitter sees a model only through the SDK's generic interface: its flat
// parameter vector (names, bounds, scopes) and predict(). It minimises the
// model's prediction error over windows of a log:
//
//   start at a row where every state is measured (x_s = the measurement),
//   propagate with the logged inputs (zero-order hold) through the measured
//   rows of the next `window` seconds, and compare predicted and measured
//   components, each divided by its measurement standard deviation sqrt(R_ii).
//
// window = 0 is the one-step (equation-error) objective (the next measured
// row only); a window of W > 0 seconds is the multi-step (simulation-error)
// objective, with windows that do not overlap (multiple shooting). The
// likelihood objective (likelihood_fitter.h) has none of this objective's
// needs (every state measured) nor its bias; docs/fitting.md compares them. A robust loss (Huber, Cauchy) limits
// the pull of outliers; parameter bounds come from the plugin. Derivatives are
// exact where the plugin provides parameter_jacobian() (the bundled plugins
// differentiate their templated equations with Ceres jets): the state's
// sensitivity is chained through each window. Otherwise they are central
// differences of predict(). After the fit:
//
//   * parameter standard deviations from Ceres' covariance, scaled by the
//     residual variance;
//   * identifiability: the singular values of the residual Jacobian; a
//     direction the logs do not excite is an error naming its parameters;
//   * the process-noise intensity Q (diagonal) that makes the mode's own EKF
//     consistent on its logs: the mean normalized innovation squared of each
//     state's measurement is 1. The IMM compares modes by their innovation
//     likelihoods, so a mode whose filter is over- or under-confident on its
//     own data would be misjudged. The fitted parameters' errors are part of
//     what Q absorbs;
//   * RMSE of one-step predictions per measured component;
//   * optionally, the covariance of each mode's fitted parameters, for a bank
//     whose modes widen where their fit saw no data (parameter_uncertainty.h,
//     docs/fitting.md "Parameter uncertainty").
#ifndef SKIDIMM_FITTING_MODEL_FITTER_H_
#define SKIDIMM_FITTING_MODEL_FITTER_H_

#include <Eigen/Core>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "skidimm/config/bank.h"
#include "skidimm/errors.h"
#include "skidimm/fitting/trajectory.h"

namespace skidimm {
namespace fitting {

// The logs cannot determine the parameters (too short, not exciting them,
// not measuring every state). what() says which and why.
class FitError : public Error {
 public:
  using Error::Error;
};

// Called after each iteration of a fit's solver with what is being fitted
// ("mode 'ice'") and the iterations so far of that fit; from the thread that
// fits. May be empty.
using FitProgress = std::function<void(const std::string& what, int iteration)>;

struct FitOptions {
  double window = 0.0;         // seconds per prediction window; 0 = one-step
  std::string loss = "huber";  // huber, cauchy, none
  double loss_scale = 3.0;     // in measurement standard deviations
  int max_iterations = 200;
  // Which parameters to fit, by scope: kMode fits each mode's own, kBank the
  // bank-level (shared:) ones jointly over every mode's logs.
  sdk::ParameterScope scope = sdk::ParameterScope::kMode;
  // Singular values below this fraction of the largest mark a direction as
  // not identifiable.
  double identifiability_threshold = 1e-7;
  // Central differences even where the plugin gives exact derivatives.
  bool numeric_derivatives = false;
  // Parameters the logs do not excite (a straight-driving mode's turn gains)
  // are held at their starting values instead of failing the fit; each is
  // named in the report's warnings.
  bool hold_unexcited = false;
  // Q with off-diagonal terms: each diagonal entry makes its component's
  // filter consistent (as without), and the correlations are those of the
  // one-step prediction errors (rows measuring every state). Their
  // covariance is Qd + R + F R F', so this is Q's correlation when R is small
  // against Qd, and understates it otherwise. Features that move together
  // (vibration on every IMU axis) are then not counted as independent
  // evidence, which makes a bank overconfident.
  bool correlated_process_noise = false;
  // Above this many residuals, with exact derivatives, the windows are
  // condensed into one residual block of the parameters' size that gives
  // the solver the same cost, gradient and Gauss-Newton matrix: memory then
  // stays that of the logs, whatever their length (docs/fitting.md, "Long
  // logs"). Below it, one residual block per window.
  long condense_above = 100000;
  // Also estimate the covariance of each mode's fitted parameters
  // (FitReport::parameter_covariance): Gauss-Newton, one residual variance
  // per measurement channel.
  bool parameter_covariance = false;
  // With parameter_covariance: count each log's residual rows as correlated,
  // each channel's variance scaled by its design effect over the logs (about
  // the rows per log where each log is missed by an offset of its own;
  // docs/fitting.md, "Parameter uncertainty"). Off, the rows count as
  // independent.
  bool parameter_covariance_per_log = false;
  // Each fitted parameter's standard deviation in the report, from Ceres'
  // covariance: an SVD of the whole Jacobian, as costly as the solve. Off,
  // they are NaN and no parameter is reported poorly determined; `tune`,
  // which keeps only the fitted values of its hundreds of fits, turns it off.
  bool standard_deviations = true;
  FitProgress progress;
};

struct ParameterEstimate {
  std::string name;
  double value = 0.0;
  double standard_deviation = 0.0;  // NaN when not available
};

struct FitReport {
  std::vector<ParameterEstimate> parameters;  // the fitted ones
  Eigen::VectorXd rmse;                       // one-step, per measurement component (NaN: never two in a row)
  Eigen::MatrixXd q_intensity;                // estimated process noise (state_dim x state_dim)
  std::vector<std::string> warnings;
  int residuals = 0;
  std::string derivatives;  // "autodiff" (from the plugin) or "numeric"
  int iterations = 0;
  double initial_cost = 0.0;
  double final_cost = 0.0;
  double condition_number = 0.0;
  // With FitOptions::parameter_covariance, the window objective's estimate of
  // the covariance of the model's whole flat parameter vector
  // (parameter_info() order; zero rows and columns for the parameters not
  // fitted: held, fixed, or of the other scope). Empty otherwise.
  Eigen::MatrixXd parameter_covariance;
  // The lag-1 correlation of the mode's one-step errors from one fully
  // measured row to the next, whitened by their covariance: tr(C^-1 G) / n
  // with C the errors' second moment and G their lag-1 cross moment
  // (ModeConfig::residual_correlation, residual_correlation.h), clamped to
  // [-0.99, 0.99]; NaN when fewer than 2n pairs of rows follow each other.
  // Filled by the window objective.
  double residual_correlation = std::numeric_limits<double>::quiet_NaN();
  // evaluate(): how many of the model's predictions on the logs (one-step
  // and output predictions) failed, left out of rmse (a warning says so),
  // and where the first did and why.
  long failed_predictions = 0;
  long predictions = 0;
  std::string first_failed_prediction;

  // Filled by the likelihood objective (likelihood_fitter.h) only.
  // Rows with at least one measured component.
  int measured_rows = 0;
  // This mode's own negative log-likelihood at the fit, and per measured row.
  double negative_log_likelihood = std::numeric_limits<double>::quiet_NaN();
  double negative_log_likelihood_per_row = std::numeric_limits<double>::quiet_NaN();
  // Per measurement component: mean nu_c^2 / S_cc, 1 when the filter is consistent.
  Eigen::VectorXd mean_nis;
  // The fitted entries of Q ("Q[i,j]", lower triangle) and R ("R[i,i]").
  std::vector<ParameterEstimate> noise_parameters;
  // The fitted bank R; empty when R was not fitted.
  Eigen::MatrixXd measurement_noise;
};

// A mode's logs.
struct ModeLogs {
  int mode = 0;  // index in the bank
  std::vector<Trajectory> logs;
};

// How many logs `data`'s segments were read from (Trajectory::log).
int log_count(const ModeLogs& data);

// Fits the parameters of `options.scope` of the bank's models in place
// (bank->models[j]->set_parameters) and returns one report per mode in
// `data` (for kBank, the parameters are common and every report lists them).
// Throws FitError.
std::vector<FitReport> fit(Bank* bank, const std::vector<ModeLogs>& data, const FitOptions& options);
// The same over logs held elsewhere (no copy of them).
std::vector<FitReport> fit(Bank* bank, const std::vector<const ModeLogs*>& data, const FitOptions& options);

// One-step RMSE and the process-noise estimate of mode `data.mode` at the
// model's current parameters (part of every FitReport; exposed for held-out
// evaluation). With `correlated`, Q gets off-diagonal terms: see
// FitOptions::correlated_process_noise.
FitReport evaluate(const Bank& bank, const ModeLogs& data, bool correlated = false);
// "the model failed N of its M predictions on these logs (the first: <log>:
// step k (t = ... s): <the model's reason>)", from evaluate()'s report.
std::string failed_predictions_text(const FitReport& report);

}  // namespace fitting
}  // namespace skidimm

#endif  // SKIDIMM_FITTING_MODEL_FITTER_H_
