// Fitting a whole bank: every mode that has logs, with one objective, the
// way `skidimm fit` and `skidimm tune` do it.
//
// The window objective (model_fitter.h) fits each mode's own parameters (after
// the bank-level ones, jointly over all modes, when asked), then the process
// noise Q that makes each mode's filter consistent. The likelihood objective
// (likelihood_fitter.h) fits parameters and Q together, and optionally one R
// for the bank. Either way the fitted Q is written into the bank's config, so
// the bank is ready to run.
#ifndef SKIDIMM_FITTING_BANK_FIT_H_
#define SKIDIMM_FITTING_BANK_FIT_H_

#include <map>
#include <string>
#include <vector>

#include "skidimm/config/bank.h"
#include "skidimm/fitting/model_fitter.h"

namespace skidimm {
namespace fitting {

enum class Objective {
  kLikelihood,  // the modes' own innovation likelihood (prediction-error method)
  kWindow,      // prediction error over windows started from measured states
};
const char* to_string(Objective objective);
Objective objective_from_string(const std::string& name);  // throws Error

struct BankFitOptions {
  Objective objective = Objective::kLikelihood;
  FitOptions window;           // the window objective's options
  bool shared = false;         // window objective: fit the bank-level parameters first
  bool fit_measurement_noise = false;  // likelihood objective: one R for the bank
  bool full_process_noise = false;     // likelihood objective: Q with off-diagonal terms
  // Window objective: give each fitted mode its own R (ModeConfig::r) whose
  // rows of the measured outputs are the variance of its fitted outputs'
  // residuals on its logs: the noise its filter should expect of them, its
  // model's error included. The state rows keep the bank's R.
  bool output_noise = false;
  // Window objective: write each fitted mode's parameter covariance into the
  // bank (ModeConfig::parameter_covariance, parameter_uncertainty.h), so its
  // predictions widen where the fit saw no data; without it a fitted mode's
  // old covariance is removed (it belonged to other parameters).
  bool parameter_uncertainty = false;
  // With it: each log's rows counted as correlated in that covariance
  // (FitOptions::parameter_covariance_per_log).
  bool uncertainty_per_log = false;
  // Window objective: write each fitted mode's residual correlation, the
  // lag-1 correlation of its whitened one-step errors on its logs
  // (FitReport::residual_correlation, ModeConfig::residual_correlation), so
  // its likelihood counts a persistent miss once, not at every step. Without
  // it a mode keeps the bank's value.
  bool residual_correlation = false;
  // Window objective: give every fitted mode one Q, the mean of the modes'
  // own estimates (pooled_process_noise()), instead of each its own. Modes
  // whose Q differ let a broad mode win a step that no mode predicts well
  // (the one whose covariance is widest in the direction of the miss, and a
  // log det that differs by mode whatever the data); with one Q the modes
  // are told apart by what they predict, not by how much they expect to miss.
  bool pooled_process_noise = false;
  // With parameter_uncertainty: each regime's fitted parameters pooled
  // partially (pool_parameters_partially()), each mode towards the regime's
  // mean by how little its own logs determined it.
  bool partial_pooling = false;
  // After each solver iteration of either objective, what is fitted and the
  // iterations so far (model_fitter.h); `window.progress` is ignored.
  FitProgress progress;
};

// The R output_noise gives a mode: `r` (the bank's) with each output row's
// variance replaced by its residual RMSE squared, floored at 1e-6 of the
// bank's, and that row's correlations dropped.
Eigen::MatrixXd output_noise_from_fit(const BankConfig& config, const Eigen::VectorXd& rmse);

// The Q pooled_process_noise gives every fitted mode: the mean of `q`, the
// fitted modes' own estimates, each mode counted once however many rows it
// was fitted on (so a class with many runs does not set the noise of all).
// Throws FitError when `q` is empty or the matrices differ in size.
Eigen::MatrixXd pooled_process_noise(const std::vector<Eigen::MatrixXd>& q);

// Partial pooling of fitted parameters (empirical Bayes): the modes of one
// regime (the same model and fit_when, at least three of them) are taken as
// draws about a common value, each parameter with its own spread between
// modes, estimated from the modes' estimates and their covariances (the
// spread of the estimates less the mean of their own variances, at least 0).
// Each mode's estimate then moves towards the regime's mean by the share its
// own uncertainty has of the two, and its other parameters with it as far
// as they are correlated: a slope its logs barely determined (a terrain
// driven at one speed) takes most of its value from the other terrains',
// one they determined keeps its own. `parameters` and `covariances` are per
// mode of `bank` (the model's flat parameter vector and its covariance);
// only `modes` with a covariance take part, and only the parameters every
// mode of the regime fitted. Each covariance becomes the posterior's, the
// mean's own uncertainty included. A direction a fit held where it started
// (--hold-unexcited) has no variance and is not moved: what the logs told
// nothing of keeps its starting value.
struct PartialPooling {
  int regimes = 0;  // regimes pooled
  // Modes that keep their own estimates, and why (a bound, a value not finite).
  std::vector<std::pair<std::string, std::string>> kept_own;
};
// What fit and tune say where --partial-pooling found no regime to pool.
extern const char* const kNothingPooled;
PartialPooling pool_parameters_partially(const Bank& bank, const std::vector<int>& modes,
                                         std::vector<Eigen::VectorXd>* parameters,
                                         std::vector<Eigen::MatrixXd>* covariances);

// What a fit of `data` faces, stated before it starts: the logs, their rows,
// the modes and the values fitted (each mode's own model parameters, and the
// bank-level ones with `shared`; the entries of each mode's Q; R's with
// fit_measurement_noise). The work grows with rows x parameters.
struct FitWork {
  int modes = 0;
  long logs = 0;      // distinct logs (a file, or files joined by +)
  long segments = 0;  // the pieces of them each mode fits (a log splits where its truth changes)
  long rows = 0;
  int parameters = 0;  // model parameters and noise entries, over every mode
  Objective objective = Objective::kLikelihood;
  // "3 modes, 12 logs (40 segments), 45678 rows, 54 parameters (likelihood objective)"
  std::string describe() const;
};
FitWork fit_work(const Bank& bank, const std::vector<ModeLogs>& data, const BankFitOptions& options);
FitWork fit_work(const Bank& bank, const std::vector<const ModeLogs*>& data, const BankFitOptions& options);

// Why hold_unexcited would do nothing in a fit of this bank by `objective`
// (naming the states not measured directly), or "" when it holds what the
// logs do not excite. It acts in the window
// fit, which the likelihood objective starts from only where every state is
// measured directly (a row of measurement.observe): with a state that is
// not, the likelihood fits alone, and refuses parameters the logs do not
// identify. (The window objective refuses such a bank itself.)
std::string hold_unexcited_ignored(const BankConfig& config, Objective objective);

// Fits the modes in `data` in place. Returns their reports by mode index.
// Throws FitError, also when options.window.hold_unexcited would do nothing
// (hold_unexcited_ignored()).
std::map<int, FitReport> fit_bank(Bank* bank, const std::vector<ModeLogs>& data, const BankFitOptions& options);

}  // namespace fitting
}  // namespace skidimm

#endif  // SKIDIMM_FITTING_BANK_FIT_H_
