// fit() (model_fitter.h), the window objective's driver: per problem (a
// mode, or the bank's shared parameters) it builds the parameter block and
// the window problem (window_cost.h, condensed_windows.h), solves it holding
// what the logs do not excite, estimates the parameters' uncertainty, and
// reports each mode at the solution (evaluate(), one_step_evaluation.cc).
#include "skidimm/fitting/model_fitter.h"

#include <ceres/ceres.h>

#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <set>

#include "affine_subspace_manifold.h"
#include "bounded_median.h"
#include "condensed_windows.h"
#include "measurement_layout.h"
#include "parameter_covariance.h"
#include "parameter_glossary.h"
#include "solver_progress.h"
#include "window_cost.h"

namespace skidimm {
namespace fitting {

namespace {

using internal::CondensedWindows;
using internal::for_each_window;
using internal::has_parameter_jacobian;
using internal::layout_of;
using internal::MeasurementLayout;
using internal::NumericWindowResidual;
using internal::ParameterMapping;
using internal::Window;
using internal::window_text;
using internal::WindowCost;
using internal::WindowWorkspace;

ceres::LossFunction* make_loss(const FitOptions& options) {
  if (options.loss == "huber") return new ceres::HuberLoss(options.loss_scale);
  if (options.loss == "cauchy") return new ceres::CauchyLoss(options.loss_scale);
  if (options.loss == "none") return nullptr;
  throw FitError("unknown loss '" + options.loss + "' (expected huber, cauchy or none)");
}

// "B[0,0], B[0,1]": the parameters that move along a direction in parameter
// space (a unit vector), largest components first; the largest always.
std::string describe_direction(const Eigen::Ref<const Eigen::VectorXd>& direction,
                               const std::vector<std::string>& names) {
  std::vector<std::pair<double, std::string>> parts;
  Eigen::Index largest = 0;
  direction.cwiseAbs().maxCoeff(&largest);
  for (Eigen::Index i = 0; i < direction.size(); ++i) {
    if (std::abs(direction[i]) > 0.2 || i == largest) {
      parts.emplace_back(std::abs(direction[i]), names[static_cast<std::size_t>(i)]);
    }
  }
  std::sort(parts.rbegin(), parts.rend());
  std::string out;
  for (const auto& p : parts) out += (out.empty() ? "" : ", ") + p.second;
  return out;
}

// "[B[0,0], B[0,1]], [A[1,1]]": the parameters in each direction the logs do
// not excite (right singular vectors of the Jacobian with negligible singular
// values, here in parameter space).
std::string describe_unexcited(const Eigen::MatrixXd& directions, const Eigen::VectorXd& singular, double threshold,
                               const std::vector<std::string>& names) {
  std::string out;
  for (Eigen::Index k = 0; k < singular.size(); ++k) {
    if (singular[k] >= threshold) continue;
    out += (out.empty() ? "[" : ", [") + describe_direction(directions.col(k), names) + "]";
  }
  return out;
}

using Group = std::vector<const ModeLogs*>;

// The parameters one problem fits: for kMode a mode's own, for kBank the
// union of the group's bank-level names.
struct ParameterBlock {
  std::vector<std::string> names;
  std::vector<std::pair<std::string, std::string>> described;  // (name, the model's description of it)
  std::vector<double> lower, upper;
  std::vector<double> values;  // the problem's parameter block: Ceres holds a pointer into it
  // Per mode: its model's flat parameters and their mapping into the block.
  std::map<int, std::pair<Eigen::VectorXd, ParameterMapping>> per_mode;
  std::size_t size() const { return values.size(); }
};

ParameterBlock parameter_block(const Bank& bank, const Group& group, sdk::ParameterScope scope) {
  ParameterBlock block;
  for (const ModeLogs* d : group) {
    const sdk::MotionModel& model = *bank.models[static_cast<std::size_t>(d->mode)];
    const auto& info = model.parameter_info();
    Eigen::VectorXd base(static_cast<Eigen::Index>(info.size()));
    model.get_parameters(base);
    ParameterMapping mapping;
    for (std::size_t i = 0; i < info.size(); ++i) {
      if (info[i].scope != scope) continue;
      auto at = std::find(block.names.begin(), block.names.end(), info[i].name);
      if (at == block.names.end()) {
        block.names.push_back(info[i].name);
        block.described.emplace_back(info[i].name, info[i].description);
        block.lower.push_back(info[i].lower_bound);
        block.upper.push_back(info[i].upper_bound);
        block.values.push_back(base[static_cast<Eigen::Index>(i)]);
        at = block.names.end() - 1;
      }
      mapping.model_index.push_back(static_cast<int>(i));
      mapping.block_index.push_back(static_cast<int>(at - block.names.begin()));
    }
    block.per_mode[d->mode] = {base, mapping};
  }
  return block;
}

// " (logs: a, b, c and 4 more)": the logs a whole-fit error is about.
std::string listed_logs(const Group& group) {
  std::string text;
  int listed = 0;
  for (const ModeLogs* d : group) {
    for (const Trajectory& t : d->logs) {
      if (++listed <= 3) text += (text.empty() ? "" : ", ") + t.source;
    }
  }
  if (listed > 3) text += " and " + std::to_string(listed - 3) + " more";
  return " (logs: " + text + ")";
}

// Every window evaluated at the starting values before the solver sees it.
// A window whose prediction is not finite there (an input of 1e200, say)
// would make the cost infinite and the fit meaningless: add() names its row.
// Finite but absurd windows (an input of 1e100) are compared with the others
// by check_absurd().
class StartingValueCheck {
 public:
  StartingValueCheck(const std::vector<double>* start, const std::string* who) : start_(start), who_(who) {}

