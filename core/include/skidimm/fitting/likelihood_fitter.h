// Likelihood fitting (the prediction-error method): a mode's model parameters,
// its process noise Q and optionally the bank's measurement noise R, chosen to
// maximise the innovation likelihood of the mode's own EKF over its logs.
//
// For mode j with logs t (times t.t, inputs t.u, measurements t.z with NaN for
// missing components) the objective is
//
//   NLL_j = sum_logs sum_{rows with a measured component}
//             1/2 (nu' S^-1 nu + log det S + k log 2 pi)
//
// where nu (k measured components) and S are computed by exactly the filter
// the IMM runs for that mode (ekf.h, imm.h): the bank's prior holds at the
// first row, whose measurement is applied without prediction; row k's input
// drives the prediction to row k+1 (zero-order hold) with F = jacobian() at
// the prior state and Qd = process_noise(Q, x, u, dt); the update uses the
// finite rows of z only, wraps angle innovations, and updates P in Joseph
// form. Rows with no measurement are predict-only and add nothing. Rows the
// IMM would reject (a non-finite input or time, a time that does not
// increase) are skipped as the IMM skips them. This is the exact Gaussian
// log-likelihood of a linear model by the prediction-error decomposition
// (Schweppe 1965) and its usual extension to EKFs; maximising it is Åström's
// prediction-error / maximum-likelihood method for state-space models
// (K. J. Åström, "Maximum likelihood and prediction error methods",
// Automatica 16(5), 1980). Unlike the window objective (model_fitter.h) it
// needs no measured start state, so it fits models with latent states,
// missing and multi-rate measurements, and it is not biased by noisy starts.
//
// Parameters, in natural units, and how they are kept feasible (the solver,
// Ceres' LBFGS on a GradientProblem, works on unconstrained coordinates):
//   * the mode's own model parameters (ParameterScope::kMode); bounded ones by
//     a logistic transform (two bounds) or an exponential (one bound), free
//     ones unchanged;
//   * Q, the continuous-time intensity: diagonal (log of each entry) or full
//     (a Cholesky factor with a log diagonal), so always positive definite;
//   * optionally one diagonal R for the whole bank (log of each entry): the
//     sensors are the same on every terrain, so R is fitted jointly with
//     every mode's parameters and Q over all modes' logs. Without R the modes
//     are independent problems and are solved one by one.
//
// Gradient: exact for the filter recursion, by forward sensitivity
// equations (N. K. Gupta and R. K. Mehra, "Computational aspects of maximum
// likelihood estimation and reduction in sensitivity function calculations",
// IEEE Trans. Autom. Control 19(6), 1974): dx/dtheta and dP/dtheta are
// propagated through prediction and update next to the filter, and dNLL
// follows from d nu and d S. What the recursion needs from the model:
//   * d f / d theta: parameter_jacobian() when it returns true (the bundled
//     plugins give it exactly with Ceres jets); otherwise, or with
//     numeric_derivatives, central differences of predict();
//   * d F / d theta and d F / d x (second derivatives of f, which the SDK
//     does not expose): central differences of jacobian();
//   * d Qd / d theta and d Qd / d x: central differences of process_noise();
//   * d Qd / d Q: process_noise() of each basis matrix of Q. This assumes
//     that process_noise() is linear in the intensity, as every
//     discretisation of white noise is (Q dt, or int expm(As) Q expm(As)' ds);
//     the fitter checks this on the first step and fails otherwise.
// With a linear model (F independent of x, affine in the parameters) every
// difference above is exact up to round-off, so the gradient is exact. The
// test suite checks the whole gradient against differences of the NLL
// (relative error below 1e-6 on its cases).
//
// Cost. One NLL + gradient is O(N p n^3) for N rows, p parameters and n
// states, plus the model calls above (docs/fitting.md has timings). Two
// savings, neither of which changes the gradient at the reported solution:
// (1) derivatives of F and Qd that came out exactly zero at every row at the
// start (a linear model's F in x or in B) are not computed again; at each
// solution everything is computed again, and if anything is non-zero that
// was not before, the solve continues with it (at most twice, then with
// everything at every step); (2) a step whose F and Qd do not change when x
// and u do (checked at every row by a perturbation whenever everything is
// computed) has its parameter and Q derivatives reused between rows of equal
// dt, e.g. every row of a log on a fixed grid. LBFGS runs on coordinates
// whitened by the BHHH information (below) at its start, and again at the
// point its first 10 iterations reach.
//
// After the fit each report holds: the parameters with standard deviations
// from the inverse of the Fisher information estimated by the outer product
// of the per-row score contributions (BHHH: Berndt, Hall, Hall and Hausman,
// Ann. Econ. Soc. Meas. 3(4), 1974); the fitted Q (and R) entries with theirs;
// the final NLL, NLL per measured row, innovation RMSE and mean NIS per
// measurement component; and warnings (a parameter on a bound, one whose
// standard deviation exceeds its value, LBFGS not converged). A direction of
// the information matrix (scaled to unit diagonal) whose eigenvalue is below
// identifiability_threshold of the largest is an error naming the
// parameters involved, as in the window fitter.
//
// Threading: fit_likelihood() and evaluate_likelihood_derivatives() modify
// the bank's models in place (set_parameters), so nothing else may use the
// bank while they run.
#ifndef SKIDIMM_FITTING_LIKELIHOOD_FITTER_H_
#define SKIDIMM_FITTING_LIKELIHOOD_FITTER_H_

