#include "skidimm/fitting/bank_fit.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <vector>

#include "skidimm/engine/measurement_model.h"
#include "skidimm/engine/parameter_uncertainty.h"
#include "skidimm/errors.h"
#include "skidimm/fitting/fit_logs.h"
#include "skidimm/fitting/likelihood_fitter.h"

namespace skidimm {
namespace fitting {

const char* to_string(Objective objective) {
  switch (objective) {
    case Objective::kLikelihood:
      return "likelihood";
    case Objective::kWindow:
      return "window";
  }
  return "?";
}

Objective objective_from_string(const std::string& name) {
  if (name == "likelihood") return Objective::kLikelihood;
  if (name == "window") return Objective::kWindow;
  throw Error("unknown fit objective '" + name + "' (expected likelihood or window)");
}

namespace {

bool has_parameters(const sdk::MotionModel& model, sdk::ParameterScope scope) {
  for (const auto& info : model.parameter_info()) {
    if (info.scope == scope) return true;
  }
  return false;
}

std::map<int, FitReport> fit_window(Bank* bank, const std::vector<ModeLogs>& data, const BankFitOptions& options) {
  std::map<int, FitReport> reports;
  FitOptions fit_options = options.window;
  fit_options.progress = options.progress;
  fit_options.correlated_process_noise = fit_options.correlated_process_noise || options.full_process_noise;
  fit_options.parameter_covariance = options.parameter_uncertainty;
  fit_options.parameter_covariance_per_log = options.uncertainty_per_log;
  if (options.shared) {
    fit_options.scope = sdk::ParameterScope::kBank;
    const std::vector<FitReport> shared = fit(bank, data, fit_options);
    for (std::size_t i = 0; i < data.size(); ++i) reports[data[i].mode] = shared[i];
  }
  fit_options.scope = sdk::ParameterScope::kMode;
  for (const ModeLogs& d : data) {
    const bool after_shared = reports.count(d.mode) > 0;
    if (!has_parameters(*bank->models[static_cast<std::size_t>(d.mode)], sdk::ParameterScope::kMode)) {
      // Nothing of its own to fit: the shared fit's report stands, or just the consistent Q. A model
      // that fails on its logs is refused, as a fit refuses one failing at its starting values.
      if (!after_shared) {
        FitReport report = evaluate(*bank, d, fit_options.correlated_process_noise);
        if (report.failed_predictions > 0) {
          throw FitError("mode '" + bank->config.modes[static_cast<std::size_t>(d.mode)].name +
                         "' (nothing of its own to fit): " + failed_predictions_text(report));
        }
        reports[d.mode] = std::move(report);
      }
      continue;
    }
    FitReport report = fit(bank, std::vector<const ModeLogs*>{&d}, fit_options).front();
    if (after_shared) {  // keep the shared estimates in the report too
      report.parameters.insert(report.parameters.begin(), reports[d.mode].parameters.begin(),
                               reports[d.mode].parameters.end());
    }
    reports[d.mode] = report;
  }
  return reports;
}

// The states no measurement row observes alone: the window objective needs
// each to start its predictions.
std::vector<std::string> states_not_measured_directly(const BankConfig& config) {
  const MeasurementModel measurement(config.measurement.h, config.measurement.r, config.measurement.is_angle);
  std::vector<bool> measured(static_cast<std::size_t>(config.state_dim()), false);
  for (int row = 0; row < measurement.measurement_dim(); ++row) {
    if (const int s = measurement.picked_state(row); s >= 0) measured[static_cast<std::size_t>(s)] = true;
  }
  std::vector<std::string> missing;
  for (std::size_t s = 0; s < measured.size(); ++s) {
    if (!measured[s]) missing.push_back(config.state_names[s]);
  }
  return missing;
}

bool every_state_measured(const BankConfig& config) { return states_not_measured_directly(config).empty(); }

std::map<int, FitReport> fit_by_likelihood(Bank* bank, const std::vector<ModeLogs>& data,
                                           const BankFitOptions& options) {
  if (options.shared) {
    throw FitError(
        "bank-level (shared:) parameters are fitted by the window objective only (--objective window); the "
        "likelihood objective fits each mode's own parameters and noise");
  }
  if (bank->config.any_mode_measurement_noise()) {
    throw FitError(
        "the likelihood objective scores every mode with the bank's R, and a mode of this bank has its own (R: in its "
        "entry); fit it with the window objective (--objective window)");
  }
  // The likelihood is not convex: from a rough start (a physical guess) LBFGS
  // can settle in a poor local minimum (on the real Husky ice logs: an
  // innovation RMSE ten times the one-step fit's). Where every state is
  // measured, the one-step (equation-error) fit, a near-convex least-squares
  // problem, gives the start.
  if (every_state_measured(bank->config)) {
    BankFitOptions start = options;
    start.objective = Objective::kWindow;
    start.window.window = 0.0;
    for (const auto& [mode, report] : fit_window(bank, data, start)) {
      bank->config.modes[static_cast<std::size_t>(mode)].q_intensity = report.q_intensity;  // consistent on its logs
    }
  }
  LikelihoodFitOptions likelihood;
  likelihood.process_noise = options.full_process_noise ? LikelihoodFitOptions::ProcessNoise::kFull
                                                        : LikelihoodFitOptions::ProcessNoise::kDiagonal;
  likelihood.fit_measurement_noise = options.fit_measurement_noise;
  likelihood.progress = options.progress;
  const std::vector<FitReport> fitted = fit_likelihood(bank, data, likelihood);
  std::map<int, FitReport> reports;
  for (std::size_t i = 0; i < data.size(); ++i) reports[data[i].mode] = fitted[i];
  return reports;
}

}  // namespace

std::string FitWork::describe() const {
  return std::to_string(modes) + (modes == 1 ? " mode, " : " modes, ") + std::to_string(logs) +
         (logs == 1 ? " log" : " logs") +
         (segments != logs ? " (" + std::to_string(segments) + " segments)" : std::string()) + ", " +
         std::to_string(rows) + " rows, " + std::to_string(parameters) + " parameters (" + to_string(objective) +
         " objective)";
}

FitWork fit_work(const Bank& bank, const std::vector<ModeLogs>& data, const BankFitOptions& options) {
  std::vector<const ModeLogs*> pointers;
  for (const ModeLogs& d : data) pointers.push_back(&d);
  return fit_work(bank, pointers, options);
}

FitWork fit_work(const Bank& bank, const std::vector<const ModeLogs*>& data, const BankFitOptions& options) {
  FitWork work;
  work.objective = options.objective;
  const int n = bank.config.state_dim();
  const bool full_q = options.full_process_noise || options.window.correlated_process_noise;
  std::set<int> modes;
  std::set<std::string> logs;
  bool shared_counted = false;
  for (const ModeLogs* mode_logs : data) {
    const ModeLogs& d = *mode_logs;
    work.segments += static_cast<long>(d.logs.size());
    for (const Trajectory& t : d.logs) {
      work.rows += t.size();
      logs.insert(t.log);
    }
    if (!modes.insert(d.mode).second) continue;
    for (const auto& info : bank.models[static_cast<std::size_t>(d.mode)]->parameter_info()) {
      const bool shared = info.scope == sdk::ParameterScope::kBank;
      if (!shared || (options.shared && !shared_counted)) ++work.parameters;
    }
    shared_counted = shared_counted || options.shared;
    work.parameters += full_q ? n * (n + 1) / 2 : n;
  }
  if (options.fit_measurement_noise) work.parameters += static_cast<int>(bank.config.measurement.h.rows());
  work.modes = static_cast<int>(modes.size());
  work.logs = static_cast<long>(logs.size());
  return work;
}

std::string hold_unexcited_ignored(const BankConfig& config, Objective objective) {
  if (objective != Objective::kLikelihood) return "";
  const std::vector<std::string> missing = states_not_measured_directly(config);
  if (missing.empty()) return "";
  std::string names;
  for (const std::string& name : missing) names += (names.empty() ? "" : ", ") + name;
  return "the bank does not measure [" + names +
         "] directly (measurement.observe), so the likelihood objective fits without the one-step window fit it "
         "starts from where every state is measured, the only fit that holds parameters the logs do not excite; "
         "the likelihood itself refuses parameters the logs do not identify (fix them in the bank, or drive "
         "maneuvers that move them)";
}

const char* const kNothingPooled =
    "partial pooling pooled nothing: it pools the modes of one model and fit_when fitted together, three or more, "
    "each with a parameter covariance and the parameters all of them fitted";

namespace {

// BankFitOptions::partial_pooling over the fitted modes: their models'
// parameters and the reports' covariances and values pooled.
void pool_fitted_parameters(Bank* bank, std::map<int, FitReport>* reports) {
  const std::size_t modes = bank->models.size();
  std::vector<Eigen::VectorXd> parameters(modes);
  std::vector<Eigen::MatrixXd> covariances(modes);
  std::vector<int> fitted;
  for (const auto& [mode, report] : *reports) {
    const auto j = static_cast<std::size_t>(mode);
    parameters[j].resize(static_cast<Eigen::Index>(bank->models[j]->parameter_info().size()));
    bank->models[j]->get_parameters(parameters[j]);
    covariances[j] = report.parameter_covariance;
    fitted.push_back(mode);
  }
  const PartialPooling outcome = pool_parameters_partially(*bank, fitted, &parameters, &covariances);
  for (const auto& [name, why] : outcome.kept_own) {
    for (auto& [mode, report] : *reports) {
      if (bank->config.modes[static_cast<std::size_t>(mode)].name == name) {
        report.warnings.push_back("partial pooling: " + why + "; the mode keeps its own estimates");
      }
    }
  }
  // Said once, with the first mode fitted: the fit's, not each mode's.
  if (outcome.regimes == 0 && !reports->empty()) reports->begin()->second.warnings.push_back(kNothingPooled);
  for (auto& [mode, report] : *reports) {
    const auto j = static_cast<std::size_t>(mode);
    std::string error;
    if (!bank->models[j]->set_parameters(parameters[j], &error)) {
      throw FitError("mode '" + bank->config.modes[j].name + "' rejected its pooled parameters: " + error);
    }
    report.parameter_covariance = covariances[j];
    const auto& info = bank->models[j]->parameter_info();
    for (ParameterEstimate& estimate : report.parameters) {
      for (std::size_t e = 0; e < info.size(); ++e) {
        if (info[e].name != estimate.name) continue;
        estimate.value = parameters[j][static_cast<Eigen::Index>(e)];
        estimate.standard_deviation =
            std::sqrt(std::max(0.0, covariances[j](static_cast<Eigen::Index>(e), static_cast<Eigen::Index>(e))));
      }
    }
  }
}

}  // namespace

std::map<int, FitReport> fit_bank(Bank* bank, const std::vector<ModeLogs>& data, const BankFitOptions& options) {
  if (data.empty()) throw FitError("no logs to fit");
  if (options.window.hold_unexcited) {
    const std::string ignored = hold_unexcited_ignored(bank->config, options.objective);
    if (!ignored.empty()) throw FitError("hold_unexcited would do nothing: " + ignored);
  }
  if (options.output_noise && options.objective != Objective::kWindow) {
    throw FitError("a mode's own output noise is estimated by the window objective (--objective window)");
  }
  if (options.parameter_uncertainty && options.objective != Objective::kWindow) {
    throw FitError("the parameter covariance is estimated by the window objective (--objective window)");
  }
  if (options.residual_correlation && options.objective != Objective::kWindow) {
    throw FitError("the residual correlation is estimated by the window objective (--objective window)");
  }
  if (options.pooled_process_noise && options.objective != Objective::kWindow) {
    throw FitError(
        "one Q for every mode is pooled from the window objective's estimates (--objective window); the likelihood "
        "objective fits each mode's Q with its parameters");
  }
  if (options.partial_pooling && !options.parameter_uncertainty) {
    throw FitError(
        "partial pooling weighs each mode's estimates by their covariance: it needs the parameter uncertainty "
        "(--parameter-uncertainty)");
  }
  if (options.output_noise && bank->config.measurement.outputs.empty()) {
    throw FitError("the bank measures no model outputs (measurement.outputs): there is no output noise to estimate");
  }
  std::map<int, FitReport> reports;
  switch (options.objective) {
    case Objective::kWindow:
      reports = fit_window(bank, data, options);
      break;
    case Objective::kLikelihood:
      reports = fit_by_likelihood(bank, data, options);
      break;
  }
  if (options.pooled_process_noise) {
    std::vector<Eigen::MatrixXd> q;
    for (const auto& [mode, report] : reports) q.push_back(report.q_intensity);
    const Eigen::MatrixXd pooled = pooled_process_noise(q);
    for (auto& [mode, report] : reports) report.q_intensity = pooled;
  }
  if (options.partial_pooling) pool_fitted_parameters(bank, &reports);
  for (auto& [mode, report] : reports) {
    ModeConfig& config = bank->config.modes[static_cast<std::size_t>(mode)];
    config.q_intensity = report.q_intensity;
    config.fitted_inputs = fitted_input_ranges(bank->config, data, mode);
    if (options.residual_correlation) {
      if (std::isfinite(report.residual_correlation)) {
        config.residual_correlation = report.residual_correlation;
      } else {
        config.residual_correlation = 0.0;
        report.warnings.push_back(
            "too few consecutive rows measuring every state to estimate the residual correlation; it is 0");
      }
    }
    if (options.output_noise) config.r = output_noise_from_fit(bank->config, report.rmse);
    if (options.parameter_uncertainty || config.parameter_covariance.size() > 0) {
      try {
        set_fitted_parameter_covariance(bank, mode, report.parameter_covariance);
      } catch (const Error& e) {
        throw FitError("mode '" + config.name + "': " + e.what());
      }
    }
  }
  return reports;
}

Eigen::MatrixXd pooled_process_noise(const std::vector<Eigen::MatrixXd>& q) {
  if (q.empty()) throw FitError("no fitted Q to pool");
  Eigen::MatrixXd sum = Eigen::MatrixXd::Zero(q.front().rows(), q.front().cols());
  for (const Eigen::MatrixXd& each : q) {
    if (each.rows() != sum.rows() || each.cols() != sum.cols()) {
      throw FitError("the modes' Q differ in size (" + std::to_string(each.rows()) + " and " +
                     std::to_string(sum.rows()) + " states): one Q cannot serve them all");
    }
    sum += each;
  }
  return sum / static_cast<double>(q.size());
}

namespace {

// The parameters every member of a regime fitted: a variance above
// round-off in each member's covariance (a held parameter's row is zero, or
// nearly, as the fit's products left it).
std::vector<Eigen::Index> fitted_by_all(const std::vector<int>& members,
                                        const std::vector<Eigen::MatrixXd>& covariances, Eigen::Index n) {
  std::vector<Eigen::Index> fitted;
  for (Eigen::Index e = 0; e < n; ++e) {
    bool all = true;
    for (int j : members) {
      const Eigen::MatrixXd& sigma = covariances[static_cast<std::size_t>(j)];
      all = all && sigma(e, e) > 1e-14 * sigma.diagonal().maxCoeff();
    }
    if (all) fitted.push_back(e);
  }
  return fitted;
}

// The pseudo-inverse of a covariance whose entries' units differ by orders
// of magnitude: scaled to a unit diagonal, eigenvalues below 1e-9 of that
// taken as zero. A direction with no variance gets no gain.
Eigen::MatrixXd scaled_pseudo_inverse(const Eigen::MatrixXd& d) {
  const Eigen::VectorXd scale = d.diagonal().cwiseSqrt().cwiseInverse();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(scale.asDiagonal() * d * scale.asDiagonal());
  Eigen::VectorXd inverse = eigen.eigenvalues();
  for (Eigen::Index a = 0; a < inverse.size(); ++a) inverse[a] = inverse[a] > 1e-9 ? 1.0 / inverse[a] : 0.0;
  return scale.asDiagonal() * eigen.eigenvectors() * inverse.asDiagonal() * eigen.eigenvectors().transpose() *
         scale.asDiagonal();
}

bool within_bounds(const std::vector<sdk::ParameterInfo>& info, const Eigen::VectorXd& theta) {
  for (std::size_t e = 0; e < info.size(); ++e) {
    const double v = theta[static_cast<Eigen::Index>(e)];
    if (!(v >= info[e].lower_bound && v <= info[e].upper_bound)) return false;
  }
  return true;
}

}  // namespace

PartialPooling pool_parameters_partially(const Bank& bank, const std::vector<int>& modes,
                                         std::vector<Eigen::VectorXd>* parameters,
                                         std::vector<Eigen::MatrixXd>* covariances) {
  constexpr std::size_t kFewestModes = 3;  // a spread between modes needs a few of them
  PartialPooling outcome;
  std::map<std::pair<std::string, std::string>, std::vector<int>> regimes;
  for (int j : modes) {
    const ModeConfig& mode = bank.config.modes[static_cast<std::size_t>(j)];
    if ((*covariances)[static_cast<std::size_t>(j)].size() == 0) continue;
    regimes[{mode.model, mode.fit_when}].push_back(j);
  }
  for (const auto& [regime, members] : regimes) {
    if (members.size() < kFewestModes) continue;
    const Eigen::Index n = (*parameters)[static_cast<std::size_t>(members.front())].size();
    bool same_size = true;
    for (int j : members) {
      same_size = same_size && (*parameters)[static_cast<std::size_t>(j)].size() == n &&
                  (*covariances)[static_cast<std::size_t>(j)].rows() == n;
    }
    if (!same_size) continue;
    const std::vector<Eigen::Index> pooled = fitted_by_all(members, *covariances, n);
    const Eigen::Index f = static_cast<Eigen::Index>(pooled.size());
    if (f == 0) continue;
    const auto entry = [&pooled](Eigen::Index a) { return pooled[static_cast<std::size_t>(a)]; };
    // Each pooled parameter's mean over the modes, the spread of the modes'
    // estimates about it, and the mean of their own variances: the spread
    // between the modes' true values is the difference, at least 0.
    const double k = static_cast<double>(members.size());
    Eigen::VectorXd mean = Eigen::VectorXd::Zero(f), spread = Eigen::VectorXd::Zero(f), own = Eigen::VectorXd::Zero(f);
    for (int j : members) {
      for (Eigen::Index a = 0; a < f; ++a) {
        mean[a] += (*parameters)[static_cast<std::size_t>(j)][entry(a)] / k;
        own[a] += (*covariances)[static_cast<std::size_t>(j)](entry(a), entry(a)) / k;
      }
    }
    for (int j : members) {
      for (Eigen::Index a = 0; a < f; ++a) {
        const double d = (*parameters)[static_cast<std::size_t>(j)][entry(a)] - mean[a];
        spread[a] += d * d / (k - 1.0);
      }
    }
    const Eigen::VectorXd between = (spread - own).cwiseMax(0.0);
    // What the mean itself is uncertain by: the variance of a mean of k
    // draws, (tau2 + own) / k, the spread / k unless tau2 was clamped at 0
    // (where the spread / k would be too sure of a mean of unsure estimates).
    const Eigen::VectorXd prior = between + (between + own) / k;
    ++outcome.regimes;
    for (int j : members) {
      Eigen::VectorXd& theta = (*parameters)[static_cast<std::size_t>(j)];
      Eigen::MatrixXd& sigma = (*covariances)[static_cast<std::size_t>(j)];
      // H selects the pooled parameters; the others the mode fitted move
      // with them as far as they are correlated (a regression's intercept
      // with its slopes).
      Eigen::MatrixXd cross(n, f);  // Sigma H'
      Eigen::VectorXd own_values(f);
      for (Eigen::Index a = 0; a < f; ++a) {
        own_values[a] = theta[entry(a)];
        cross.col(a) = sigma.col(entry(a));
      }
      Eigen::MatrixXd d(f, f);  // H Sigma H' + T
      for (Eigen::Index a = 0; a < f; ++a) d.row(a) = cross.row(entry(a));
      d.diagonal() += between;
      // theta + G (mean - H theta), G = Sigma H' (H Sigma H' + T)^+; its
      // covariance in the Joseph form, a sum of two covariances whatever the
      // round-off (Sigma - G H Sigma is the same in exact arithmetic, and is
      // not positive semidefinite once rounded where Sigma spans many orders
      // of magnitude), the second the prior's with the mean's uncertainty.
      const Eigen::MatrixXd gain = cross * scaled_pseudo_inverse(d);
      const Eigen::VectorXd moved = theta + gain * (mean - own_values);
      Eigen::MatrixXd keep = Eigen::MatrixXd::Identity(n, n);
      for (Eigen::Index a = 0; a < f; ++a) keep.col(entry(a)) -= gain.col(a);
      Eigen::MatrixXd posterior = keep * sigma * keep.transpose() + gain * prior.asDiagonal() * gain.transpose();
      posterior = (0.5 * (posterior + posterior.transpose())).eval();
      const auto& info = bank.models[static_cast<std::size_t>(j)]->parameter_info();
      const std::string& name = bank.config.modes[static_cast<std::size_t>(j)].name;
      if (!moved.allFinite() || !posterior.allFinite()) {
        outcome.kept_own.emplace_back(name, "the pooled values would not be finite");
        continue;
      }
      if (static_cast<Eigen::Index>(info.size()) != n || !within_bounds(info, moved)) {
        outcome.kept_own.emplace_back(name, "the pooled values would leave a parameter outside its bounds");
        continue;
      }
      theta = moved;
      sigma = posterior;
    }
  }
  return outcome;
}

Eigen::MatrixXd output_noise_from_fit(const BankConfig& config, const Eigen::VectorXd& rmse) {
  Eigen::MatrixXd r = config.measurement.r;
  const Eigen::Index rows = r.rows();
  if (rmse.size() != rows) throw FitError("output noise: one RMSE per measurement row expected");
  for (Eigen::Index c = config.measurement.first_output_row(); c < rows; ++c) {
    const double variance = std::isfinite(rmse[c]) ? rmse[c] * rmse[c] : r(c, c);
    r.row(c).setZero();
    r.col(c).setZero();
    r(c, c) = std::max(variance, 1e-6 * config.measurement.r(c, c));
  }
  return r;
}

}  // namespace fitting
}  // namespace skidimm