  void add(const WindowCost& cost, const Trajectory& t, const Window& w) {
    r_.resize(static_cast<std::size_t>(w.residuals));
    const double* p[] = {start_->data()};
    const bool ok = cost.EvaluateWindow(w, p, r_.data(), nullptr);
    bool finite = ok;
    double largest_residual = 0.0;
    for (double v : r_) {
      finite = finite && std::isfinite(v) && std::abs(v) < 1e150;
      largest_residual = std::max(largest_residual, std::abs(v));
    }
    if (!finite) {
      // A model that failed says why (a plugin's exception, its own report);
      // otherwise the numbers themselves are the suspects.
      const std::string failure = ok ? "" : cost.model_failure();
      throw FitError(window_text(t, w) +
                     (failure.empty()
                          ? " is not finite (or absurd) with the starting values of " + *who_ +
                                "; check the log's inputs and measurements there"
                          : " failed with the starting values of " + *who_ + ": the model failed: " + failure));
    }
    start_residuals_.add(largest_residual);
    if (largest_residual > worst_residual_) {
      worst_residual_ = largest_residual;
      worst_log_ = &t;
      worst_window_ = w;
    }
  }

  // One window a million times further from its measurements than the
  // typical one (residuals are in units of the measurement noise, R) is not
  // a poor starting value but a corrupt cell: it would dominate the fit,
  // which would then end "converged" with an RMSE of 1e80. Name it.
  void check_absurd() {
    if (start_residuals_.empty()) return;
    const double median = start_residuals_.median();
    if (internal::is_absurd_miss(worst_residual_, median)) {
      throw FitError(window_text(*worst_log_, worst_window_) + " misses its measurements by " +
                     internal::miss_text(worst_residual_) + " times their noise (R) with the starting values of " +
                     *who_ + ", against " + internal::miss_text(median) +
                     " for the median window: an absurd input or measurement there (a corrupt cell?); "
                     "fix or remove it");
    }
  }

