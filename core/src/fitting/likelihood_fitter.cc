#include "skidimm/fitting/likelihood_fitter.h"

#include <ceres/gradient_problem.h>
#include <ceres/gradient_problem_solver.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <sstream>
#include <unordered_map>
#include <utility>

#include "bounded_median.h"
#include "covariance.h"
#include "likelihood_problem.h"
#include "parameter_glossary.h"
#include "parameter_noise.h"
#include "skidimm/engine/measurement_model.h"
#include "skidimm/sdk/angles.h"
#include "solver_progress.h"

namespace skidimm {
namespace fitting {

namespace {

using namespace internal;  // NOLINT: the parts of this fitter (likelihood_problem.h)

// T with T' I T = identity on the directions the information I determines:
// T = D V L^-1/2 from the eigen decomposition V L V' of D I D, D scaling I to
// unit diagonal. Eigenvalues are floored at 1e-8 of the largest, so a
// direction the start does not determine is not stretched without bound.
// With BHHH's I close to the Hessian near the optimum, LBFGS then sees a
// nearly isotropic problem.
Eigen::MatrixXd whitening(const Eigen::MatrixXd& information) {
  const Eigen::Index size = information.rows();
  Eigen::VectorXd d = Eigen::VectorXd::Ones(size);
  for (Eigen::Index i = 0; i < size; ++i) {
    const double v = information(i, i);
    if (v > 0.0 && std::isfinite(v)) d[i] = 1.0 / std::sqrt(v);
  }
  Eigen::MatrixXd scaled = d.asDiagonal() * information * d.asDiagonal();
  for (Eigen::Index i = 0; i < size; ++i) {
    if (!(information(i, i) > 0.0 && std::isfinite(information(i, i)))) {
      scaled.row(i).setZero();
      scaled.col(i).setZero();
      scaled(i, i) = 1.0;
    }
  }
  if (!scaled.allFinite()) return d.asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(scaled);
  const Eigen::VectorXd values = eigen.eigenvalues().cwiseMax(1e-8 * eigen.eigenvalues().maxCoeff());
  return d.asDiagonal() * eigen.eigenvectors() * values.cwiseSqrt().cwiseInverse().asDiagonal();
}

// "[B[0,0], B[0,1]], [B[1,0], B[1,1]]": the parameters of each direction the
// information does not determine (eigenvectors with eigenvalues below
// `threshold`). Several such directions span a space whose eigenvectors are
// any rotation of each other, so they are first brought to reduced row
// echelon form: each direction then starts at its own parameter and they
// share as few as possible, which is what a reader can act on.
std::string describe_unidentified(const Eigen::MatrixXd& vectors, const Eigen::VectorXd& values, double threshold,
                                  const std::vector<std::string>& names) {
  std::vector<Eigen::Index> null;
  for (Eigen::Index k = 0; k < values.size(); ++k) {
    if (values[k] < threshold) null.push_back(k);
  }
  Eigen::MatrixXd rows(static_cast<Eigen::Index>(null.size()), vectors.rows());
  for (std::size_t r = 0; r < null.size(); ++r)
    rows.row(static_cast<Eigen::Index>(r)) = vectors.col(null[r]).transpose();
  Eigen::Index pivot_row = 0;
  for (Eigen::Index c = 0; c < rows.cols() && pivot_row < rows.rows(); ++c) {
    Eigen::Index best = pivot_row;
    rows.col(c).segment(pivot_row, rows.rows() - pivot_row).cwiseAbs().maxCoeff(&best);
    best += pivot_row;
    if (std::abs(rows(best, c)) < 1e-6) continue;
    rows.row(pivot_row).swap(rows.row(best));
    rows.row(pivot_row) /= rows(pivot_row, c);
    for (Eigen::Index r = 0; r < rows.rows(); ++r) {
      if (r != pivot_row) rows.row(r) -= rows(r, c) * rows.row(pivot_row);
    }
    ++pivot_row;
  }
  std::string out;
  for (Eigen::Index r = 0; r < rows.rows(); ++r) {
    const double largest = rows.row(r).cwiseAbs().maxCoeff();
    std::vector<std::pair<double, std::size_t>> parts;  // (weight rounded, parameter)
    for (Eigen::Index i = 0; i < rows.cols(); ++i) {
      const double weight = std::abs(rows(r, i)) / largest;
      if (weight > 0.2) parts.emplace_back(std::round(weight * 1e6), static_cast<std::size_t>(i));
    }
    // Largest first; equal weights in the model's order.
    std::stable_sort(parts.begin(), parts.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
    std::string direction;
    for (const auto& p : parts) direction += (direction.empty() ? "" : ", ") + names[p.second];
    out += (out.empty() ? "[" : ", [") + direction + "]";
  }
  return out;
}

// The start of Q: the bank's, with a positive diagonal. A zero entry (a state
// the bank gave no process noise) starts at a tenth of the measurement
// variance per step when a row of H measures the state alone, otherwise at
// 1e-2 of the largest positive entry (1e-6 if there is none). LBFGS moves in
// log Q, so the start's scale costs a few iterations, never the fit.
Eigen::MatrixXd q_start(const BankConfig& config, const Eigen::MatrixXd& bank_q, double typical_dt, ProcessNoise form) {
  const int n = config.state_dim();
  Eigen::MatrixXd q = 0.5 * (bank_q + bank_q.transpose());
  const double largest = q.diagonal().maxCoeff();
  for (int i = 0; i < n; ++i) {
    if (q(i, i) > 0.0 && std::isfinite(q(i, i))) continue;
    double start = largest > 0.0 ? 1e-2 * largest : 1e-6;
    const Eigen::MatrixXd& h = config.measurement.h;
    for (Eigen::Index c = 0; c < h.rows(); ++c) {
      if (h(c, i) != 0.0 && h.row(c).cwiseAbs().sum() == std::abs(h(c, i))) {
        start = 0.1 * config.measurement.r(c, c) / (h(c, i) * h(c, i)) / typical_dt;
        break;
      }
    }
    q(i, i) = start;
    q.row(i).setZero();
    q.col(i).setZero();
    q(i, i) = start;
  }
  if (form == ProcessNoise::kDiagonal) return Eigen::MatrixXd(q.diagonal().asDiagonal());
  if (Eigen::LLT<Eigen::MatrixXd>(q).info() != Eigen::Success) return Eigen::MatrixXd(q.diagonal().asDiagonal());
  return q;
}

double median_step(const std::vector<const Trajectory*>& logs) {
  std::vector<double> steps;
  for (const Trajectory* t : logs) {
    for (int k = 1; k < t->size(); ++k) {
      const double dt = t->t[static_cast<std::size_t>(k)] - t->t[static_cast<std::size_t>(k) - 1];
      if (dt > 0.0 && std::isfinite(dt)) steps.push_back(dt);
    }
  }
  if (steps.empty()) return 1.0;
  std::nth_element(steps.begin(), steps.begin() + static_cast<std::ptrdiff_t>(steps.size() / 2), steps.end());
  return steps[steps.size() / 2];
}

std::string mode_name(const BankConfig& config, int mode) {
  return "mode '" + config.modes[static_cast<std::size_t>(mode)].name + "'";
}

// Fits one group of modes: one mode alone, or every mode jointly with R.
// The likelihood's filter pass and its derivatives are written for z = H x
// + v: a bank measuring model outputs is fitted with the window objective.
void refuse_outputs(const Bank& bank) {
  if (!bank.config.measurement.outputs.empty()) {
    throw FitError("the likelihood objective does not fit banks that measure model outputs (measurement.outputs: " +
                   bank.config.measurement.outputs.front() +
                   (bank.config.measurement.outputs.size() > 1 ? ", ...)" : ")") +
                   "; use the window objective (--objective window)");
  }
}

std::map<int, FitReport> fit_group(Bank* bank, const std::vector<std::pair<int, std::vector<const Trajectory*>>>& group,
                                   const LikelihoodFitOptions& options) {
  const BankConfig& config = bank->config;
  const int n = config.state_dim();
  const int m = static_cast<int>(config.measurement.h.rows());
  const std::string who = group.size() == 1 && !options.fit_measurement_noise
                              ? mode_name(config, group.front().first)
                              : "the bank's joint fit (" + std::to_string(group.size()) + " modes and R)";
  // The logs a whole-fit error is about, for its message.
  std::string logs_text;
  int listed = 0;
  for (const auto& entry : group) {
    for (const Trajectory* t : entry.second) {
      if (++listed <= 3) logs_text += (logs_text.empty() ? "" : ", ") + t->source;
    }
  }
  if (listed > 3) logs_text += " and " + std::to_string(listed - 3) + " more";
  logs_text = " (logs: " + logs_text + ")";

  // Blocks and the start.
  std::vector<ModeBlock> blocks;
  std::vector<double> start;
  std::vector<std::string> warnings_all;
  for (const auto& [mode, logs] : group) {
    ModeBlock b;
    b.mode = mode;
    b.model = bank->models[static_cast<std::size_t>(mode)].get();
    b.logs = logs;
    b.par = parameterization_of(*b.model, n, m, options);
    b.q_form = options.process_noise;
    b.num_q_coordinates = q_coordinates(options.process_noise, n);
    b.start_parameters.resize(static_cast<Eigen::Index>(b.model->parameter_info().size()));
    b.model->get_parameters(b.start_parameters);
    b.fixed_q = config.modes[static_cast<std::size_t>(mode)].q_intensity;
    const std::string name = mode_name(config, mode);
    if (b.par.size() == 0) {
      throw FitError(name + ": nothing to fit: no model parameters, Q kept and R not fitted");
    }
    b.offset = static_cast<int>(start.size());
    for (int p = 0; p < b.par.num_model(); ++p) {
      const sdk::ParameterInfo& info =
          b.model->parameter_info()[static_cast<std::size_t>(b.par.model_index[static_cast<std::size_t>(p)])];
      Bounded bound{info.lower_bound, info.upper_bound};
      b.bounds.push_back(bound);
      const double value = bound.inside(b.start_parameters[b.par.model_index[static_cast<std::size_t>(p)]]);
      start.push_back(bound.coordinate(value));
    }
    if (options.process_noise != ProcessNoise::kKeep) {
      const Eigen::MatrixXd q0 = q_start(config, b.fixed_q, median_step(logs), options.process_noise);
      if (options.process_noise == ProcessNoise::kDiagonal) {
        for (int i = 0; i < n; ++i) start.push_back(std::log(q0(i, i)));
      } else {
        const Eigen::MatrixXd l = Eigen::LLT<Eigen::MatrixXd>(q0).matrixL();
        for (int i = 0; i < n; ++i) {
          for (int j = 0; j <= i; ++j) start.push_back(i == j ? std::log(l(i, i)) : l(i, j));
        }
      }
      const Eigen::MatrixXd& bank_q = b.fixed_q;
      if (options.process_noise == ProcessNoise::kDiagonal &&
          (bank_q - Eigen::MatrixXd(bank_q.diagonal().asDiagonal())).cwiseAbs().maxCoeff() > 0.0) {
        b.warnings.push_back("the bank's Q has off-diagonal entries; a diagonal Q was fitted");
      }
    }
    blocks.push_back(std::move(b));
  }
  const int r_offset = static_cast<int>(start.size());
  if (options.fit_measurement_noise) {
    for (int c = 0; c < m; ++c) {
      const double r = config.measurement.r(c, c);
      start.push_back(std::log(r > 0.0 && std::isfinite(r) ? r : 1e-6));  // a bank R is positive definite
    }
    if ((config.measurement.r - Eigen::MatrixXd(config.measurement.r.diagonal().asDiagonal())).cwiseAbs().maxCoeff() >
        0.0) {
      warnings_all.push_back("the bank's R has off-diagonal entries; a diagonal R was fitted");
    }
  }
  for (ModeBlock& b : blocks) {
    for (int p = 0; p < b.par.num_model() + b.num_q_coordinates; ++p) b.local_to_global.push_back(b.offset + p);
    for (int e = 0; e < b.par.num_r(); ++e) b.local_to_global.push_back(r_offset + e);
  }

  // Restores the models if anything below throws.
  struct Restore {
    std::vector<std::pair<sdk::MotionModel*, Eigen::VectorXd>> saved;
    bool armed = true;
    ~Restore() {
      if (!armed) return;
      for (auto& [model, values] : saved) model->set_parameters(values, nullptr);
    }
  } restore;
  for (const ModeBlock& b : blocks) restore.saved.emplace_back(b.model, b.start_parameters);

  Problem problem(config, std::move(blocks), options.fit_measurement_noise, r_offset, options.numeric_derivatives);
  Eigen::VectorXd phi0 = Eigen::Map<const Eigen::VectorXd>(start.data(), static_cast<Eigen::Index>(start.size()));

  // The start: finite, linear in Q, and the information that scales the
  // solver's coordinates.
  for (const ModeBlock& b : problem.blocks()) {
    int measured = 0;
    for (const Trajectory* t : b.logs) {
      for (int k = 0; k < t->size(); ++k) measured += t->z.col(k).array().isFinite().any() ? 1 : 0;
    }
    if (measured == 0) {
      std::string sources;
      for (const Trajectory* t : b.logs) sources += (sources.empty() ? "" : ", ") + t->source;
      throw FitError(mode_name(config, b.mode) + ": no measured row in its logs (" + sources +
                     "): every measurement is missing");
    }
    if (options.process_noise != ProcessNoise::kKeep) {
      const NaturalValues v = problem.natural(b, phi0.data());
      if (!b.model->set_parameters(v.parameters, nullptr)) {
        throw FitError(mode_name(config, b.mode) + ": the model rejected its starting parameters");
      }
      for (const Trajectory* t : b.logs) {
        if (t->size() < 2) continue;
        std::string why;
        if (!check_linear_in_intensity(*b.model, v.q, config.initial_state, t->u.col(0), t->t[1] - t->t[0], &why)) {
          if (::skidimm::internal::model_under_parameter_uncertainty(*b.model) != nullptr) {
            // A bank as fit and tune write it with --parameter-uncertainty (the bundled BorealTC banks).
            throw FitError(mode_name(config, b.mode) +
                           ": its parameter_covariance (the uncertainty of the fit it came from) is added to its "
                           "process noise, which the likelihood objective cannot fit Q through; fit it by the window "
                           "objective (--parameter-uncertainty estimates the covariance anew), or start from a bank "
                           "without parameter_covariance");
          }
          throw FitError(mode_name(config, b.mode) + ": " + why);
        }
        break;
      }
    }
  }
  // The start: finite, what the model's steps depend on (observed at every
  // row), and the information that whitens the solver's coordinates.
  auto fresh_structures = [&] {
    std::vector<StepStructure> out(problem.blocks().size());
    for (std::size_t j = 0; j < out.size(); ++j) out[j].reset(n, problem.blocks()[j].par.num_model());
    return out;
  };
  std::vector<StepStructure> structure = fresh_structures();
  Problem::Result first;
  if (!problem.evaluate(phi0.data(), true, true, &first, nullptr, &structure)) {
    throw FitError(first.failure + "; the negative log-likelihood is not finite at the starting values of " + who +
                   "; check the log's inputs and measurements there");
  }
  // Finite but absurd: a cell of 1e100 keeps every number finite, and the
  // fit would then be that row's (or fail with a misleading message).
  if (const std::string row = problem.absurd_row(phi0.data()); !row.empty()) {
    throw FitError(row + " in the negative log-likelihood at the starting values of " + who +
                   ": an absurd input or measurement there (a corrupt cell?); fix or remove that row");
  }

  // Solve, skipping the derivatives the model was seen not to have. LBFGS
  // runs on coordinates whitened by the information at its start point; a
  // first short run brings the start closer to the optimum, where the
  // information is a better Hessian, and the rest runs whitened there.
  // Every run ends with everything computed again at its solution; should
  // the model show a dependence it did not show before (a derivative that
  // vanished only at the start), the solve continues with it, and after two
  // such rounds with every derivative computed at every step.
  constexpr int kFirstRunIterations = 10;
  ceres::GradientProblemSolver::Options solver_options;
  solver_options.line_search_direction_type = ceres::LBFGS;
  // In the whitened coordinates a unit is about one standard deviation: stop
  // when the gradient says the optimum is within 1e-6 of one.
  solver_options.gradient_tolerance = 1e-6;
  solver_options.function_tolerance = 1e-13;
  solver_options.parameter_tolerance = 1e-12;
  solver_options.logging_type = ceres::SILENT;
  ceres::GradientProblemSolver::Summary summary;
  Eigen::VectorXd phi = phi0;
  const double initial_cost = first.cost;
  Problem::Result final_result = std::move(first);
  int iterations = 0;
  int structure_rounds = 0;
  for (int run = 0;; ++run) {
    const int budget = options.max_iterations - iterations;
    if (budget <= 0) break;
    const bool full = structure_rounds >= 2;
    solver_options.max_num_iterations = run == 0 ? std::min(kFirstRunIterations, budget) : budget;
    SolverProgress solver_progress(options.progress, who + " (likelihood objective)", iterations);
    solver_options.callbacks.clear();
    if (options.progress) solver_options.callbacks.push_back(&solver_progress);
    auto* objective =
        new ScaledObjective(&problem, phi, whitening(final_result.information_phi), full ? nullptr : &structure);
    ceres::GradientProblem gradient_problem(objective);  // takes ownership
    std::vector<double> psi(static_cast<std::size_t>(problem.size()), 0.0);
    ceres::Solve(solver_options, gradient_problem, psi.data(), &summary);
    iterations += std::max(0, static_cast<int>(summary.iterations.size()) - 1);
    phi = objective->phi_of(psi.data());
    std::vector<StepStructure> seen = fresh_structures();
    if (!problem.evaluate(phi.data(), true, true, &final_result, nullptr, &seen)) {
      // Ceres returns the last accepted point, which evaluated; this only
      // happens if the model is not deterministic.
      throw FitError(who + logs_text + ": the solution could not be evaluated again: " + final_result.failure);
    }
    bool covered = true;
    for (std::size_t j = 0; j < seen.size(); ++j) covered = covered && structure[j].covers(seen[j]);
    if (!covered && !full) {
      for (std::size_t j = 0; j < seen.size(); ++j) structure[j].merge(seen[j]);
      ++structure_rounds;
      continue;
    }
    if (run == 0 && summary.termination_type == ceres::NO_CONVERGENCE) continue;  // the first, short run
    break;
  }

  std::vector<std::string> warnings = warnings_all;
  if (summary.termination_type == ceres::NO_CONVERGENCE) {
    warnings.push_back("LBFGS stopped after " + std::to_string(options.max_iterations) +
                       " iterations without converging; the values are the best found");
  } else if (summary.termination_type == ceres::FAILURE) {
    warnings.push_back("LBFGS stopped early (" + summary.message + "); the values are the best found");
  }

  // The information in natural units over the group: per mode [model, Q]
  // then R, the R entries shared by every mode.
  std::vector<std::string> names;
  std::vector<std::pair<std::string, std::string>> described;  // (name, the model's description of it)
  std::vector<std::vector<int>> natural_index;  // per mode: its par entries -> joint natural index
  int joint = 0;
  for (const ModeBlock& b : problem.blocks()) {
    std::vector<int> index;
    const std::string prefix =
        problem.blocks().size() > 1 ? config.modes[static_cast<std::size_t>(b.mode)].name + "." : "";
    for (const sdk::ParameterInfo& info : b.model->parameter_info()) {
      described.emplace_back(prefix + info.name, info.description);
    }
    const std::vector<std::string> mode_names = names_of(b.par, *b.model);
    for (int p = 0; p < b.par.num_model() + b.par.num_q(); ++p) {
      index.push_back(joint++);
      names.push_back(prefix + mode_names[static_cast<std::size_t>(p)]);
    }
    natural_index.push_back(index);
  }
  const int r_natural = joint;
  if (options.fit_measurement_noise) {
    for (int c = 0; c < m; ++c) names.push_back(r_name(c));
    joint += m;
  }
  for (std::size_t j = 0; j < problem.blocks().size(); ++j) {
    const ModeBlock& b = problem.blocks()[j];
    for (int e = 0; e < b.par.num_r(); ++e) natural_index[j].push_back(r_natural + e);
  }
  Eigen::MatrixXd information = Eigen::MatrixXd::Zero(joint, joint);
  Eigen::VectorXd values(joint);
  for (std::size_t j = 0; j < problem.blocks().size(); ++j) {
    const ModeBlock& b = problem.blocks()[j];
    const Eigen::MatrixXd& mode_information = final_result.modes[j].acc.information;
    const NaturalValues& v = final_result.natural[j];
    const std::vector<int>& index = natural_index[j];
    for (std::size_t a = 0; a < index.size(); ++a) {
      for (std::size_t c = 0; c < index.size(); ++c) {
        information(index[a], index[c]) += mode_information(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(c));
      }
    }
    for (int p = 0; p < b.par.num_model(); ++p) {
      values[index[static_cast<std::size_t>(p)]] = v.parameters[b.par.model_index[static_cast<std::size_t>(p)]];
    }
    for (int e = 0; e < b.par.num_q(); ++e) {
      const auto& [qi, qj] = b.par.q_entries[static_cast<std::size_t>(e)];
      values[index[static_cast<std::size_t>(b.par.num_model() + e)]] = v.q(qi, qj);
    }
  }
  const Eigen::MatrixXd fitted_r = problem.r(phi.data());
  for (int c = 0; c < (options.fit_measurement_noise ? m : 0); ++c) values[r_natural + c] = fitted_r(c, c);

  // Identifiability: eigenvalues of the information scaled to unit diagonal
  // (a correlation matrix), so the units of the parameters do not matter.
  Eigen::VectorXd unit = Eigen::VectorXd::Zero(joint);
  std::string unexcited;
  for (int i = 0; i < joint; ++i) {
    const double d = information(i, i);
    if (d > 0.0 && std::isfinite(d)) {
      unit[i] = 1.0 / std::sqrt(d);
    } else {
      unexcited += (unexcited.empty() ? "[" : ", [") + names[static_cast<std::size_t>(i)] + "]";
    }
  }
  const Eigen::MatrixXd scaled = unit.asDiagonal() * information * unit.asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(scaled);
  const Eigen::VectorXd eigenvalues = eigen.eigenvalues();
  const double largest = eigenvalues.maxCoeff();
  const double threshold = options.identifiability_threshold * largest;
  if (unexcited.empty()) unexcited = describe_unidentified(eigen.eigenvectors(), eigenvalues, threshold, names);
  if (!unexcited.empty() || !(largest > 0.0)) {
    const std::string glossary = internal::parameter_glossary(unexcited, described);
    throw FitError(who + logs_text + ": the logs do not identify every parameter: no information on the combinations " +
                   unexcited +
                   "; drive maneuvers that move them (turns and speed changes), or fix them; the window objective "
                   "(--objective window --hold-unexcited) fits what the logs determine and holds the rest where it "
                   "started, which this objective cannot (docs/fitting.md)" +
                   (glossary.empty() ? std::string() : ". What they are: " + glossary));
  }
  const double smallest = eigenvalues.minCoeff();
  // Covariance = information^-1 = D (V L^-1 V') D, from the eigen decomposition above.
  const Eigen::MatrixXd covariance =
      unit.asDiagonal() *
      (eigen.eigenvectors() * eigenvalues.cwiseInverse().asDiagonal() * eigen.eigenvectors().transpose()) *
      unit.asDiagonal();
  Eigen::VectorXd deviation = covariance.diagonal().cwiseMax(0.0).cwiseSqrt();

  // Leave the models at the solution; write R.
  for (std::size_t j = 0; j < problem.blocks().size(); ++j) {
    const ModeBlock& b = problem.blocks()[j];
    std::string error;
    if (!b.model->set_parameters(final_result.natural[j].parameters, &error)) {
      throw FitError(mode_name(config, b.mode) + ": the model rejected the fitted parameters: " + error);
    }
  }
  restore.armed = false;
  if (options.fit_measurement_noise) bank->config.measurement.r = fitted_r;

  std::map<int, FitReport> reports;
  for (std::size_t j = 0; j < problem.blocks().size(); ++j) {
    const ModeBlock& b = problem.blocks()[j];
    const std::vector<int>& index = natural_index[j];
    const LikelihoodEvaluation e = to_evaluation(final_result.modes[j]);
    const std::vector<std::string> mode_names = names_of(b.par, *b.model);
    FitReport report;
    report.warnings = b.warnings;
    report.warnings.insert(report.warnings.end(), warnings.begin(), warnings.end());
    auto estimate = [&](int p) {
      const int i = index[static_cast<std::size_t>(p)];
      return ParameterEstimate{mode_names[static_cast<std::size_t>(p)], values[i], deviation[i]};
    };
    auto check_determined = [&](const ParameterEstimate& pe) {
      if (pe.standard_deviation > std::max(std::abs(pe.value), 1e-12)) {
        report.warnings.push_back("parameter '" + pe.name + "' is poorly determined: standard deviation " +
                                  number(pe.standard_deviation) + " exceeds its value " + number(pe.value));
      }
    };
    for (int p = 0; p < b.par.num_model(); ++p) {
      const ParameterEstimate pe = estimate(p);
      report.parameters.push_back(pe);
      if (b.bounds[static_cast<std::size_t>(p)].near_bound(pe.value)) {
        report.warnings.push_back("parameter '" + pe.name + "' = " + number(pe.value) +
                                  " ended on its bound; its standard deviation is not meaningful");
      } else {
        check_determined(pe);
      }
    }
    for (int e = 0; e < b.par.num_q() + b.par.num_r(); ++e) {
      const ParameterEstimate pe = estimate(b.par.num_model() + e);
      report.noise_parameters.push_back(pe);
      check_determined(pe);
    }
    report.q_intensity = final_result.natural[j].q;
    if (options.fit_measurement_noise) report.measurement_noise = fitted_r;
    report.rmse = e.rmse;
    report.mean_nis = e.mean_nis;
    report.residuals = e.residuals;
    report.measured_rows = e.measured_rows;
    report.negative_log_likelihood = e.negative_log_likelihood;
    report.negative_log_likelihood_per_row = e.negative_log_likelihood / std::max(1, e.measured_rows);
    report.derivatives = b.par.num_model() == 0                   ? "none"
                         : final_result.modes[j].acc.used_numeric ? "numeric"
                                                                  : "autodiff";
    report.iterations = iterations;
    report.initial_cost = initial_cost;
    report.final_cost = final_result.cost;
    report.condition_number = largest / smallest;
    reports[b.mode] = report;
  }
  return reports;
}

}  // namespace

std::vector<FitReport> fit_likelihood(Bank* bank, const std::vector<ModeLogs>& data,
                                      const LikelihoodFitOptions& options) {
  if (data.empty()) throw FitError("no logs to fit");
  refuse_outputs(*bank);
  // Pool the logs of a mode listed more than once, in order of first mention.
  std::vector<std::pair<int, std::vector<const Trajectory*>>> modes;
  for (const ModeLogs& d : data) {
    check_mode(*bank, d.mode);
    auto at = std::find_if(modes.begin(), modes.end(), [&](const auto& e) { return e.first == d.mode; });
    if (at == modes.end()) {
      modes.emplace_back(d.mode, std::vector<const Trajectory*>{});
      at = modes.end() - 1;
    }
    for (const Trajectory& t : d.logs) at->second.push_back(&t);
  }
  for (const auto& [mode, logs] : modes) {
    if (logs.empty()) throw FitError(mode_name(bank->config, mode) + ": no logs given");
  }
  std::map<int, FitReport> reports;
  if (options.fit_measurement_noise) {
    reports = fit_group(bank, modes, options);
  } else {
    for (const auto& entry : modes) {
      for (auto& [mode, report] : fit_group(bank, {entry}, options)) reports[mode] = std::move(report);
    }
  }
  std::vector<FitReport> out;
  for (const ModeLogs& d : data) out.push_back(reports[d.mode]);
  return out;
}

LikelihoodEvaluation evaluate_likelihood(const Bank& bank, const ModeLogs& data) {
  check_mode(bank, data.mode);
  const Parameterization none;
  const ModeEvaluation e =
      evaluate_mode(bank.config, bank.models[static_cast<std::size_t>(data.mode)].get(), pointers(data), none,
                    bank.config.modes[static_cast<std::size_t>(data.mode)].q_intensity, bank.config.measurement.r,
                    false, false, false, true);
  return to_evaluation(e);
}

LikelihoodEvaluation evaluate_likelihood_derivatives(Bank* bank, const ModeLogs& data,
                                                     const LikelihoodFitOptions& options) {
  refuse_outputs(*bank);
  check_mode(*bank, data.mode);
  sdk::MotionModel* model = bank->models[static_cast<std::size_t>(data.mode)].get();
  const Parameterization par = parameterization_of(*model, bank->config.state_dim(),
                                                   static_cast<int>(bank->config.measurement.h.rows()), options);
  const Eigen::MatrixXd& q = bank->config.modes[static_cast<std::size_t>(data.mode)].q_intensity;
  if (par.num_q() > 0) {
    for (const Trajectory& t : data.logs) {
      if (t.size() < 2) continue;
      std::string why;
      if (!check_linear_in_intensity(*model, q, bank->config.initial_state, t.u.col(0), t.t[1] - t.t[0], &why)) {
        LikelihoodEvaluation out;
        out.negative_log_likelihood = kInfinity;
        out.failure = why;
        return out;
      }
      break;
    }
  }
  // Every derivative computed at every row, except that a step found static
  // at its row (F and Qd independent of x and u) reuses the parameter
  // derivatives of an earlier static step of the same dt.
  StepStructure observed;
  observed.reset(model->state_dim(), par.num_model());
  const ModeEvaluation e = evaluate_mode(bank->config, model, pointers(data), par, q, bank->config.measurement.r, true,
                                         options.numeric_derivatives, true, true, nullptr, &observed);
  LikelihoodEvaluation out = to_evaluation(e);
  out.parameter_names = names_of(par, *model);
  if (e.ok()) {
    out.gradient = e.acc.gradient;
    out.information = e.acc.information;
  }
  return out;
}

}  // namespace fitting
}  // namespace skidimm