#include <Eigen/Core>
#include <string>
#include <vector>

#include "skidimm/config/bank.h"
#include "skidimm/fitting/model_fitter.h"
#include "skidimm/fitting/trajectory.h"

namespace skidimm {
namespace fitting {

struct LikelihoodFitOptions {
  // How the mode's process-noise intensity Q is fitted.
  enum class ProcessNoise {
    kKeep,      // not fitted: the bank's Q
    kDiagonal,  // a diagonal Q (off-diagonal entries of the bank's Q are dropped)
    kFull,      // a full symmetric positive definite Q
  };

  // The mode's own (ParameterScope::kMode) model parameters, where its model
  // has any (a mode whose model has none fits its noise only). Bank-level
  // (shared:) parameters are never fitted here.
  bool fit_model_parameters = true;
  ProcessNoise process_noise = ProcessNoise::kDiagonal;
  // One diagonal R for the whole bank, jointly over every mode's logs;
  // written into bank->config.measurement.r. Off-diagonal entries of the
  // bank's R are dropped.
  bool fit_measurement_noise = false;
  // LBFGS iterations (each costs about one evaluation of NLL and gradient).
  int max_iterations = 300;
  FitProgress progress;  // after each LBFGS iteration (model_fitter.h)
  // Central differences of predict() for d f / d theta even where the plugin
  // gives parameter_jacobian() (the report says which was used).
  bool numeric_derivatives = false;
  // A direction of the information matrix, scaled to unit diagonal, with an
  // eigenvalue below this fraction of the largest is not identifiable.
  double identifiability_threshold = 1e-10;
};

// Fits every mode in `data` (a mode listed twice has all its logs pooled).
// Leaves the fitted model parameters in bank->models[j] and, with
// fit_measurement_noise, the fitted R in bank->config.measurement.r. The
// fitted Q of each mode is FitReport::q_intensity; the bank's config Q is not
// changed (bank_fit.h writes it). Returns one report per entry of `data`, in
// order; FitReport's fields mean:
//   parameters          the fitted model parameters, with BHHH standard deviations
//   noise_parameters    the fitted entries "Q[i,j]" (lower triangle) and "R[i,i]"
//   q_intensity         the mode's Q (the bank's when kKeep)
//   measurement_noise   the fitted bank R (empty unless fit_measurement_noise)
//   rmse, mean_nis      per measurement component: innovation RMSE and mean of
//                       nu_c^2 / S_cc (1 when the filter is consistent)
//   residuals           measured scalar components; measured_rows: rows with one
//   negative_log_likelihood(_per_row)  this mode's NLL at the fit
//   initial_cost, final_cost           the objective solved (with R: the sum
//                                      over every mode) at the start and the end
//   iterations, derivatives ("autodiff": parameter_jacobian(); "numeric":
//                       differences of predict(); "none": no model parameters)
//   condition_number    of the scaled information matrix
// On error the models are restored to their starting parameters. Throws
// FitError: no logs or no measured row for a mode; nothing to fit (a
// model without per-mode parameters, Q kept and R not fitted); an NLL
// that is not finite at the starting values (naming the log and the row);
// process_noise() not linear in Q; parameters the logs do not identify.
std::vector<FitReport> fit_likelihood(Bank* bank, const std::vector<ModeLogs>& data,
                                      const LikelihoodFitOptions& options = {});

// The objective of one mode at given values, for held-out evaluation and
// tests.
struct LikelihoodEvaluation {
  double negative_log_likelihood = 0.0;  // +inf if the filter failed (see failure)
  int measured_rows = 0;                 // rows with at least one measured component
  int residuals = 0;                     // measured scalar components
  Eigen::VectorXd rmse;                  // innovation RMSE per measurement component (NaN: never measured)
  Eigen::VectorXd mean_nis;              // mean nu_c^2 / S_cc per component (NaN: never measured)
  // Per log (in data.logs order), per row: the row's term of the NLL; NaN for
  // predict-only and skipped rows.
  std::vector<Eigen::VectorXd> row_terms;
  // Empty if the filter ran through; otherwise "<source>: row <r> (t = ... s): <why>".
  std::string failure;

  // Only from evaluate_likelihood_derivatives(): the parameters the
  // options select, in natural units ("A[0,1]", "Q[1,0]", "R[0,0]"), the
  // gradient of the NLL with respect to them and the BHHH information
  // sum_rows g_row g_row'.
  std::vector<std::string> parameter_names;
  Eigen::VectorXd gradient;
  Eigen::MatrixXd information;
};

// The NLL of mode data.mode at the bank's current values: its model's
// parameters, its Q (config.modes[mode].q_intensity) and the bank's R. The
// bank is not modified.
LikelihoodEvaluation evaluate_likelihood(const Bank& bank, const ModeLogs& data);

// The same with the gradient and the BHHH information with respect to the
// parameters `options` would fit for this mode: its model parameters (if
// fit_model_parameters), the entries of Q (diagonal, or the lower triangle
// for kFull; none for kKeep) and, with fit_measurement_noise, the diagonal
// entries of R; each entry of a symmetric matrix moves both of its places.
// The model is perturbed for differences and left at its values. A
// process_noise() that is not linear in Q is a failure (no gradient).
LikelihoodEvaluation evaluate_likelihood_derivatives(Bank* bank, const ModeLogs& data,
                                                     const LikelihoodFitOptions& options = {});

}  // namespace fitting
}  // namespace skidimm

#endif  // SKIDIMM_FITTING_LIKELIHOOD_FITTER_H_