 private:
  const std::vector<double>* start_;
  const std::string* who_;
  std::vector<double> r_;
  // Each window's largest residual (in units of R) at the starting values,
  // and the worst window.
  internal::BoundedMedian start_residuals_;
  double worst_residual_ = -1.0;
  const Trajectory* worst_log_ = nullptr;
  Window worst_window_{};  // a copy: each log's windows go when its loop ends
};

// What build_window_problem() added to the problem.
struct WindowProblem {
  int residuals = 0;
  int most_residuals = 0;  // of one window
  bool all_analytic = true;
  std::vector<std::unique_ptr<WindowCost>> log_windows;  // the condensed problem's, per log
};

// Adds every window of the group's logs to `problem`: one residual block per
// window, or, for a large problem with exact derivatives, all of them as one
// CondensedWindows block. Checks each window at the starting values.
WindowProblem build_window_problem(Bank* bank, const Group& group, const std::map<int, MeasurementLayout>& layouts,
                                   ParameterBlock* block, const FitOptions& options, const std::string& who,
                                   ceres::Problem* problem) {
  WindowProblem out;
  std::map<const sdk::MotionModel*, std::shared_ptr<WindowWorkspace>> workspaces;  // per model, its windows'
  std::vector<std::string> empty_sources;
  StartingValueCheck start(&block->values, &who);
  // How many residuals, and whether every log has exact derivatives: a
  // large problem so differentiated is condensed (CondensedWindows).
  long total_residuals = 0;
  bool condense = !options.numeric_derivatives;
  for (const ModeLogs* d : group) {
    const MeasurementLayout& m = layouts.at(d->mode);
    for (const Trajectory& t : d->logs) {
      condense = condense && has_parameter_jacobian(*bank->models[static_cast<std::size_t>(d->mode)], m, t);
      for_each_window(m, t, options.window, [&](const Window& w) {
        total_residuals += w.residuals;
        out.most_residuals = std::max(out.most_residuals, w.residuals);
      });
    }
  }
  condense = condense && total_residuals > options.condense_above;
  std::vector<CondensedWindows::Log> condensed_logs;
  const int block_size = static_cast<int>(block->size());
  double* values = block->values.data();
  for (const ModeLogs* d : group) {
    if (d->logs.empty()) throw FitError(who + ": no logs given");
    const MeasurementLayout& m = layouts.at(d->mode);
    const auto& [base, mapping] = block->per_mode.at(d->mode);
    for (const Trajectory& t : d->logs) {
      sdk::MotionModel* model = bank->models[static_cast<std::size_t>(d->mode)].get();
      std::shared_ptr<WindowWorkspace>& workspace = workspaces[model];
      if (!workspace) workspace = std::make_shared<WindowWorkspace>();
      if (condense) {
        out.log_windows.push_back(
            std::make_unique<WindowCost>(model, base, mapping, &m, Window{&t, 0, {}, 0}, block_size, workspace));
        const int before = out.residuals;
        for_each_window(m, t, options.window, [&](const Window& w) {
          start.add(*out.log_windows.back(), t, w);
          out.residuals += w.residuals;
        });
        if (out.residuals == before) empty_sources.push_back(t.source);
        condensed_logs.push_back({out.log_windows.back().get(), &t, &m});
        continue;
      }
      std::vector<Window> windows;
      for_each_window(m, t, options.window, [&](const Window& w) { windows.push_back(w); });
      if (windows.empty()) {
        // A short segment (a class's log split by fit_when) may hold no
        // window; only a mode with no window at all is an error (below).
        empty_sources.push_back(t.source);
        continue;
      }
      const bool analytic = !options.numeric_derivatives && has_parameter_jacobian(*model, m, t);
      out.all_analytic = out.all_analytic && analytic;
      for (const Window& w : windows) {
        auto window_cost = std::make_unique<WindowCost>(model, base, mapping, &m, w, block_size, workspace);
        start.add(*window_cost, t, w);
        ceres::CostFunction* cost = nullptr;
        if (analytic) {
          cost = window_cost.release();
        } else {
          auto* numeric = new ceres::DynamicNumericDiffCostFunction<NumericWindowResidual, ceres::CENTRAL>(
              new NumericWindowResidual{std::move(window_cost)});
          numeric->AddParameterBlock(block_size);
          numeric->SetNumResiduals(w.residuals);
          cost = numeric;
        }
        problem->AddResidualBlock(cost, make_loss(options), values);
        out.residuals += w.residuals;
      }
    }
  }
  if (condense && out.residuals > 0) {
    problem->AddResidualBlock(
        new CondensedWindows(std::move(condensed_logs), options.window, block_size, out.most_residuals,
                             std::unique_ptr<ceres::LossFunction>(make_loss(options))),
        nullptr, values);
  }
  start.check_absurd();
  if (out.residuals == 0 && !empty_sources.empty()) {
    std::string states;
    for (const std::string& s : bank->config.state_names) states += (states.empty() ? "" : ", ") + s;
    throw FitError(empty_sources.front() + (empty_sources.size() > 1 ? " (and the other logs of " + who + ")" : "") +
                   ": no prediction window: no row measures every state (" + states + ") with a measured row after it");
  }
  return out;
}

// Where the solver left the block, and how well the logs determine it.
struct Solution {
  ceres::Solver::Summary summary;  // of the last solve
  // The directions in parameter space the logs do not excite, each held
  // where it started (unit columns), and a basis of the directions the fit
  // moved (orthonormal columns, the identity when it held nothing): every
  // uncertainty lives in the latter.
  Eigen::MatrixXd held;
  Eigen::MatrixXd free_basis;
  double largest = 0.0, smallest = 0.0;  // singular values of the Jacobian at the solution
  double first_initial_cost = -1.0;

  // A parameter no free direction moves: held entirely at its start.
  bool holds_whole(std::size_t parameter) const {
    return free_basis.row(static_cast<Eigen::Index>(parameter)).norm() < 1e-12;
  }
};

// Solves; with hold_unexcited, the directions the logs do not excite are held
// where they started and the rest solved again.
Solution solve(const FitOptions& options, const std::string& who, const std::string& logs, ParameterBlock* block,
               ceres::Problem* problem) {
  ceres::Solver::Options solver_options;
  // Each Levenberg-Marquardt step solves the normal equations (J'J + D) dx =
  // -J'r by Cholesky: a window problem has thousands of rows and tens of
  // parameters, where forming J'J costs a fraction of a Householder QR of J
  // (the costliest step of a BorealTC fit). The squared condition number is
  // harmless here: the identifiability check below (the Jacobian's own
  // singular values) holds every direction the logs barely excite, and LM's
  // damping keeps the system positive definite while it does.
  solver_options.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.function_tolerance = 1e-12;
  solver_options.parameter_tolerance = 1e-12;
  solver_options.num_threads = 1;  // residual blocks share the model instance
  solver_options.logging_type = ceres::SILENT;
  SolverProgress solver_progress(options.progress, who + " (window objective)");
  if (options.progress) solver_options.callbacks.push_back(&solver_progress);
  Solution s;
  std::vector<double>& values = block->values;
  const Eigen::Index n = static_cast<Eigen::Index>(values.size());
  const Eigen::VectorXd start = Eigen::Map<const Eigen::VectorXd>(values.data(), n);
  s.free_basis = Eigen::MatrixXd::Identity(n, n);
  s.held.resize(n, 0);
  while (true) {
    ceres::Solve(solver_options, problem, &s.summary);
    if (s.first_initial_cost < 0.0) s.first_initial_cost = s.summary.initial_cost;
    if (!s.summary.IsSolutionUsable()) throw FitError(who + logs + ": the solver failed: " + s.summary.message);
    if (!std::isfinite(s.summary.initial_cost) || !std::isfinite(s.summary.final_cost)) {
      throw FitError(who + logs + ": the cost is not finite (" + std::to_string(s.summary.initial_cost) + " -> " +
                     std::to_string(s.summary.final_cost) + "); a cell of the logs is absurd");
    }

    // Identifiability: singular values of the Jacobian at the solution, in
    // the directions still free (Ceres differentiates along the manifold).
    ceres::CRSMatrix crs;
    double cost = 0.0;
    problem->Evaluate(ceres::Problem::EvaluateOptions(), &cost, nullptr, nullptr, &crs);
    Eigen::MatrixXd jacobian = Eigen::MatrixXd::Zero(crs.num_rows, crs.num_cols);
    for (int row = 0; row < crs.num_rows; ++row) {
      for (int k = crs.rows[static_cast<std::size_t>(row)]; k < crs.rows[static_cast<std::size_t>(row) + 1]; ++k) {
        jacobian(row, crs.cols[static_cast<std::size_t>(k)]) = crs.values[static_cast<std::size_t>(k)];
      }
    }
    Eigen::JacobiSVD<Eigen::MatrixXd> svd(jacobian, Eigen::ComputeThinV);
    const Eigen::VectorXd singular = svd.singularValues();
    s.largest = singular[0];
    s.smallest = singular[singular.size() - 1];
    const double threshold = options.identifiability_threshold * s.largest;
    if (s.largest > 0.0 && s.smallest >= threshold) break;
    const Eigen::MatrixXd directions = s.free_basis * svd.matrixV();  // in parameter space
    if (!(s.largest > 0.0)) {
      // No direction stands out against the others: there is none to name.
      throw FitError(who + logs +
                     ": the logs carry no information on any parameter (the fit's residuals do not change with "
                     "them: inputs that never move, or no measured row the model predicts); drive maneuvers that "
                     "move them (turns and speed changes)");
    }
    const std::string unexcited = describe_unexcited(directions, singular, threshold, block->names);
    const std::string glossary = internal::parameter_glossary(unexcited, block->described);
    const std::string what_they_are = glossary.empty() ? "" : ". What they are: " + glossary;
    if (!options.hold_unexcited) {
      throw FitError(who + logs + ": the logs do not excite every parameter: no information on the combinations " +
                     unexcited + "; drive maneuvers that move them (turns and speed changes), or fix them" +
                     (options.hold_unexcited ? "" : " (or let the fit hold them: --hold-unexcited)") + what_they_are);
    }
    // Each unexcited direction is held where it started, and the parameters
    // move the least that fits what the logs do determine: the part of the
    // solution in the unexcited directions goes back to the start's. Holding
    // one parameter per direction instead would let the basis the SVD
    // returns, and round-off between parameters that move alike (two wheel
    // gains on a straight run; the coefficients of dv and turn = abs(dv) on
    // runs turning one way), decide which one carries the fit, and with it
    // how the mode extrapolates; the subspace is what the logs define.
    for (Eigen::Index k = 0; k < singular.size(); ++k) {
      if (singular[k] >= threshold) continue;
      Eigen::VectorXd u = directions.col(k);
      // Components at round-off level belong to no parameter: a direction
      // within some parameters then stays exactly within them.
      const double largest = u.cwiseAbs().maxCoeff();
      for (Eigen::Index i = 0; i < n; ++i) {
        if (std::abs(u[i]) <= 1e-9 * largest) u[i] = 0.0;
      }
      u.normalize();
      s.held.conservativeResize(Eigen::NoChange, s.held.cols() + 1);
      s.held.col(s.held.cols() - 1) = u;
    }
    if (s.held.cols() >= n) {
      throw FitError(who + logs + ": the logs do not excite every parameter: no information on the combinations " +
                     unexcited + "; drive maneuvers that move them, or fix them" + what_they_are);
    }
    // The free directions: the orthogonal complement of the held ones.
    const Eigen::HouseholderQR<Eigen::MatrixXd> qr(s.held);
    const Eigen::MatrixXd q = qr.householderQ() * Eigen::MatrixXd::Identity(n, n);
    s.free_basis = q.rightCols(n - s.held.cols());
    Eigen::Map<Eigen::VectorXd> x(values.data(), n);
    x = start + s.free_basis * (s.free_basis.transpose() * (x - start));
    for (Eigen::Index i = 0; i < n; ++i) {  // a bound still holds
      x[i] = std::clamp(x[i], block->lower[static_cast<std::size_t>(i)], block->upper[static_cast<std::size_t>(i)]);
    }
    problem->SetManifold(values.data(), new internal::AffineSubspaceManifold(s.free_basis));
  }
  return s;
}

// Each parameter's standard deviation from Ceres' covariance at the
// solution (in the directions the fit moved), scaled by the residuals'
// variance; NaN where Ceres cannot compute it and for parameters held whole.
std::vector<double> standard_deviations(ceres::Problem* problem, ParameterBlock* block, const Solution& s,
                                        int residuals) {
  std::vector<double> deviations(block->size(), std::nan(""));
  ceres::Covariance::Options covariance_options;
  covariance_options.algorithm_type = ceres::DENSE_SVD;
  ceres::Covariance covariance(covariance_options);
  double* values = block->values.data();
  const int dof = residuals - static_cast<int>(block->size());
  if (covariance.Compute({std::make_pair(values, values)}, problem)) {
    std::vector<double> c(block->size() * block->size());
    covariance.GetCovarianceBlock(values, values, c.data());
    const double variance = 2.0 * s.summary.final_cost / dof;  // residuals are whitened by the assumed R
    for (std::size_t i = 0; i < block->size(); ++i) deviations[i] = std::sqrt(c[i * block->size() + i] * variance);
    for (std::size_t i = 0; i < block->size(); ++i) {
      if (s.holds_whole(i)) deviations[i] = std::nan("");
    }
  }
  return deviations;
}

// The covariance of a mode's own parameters (parameter_covariance.h), from
// every window's residuals and exact derivatives at the solution, in the
// model's flat parameter order.
Eigen::MatrixXd mode_parameter_covariance(Bank* bank, const ModeLogs& d, const MeasurementLayout& m,
                                          const ParameterBlock& block, const Eigen::MatrixXd& free_basis,
                                          int most_residuals, const FitOptions& options, const std::string& who) {
  sdk::MotionModel* model = bank->models[static_cast<std::size_t>(d.mode)].get();
  const auto& [base, mapping] = block.per_mode.at(d.mode);
  const int p = static_cast<int>(block.size());
  internal::ParameterCovarianceEstimate estimate(p, static_cast<int>(m.h.rows()));
  std::vector<double> r(static_cast<std::size_t>(std::max(1, most_residuals)));
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> j(std::max(1, most_residuals), p);
  const double* point[] = {block.values.data()};
  std::map<std::string, int> log_index;  // a log's segments (fit_when) are one log
  for (const Trajectory& t : d.logs) {
    const int log = options.parameter_covariance_per_log
                        ? log_index.emplace(t.log, static_cast<int>(log_index.size())).first->second
                        : -1;
    if (t.size() < 2) continue;  // no window
    if (!has_parameter_jacobian(*model, m, t)) {
      throw FitError(who + ": the parameter covariance needs the model's exact derivatives (parameter_jacobian())");
    }
    WindowCost windows(model, base, mapping, &m, Window{&t, 0, {}, 0}, p, std::make_shared<WindowWorkspace>());
    for_each_window(m, t, options.window, [&](const Window& w) {
      double* jacobian = j.data();
      if (!windows.EvaluateWindow(w, point, r.data(), &jacobian)) return;
      int row = 0;
      for (int target : w.targets) {
        for (Eigen::Index c = 0; c < t.z.rows(); ++c) {
          if (!std::isfinite(t.z(c, target))) continue;
          estimate.add(static_cast<int>(c), j.row(row), r[static_cast<std::size_t>(row)], log);
          ++row;
        }
      }
    });
  }
  const Eigen::MatrixXd in_block = estimate.covariance(free_basis);
  const Eigen::Index size = base.size();
  Eigen::MatrixXd covariance = Eigen::MatrixXd::Zero(size, size);
  for (std::size_t a = 0; a < mapping.model_index.size(); ++a) {
    for (std::size_t b = 0; b < mapping.model_index.size(); ++b) {
      covariance(mapping.model_index[a], mapping.model_index[b]) =
          in_block(mapping.block_index[a], mapping.block_index[b]);
    }
  }
  return covariance;
}

// Leaves every model of the group at the solution.
void set_fitted_parameters(Bank* bank, const Group& group, const ParameterBlock& block, const std::string& who) {
  for (const ModeLogs* d : group) {
    const auto& [base, mapping] = block.per_mode.at(d->mode);
    Eigen::VectorXd full = base;
    for (std::size_t i = 0; i < mapping.model_index.size(); ++i) {
      full[mapping.model_index[i]] = block.values[static_cast<std::size_t>(mapping.block_index[i])];
    }
    std::string error;
    if (!bank->models[static_cast<std::size_t>(d->mode)]->set_parameters(full, &error)) {
      throw FitError(who + ": the model rejected the fitted parameters: " + error);
    }
  }
}

// Mode d's report: its one-step errors and Q at the solution (evaluate()),
// the fitted parameters and what the solve says of them.
FitReport report_of(const Bank& bank, const ModeLogs& d, const FitOptions& options, const ParameterBlock& block,
                    const std::vector<double>& deviations, const Eigen::MatrixXd& parameter_covariance,
                    const WindowProblem& windows, const Solution& s) {
  const std::vector<double>& values = block.values;
  FitReport report = evaluate(bank, d, options.correlated_process_noise);
  for (std::size_t i = 0; i < values.size(); ++i) {
    const std::string& name = block.names[i];
    report.parameters.push_back({name, values[i], deviations[i]});
    if (s.holds_whole(i)) {
      report.warnings.push_back("parameter '" + name + "' is held at its starting value " + std::to_string(values[i]) +
                                ": the logs do not excite it");
      continue;
    }
    if (std::isfinite(deviations[i]) && deviations[i] > std::max(std::abs(values[i]), 1e-9)) {
      report.warnings.push_back("parameter '" + name + "' is poorly determined: standard deviation " +
                                std::to_string(deviations[i]) + " exceeds its value");
    }
    if (values[i] <= block.lower[i] || values[i] >= block.upper[i]) {
      report.warnings.push_back("parameter '" + name + "' ended on its bound");
    }
  }
  for (Eigen::Index k = 0; k < s.held.cols(); ++k) {
    bool named = true;  // every member already named as held whole
    for (Eigen::Index i = 0; i < s.held.rows(); ++i) {
      if (s.held(i, k) != 0.0 && !s.holds_whole(static_cast<std::size_t>(i))) named = false;
    }
    if (named) continue;
    report.warnings.push_back("the logs do not excite a combination of " +
                              describe_direction(s.held.col(k), block.names) +
                              ": it is held where it started, and those parameters move the least that fits the rest");
  }
  const auto finite = [](double value) { return std::isfinite(value); };
  if (options.standard_deviations && std::none_of(deviations.begin(), deviations.end(), finite)) {
    report.warnings.push_back("Ceres could not compute the covariance");
  }
  report.parameter_covariance = parameter_covariance;
  report.residuals = windows.residuals;
  report.derivatives = windows.all_analytic ? "autodiff" : "numeric";
  report.iterations = static_cast<int>(s.summary.iterations.size());
  report.initial_cost = s.first_initial_cost;
  report.final_cost = s.summary.final_cost;
  report.condition_number = s.largest / s.smallest;
  if (report.condition_number > 1e6) {
    report.warnings.push_back("the fit is ill-conditioned (condition number " +
                              std::to_string(report.condition_number) + "): some parameters trade off");
  }
  return report;
}

}  // namespace

std::vector<FitReport> fit(Bank* bank, const std::vector<ModeLogs>& data, const FitOptions& options) {
  std::vector<const ModeLogs*> pointers;
  for (const ModeLogs& d : data) pointers.push_back(&d);
  return fit(bank, pointers, options);
}

std::vector<FitReport> fit(Bank* bank, const std::vector<const ModeLogs*>& data, const FitOptions& options) {
  if (!(options.window >= 0.0) || !std::isfinite(options.window)) {
    throw FitError("the window must be 0 (one-step) or a number of seconds");
  }
  std::map<int, MeasurementLayout> layouts;  // per mode fitted
  for (const ModeLogs* d : data) {
    if (layouts.count(d->mode) == 0) layouts.emplace(d->mode, layout_of(bank->config, d->mode));
  }

  // The parameter block: for kMode one problem per mode (its own parameters);
  // for kBank one problem over every mode, on the union of bank-level names.
  std::vector<Group> problems;
  if (options.scope == sdk::ParameterScope::kMode) {
    for (const ModeLogs* d : data) problems.push_back({d});
  } else {
    problems.emplace_back();
    for (const ModeLogs* d : data) problems.back().push_back(d);
  }

  std::map<int, FitReport> reports;
  for (const Group& group : problems) {
    ParameterBlock block = parameter_block(*bank, group, options.scope);
    const std::string who = options.scope == sdk::ParameterScope::kMode
                                ? "mode '" + bank->config.modes[static_cast<std::size_t>(group[0]->mode)].name + "'"
                                : "the bank's shared parameters";
    if (block.names.empty()) {
      throw FitError(who + ": the model has no " +
                     std::string(options.scope == sdk::ParameterScope::kMode ? "per-mode" : "bank-level") +
                     " parameters to fit");
    }

    ceres::Problem::Options problem_options;
    problem_options.loss_function_ownership = ceres::TAKE_OWNERSHIP;
    ceres::Problem problem(problem_options);
    const WindowProblem windows = build_window_problem(bank, group, layouts, &block, options, who, &problem);
    const std::string logs = listed_logs(group);
    if (windows.residuals <= static_cast<int>(block.size())) {
      throw FitError(who + logs + ": the logs are too short: " + std::to_string(windows.residuals) + " residuals for " +
                     std::to_string(block.size()) + " parameters");
    }
    for (std::size_t i = 0; i < block.size(); ++i) {
      const int index = static_cast<int>(i);
      if (std::isfinite(block.lower[i])) problem.SetParameterLowerBound(block.values.data(), index, block.lower[i]);
      if (std::isfinite(block.upper[i])) problem.SetParameterUpperBound(block.values.data(), index, block.upper[i]);
    }

    const Solution solution = solve(options, who, logs, &block, &problem);
    const std::vector<double> deviations =
        options.standard_deviations ? standard_deviations(&problem, &block, solution, windows.residuals)
                                    : std::vector<double>(block.size(), std::numeric_limits<double>::quiet_NaN());
    Eigen::MatrixXd parameter_covariance;
    if (options.parameter_covariance && options.scope == sdk::ParameterScope::kMode && group.size() == 1) {
      const ModeLogs& d = *group.front();
      parameter_covariance = mode_parameter_covariance(bank, d, layouts.at(d.mode), block, solution.free_basis,
                                                       windows.most_residuals, options, who);
    }
    set_fitted_parameters(bank, group, block, who);
    for (const ModeLogs* d : group) {
      reports[d->mode] = report_of(*bank, *d, options, block, deviations, parameter_covariance, windows, solution);
      if (parameter_covariance.size() > 0 && options.parameter_covariance_per_log && log_count(*d) < 2) {
        reports[d->mode].warnings.push_back(
            "fitted on one log: its parameter covariance counts the rows as independent (the rows of one log "
            "cannot say how much logs differ)");
      }
    }
  }
  std::vector<FitReport> out;
  for (const ModeLogs* d : data) out.push_back(reports[d->mode]);
  return out;
}

int log_count(const ModeLogs& data) {
  std::set<std::string> logs;
  for (const Trajectory& t : data.logs) logs.insert(t.log);
  return static_cast<int>(logs.size());
}

}  // namespace fitting
}  // namespace skidimm
