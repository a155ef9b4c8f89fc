#include "skidimm/fitting/model_fitter.h"

#include <ceres/ceres.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <map>
#include <memory>
#include <sstream>

#include "bounded_median.h"
#include "covariance.h"
#include "measured_outputs.h"
#include "measurement_layout.h"
#include "parameter_covariance.h"
#include "process_noise_search.h"
#include "skidimm/engine/measurement_model.h"
#include "skidimm/sdk/angles.h"
#include "solver_progress.h"

namespace skidimm {
namespace fitting {

namespace {

using internal::for_each_error;
using internal::fully_measured;
using internal::MeasurementLayout;
using internal::measured_state;

// `mode`'s layout: its residuals are weighed by its own R where it has one
// (R: in its entry), the noise its filter assumes; else by the bank's.
MeasurementLayout layout_of(const BankConfig& bank, int mode) {
  MeasurementLayout m;
  const MeasurementConfig& mc = bank.measurement;
  const Eigen::MatrixXd& r = bank.measurement_noise(mode);
  m.h = mc.h;
  m.sigma = r.diagonal().cwiseSqrt();
  m.row_is_angle = mc.is_angle;
  m.state_is_angle = bank.angle_mask;
  const int n = bank.state_dim();
  m.state_row.assign(n, -1);
  const MeasurementModel measurement(mc.h, mc.r, mc.is_angle);
  m.every_row_picks = true;
  for (int row = 0; row < measurement.measurement_dim(); ++row) {
    const int s = measurement.picked_state(row);
    if (s >= 0 && m.state_row[static_cast<std::size_t>(s)] < 0) m.state_row[static_cast<std::size_t>(s)] = row;
    m.row_picks.push_back(s);
    m.every_row_picks = m.every_row_picks && s >= 0;
  }
  std::string missing;
  for (int s = 0; s < n; ++s) {
    if (m.state_row[s] < 0) missing += (missing.empty() ? "" : ", ") + bank.state_names[s];
  }
  if (!missing.empty()) {
    throw FitError("fitting starts predictions from measured states, but the bank does not measure [" + missing +
                   "] directly; list every state under measurement.observe");
  }
  m.r_state.resize(n, n);
  for (int a = 0; a < n; ++a) {
    for (int b = 0; b < n; ++b) m.r_state(a, b) = r(m.state_row[a], m.state_row[b]);
  }
  m.outputs = mc.outputs;
  m.first_output_row = mc.first_output_row();
  return m;
}

// Where each output the bank measures is in `model`'s outputs().
std::vector<int> output_positions(const sdk::MotionModel& model, const MeasurementLayout& m) {
  const std::vector<int> positions = output_indices(model, m.outputs);
  for (std::size_t k = 0; k < positions.size(); ++k) {
    if (positions[k] < 0) throw FitError("the model has no output '" + m.outputs[k] + "', which the bank measures");
  }
  return positions;
}

// The measurement the model predicts besides H x: zero on the state rows,
// its outputs at input u on the output rows. False if outputs() fails or is
// not finite.
bool expected_outputs(const sdk::MotionModel& model, const MeasurementLayout& m, const std::vector<int>& positions,
                      const Eigen::Ref<const Eigen::VectorXd>& u, Eigen::VectorXd* all, Eigen::VectorXd* expected) {
  if (m.outputs.empty()) return true;
  all->resize(static_cast<Eigen::Index>(model.output_names().size()));
  if (!model.outputs(u, *all)) return false;
  for (std::size_t k = 0; k < positions.size(); ++k) {
    (*expected)[m.first_output_row + static_cast<Eigen::Index>(k)] = (*all)[positions[k]];
  }
  return expected->allFinite();
}

bool any_measured(const Trajectory& t, int k) { return t.z.col(k).array().isFinite().any(); }

// Propagates x from row `from` to row `to` with the logged inputs.
bool propagate(const sdk::MotionModel& model, const Trajectory& t, int from, int to, Eigen::VectorXd* x,
               Eigen::MatrixXd* jacobian = nullptr) {
  Eigen::VectorXd next(x->size());
  Eigen::MatrixXd f(x->size(), x->size());
  if (jacobian != nullptr) jacobian->setIdentity(x->size(), x->size());
  for (int k = from; k < to; ++k) {
    const double dt = t.t[k + 1] - t.t[k];
    if (jacobian != nullptr) {
      if (!model.jacobian(*x, t.u.col(k), dt, f)) return false;
      *jacobian = f * *jacobian;
    }
    if (!model.predict(*x, t.u.col(k), dt, next)) return false;
    *x = next;
  }
  return x->allFinite();
}

struct Window {
  const Trajectory* trajectory;
  int start;
  std::vector<int> targets;  // measured rows after start, in order
  int residuals;
};

// Calls visit(w) with each window of the log in turn, one Window reused: a
// long log's windows are never all held at once.
template <typename Visit>
void for_each_window(const MeasurementLayout& m, const Trajectory& t, double window, Visit&& visit) {
  // Times within this of a window's end belong to it: a 0.5 s window at 50 Hz
  // holds 25 rows whatever the rounding of the logged times.
  constexpr double kTimeTolerance = 1e-9;
  double next_start = -std::numeric_limits<double>::infinity();
  Window w{&t, 0, {}, 0};
  for (int start = 0; start < t.size(); ++start) {
    if (!fully_measured(m, t, start) || t.t[start] < next_start - kTimeTolerance) continue;
    w.start = start;
    w.targets.clear();
    w.residuals = 0;
    const double end = t.t[start] + window + kTimeTolerance;
    for (int k = start + 1; k < t.size(); ++k) {
      if (!any_measured(t, k)) continue;
      if (!w.targets.empty() && t.t[k] > end) break;
      w.targets.push_back(k);
      w.residuals += static_cast<int>(t.z.col(k).array().isFinite().count());
      if (window <= 0.0) break;  // one-step: the next measured row only
    }
    // Multi-step windows do not overlap (multiple shooting); one-step ones start at every fully measured row.
    next_start = window > 0.0 ? t.t[start] + window : -std::numeric_limits<double>::infinity();
    if (!w.targets.empty()) visit(static_cast<const Window&>(w));
  }
}

// "<log>: the prediction from step k (t = ...) to t = ... s", for messages.
std::string window_text(const Trajectory& t, const Window& w) {
  return t.source + ": the prediction from step " + std::to_string(w.start + 1) + " (t = " +
         std::to_string(t.t[w.start]) + " s) to t = " + std::to_string(t.t[w.targets.back()]) + " s";
}

// How many times the median window's residual (at least one sigma) a window
// may miss by before it is called a corrupt cell rather than a poor start:
// a start far off a robot's dynamics misses by tens of sigma, a cell of 1e100
// by 1e90.
constexpr double kAbsurdWindowRatio = 1e6;

std::string format_number(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3g", value);
  return text;
}

// Which entries of a model's flat parameter vector the problem's parameter
// block sets: block index -> model index.
struct ParameterMapping {
  std::vector<int> model_index;
  std::vector<int> block_index;
};

// What the windows of one model evaluate in: every window of a problem runs
// on the same model instance, one after the other (the solver runs one
// thread), so they share their buffers, and the parameters last given to the
// model: Ceres evaluates every window at the same point, and setting a
// model's parameters is not free (bounds checks, and for some models a
// matrix exponential).
struct WindowWorkspace {
  Eigen::VectorXd full;  // the model's flat parameters
  Eigen::VectorXd set;   // as last given to the model (empty: none yet)
  Eigen::VectorXd x, next, all_outputs, expected, predicted;
  Eigen::MatrixXd sensitivity, updated, f, g, output_g;
  Eigen::RowVectorXd d;
};

// The residuals of one window, each error divided by its measurement
// standard deviation. With `jacobians`, also their exact derivatives: the
// sensitivity S = dx/dtheta of the propagated state is carried through the
// window,
//   S_{k+1} = F_k S_k + df/dtheta|_k,   S_start = 0 (the start is measured),
// with F_k from jacobian() and df/dtheta from parameter_jacobian().
class WindowCost : public ceres::CostFunction {
 public:
  WindowCost(sdk::MotionModel* model, Eigen::VectorXd base, ParameterMapping mapping, const MeasurementLayout* m,
             Window window, int block_size, std::shared_ptr<WindowWorkspace> workspace)
      : model_(model),
        base_(std::move(base)),
        mapping_(std::move(mapping)),
        m_(m),
        window_(std::move(window)),
        positions_(output_positions(*model, *m)),
        w_(std::move(workspace)) {
    mutable_parameter_block_sizes()->push_back(block_size);
    set_num_residuals(window_.residuals);
    const int n = model_->state_dim();
    const Eigen::Index parameters = base_.size();
    w_->x.resize(n);
    w_->next.resize(n);
    w_->expected = Eigen::VectorXd::Zero(m_->h.rows());
    w_->predicted.resize(m_->h.rows());
    w_->f.resize(n, n);
    w_->g.resize(n, parameters);
    w_->output_g.resize(static_cast<Eigen::Index>(model_->output_names().size()), parameters);
    w_->d.resize(block_size);
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    return EvaluateWindow(window_, parameters, residuals, jacobians);
  }

  // Evaluate() for any window of the mode's logs (CondensedWindows).
  bool EvaluateWindow(const Window& window, double const* const* parameters, double* residuals,
                      double** jacobians) const {
    WindowWorkspace& w = *w_;
    w.full = base_;
    for (std::size_t i = 0; i < mapping_.model_index.size(); ++i) {
      w.full[mapping_.model_index[i]] = parameters[0][mapping_.block_index[i]];
    }
    // The same parameters, bit for bit, leave the model as it is.
    if (w.set.size() != w.full.size() ||
        std::memcmp(w.set.data(), w.full.data(), sizeof(double) * static_cast<std::size_t>(w.full.size())) != 0) {
      if (!model_->set_parameters(w.full, nullptr)) return false;
      w.set = w.full;
    }
    const bool derivatives = jacobians != nullptr && jacobians[0] != nullptr;
    const Trajectory& t = *window.trajectory;
    const int n = model_->state_dim();
    const int block = parameter_block_sizes()[0];
    for (int s = 0; s < n; ++s) w.x[s] = t.z(m_->state_row[static_cast<std::size_t>(s)], window.start);
    // S is +0 at the start; it is written at the first step.
    bool sensitivity_zero = true;
    int row = window.start;
    int r = 0;
    for (int target : window.targets) {
      for (int k = row; k < target; ++k) {
        const double dt = t.t[k + 1] - t.t[k];
        if (derivatives) {
          if (!model_->jacobian(w.x, t.u.col(k), dt, w.f) || !model_->parameter_jacobian(w.x, t.u.col(k), dt, w.g)) {
            return false;
          }
          if (sensitivity_zero && all_finite(w.f)) {
            // F S with S = +0 is +0: only the parameters' own terms remain.
            w.sensitivity.setZero(n, block);
            for (std::size_t i = 0; i < mapping_.model_index.size(); ++i) {
              w.sensitivity.col(mapping_.block_index[i]) += w.g.col(mapping_.model_index[i]);
            }
          } else {
            if (sensitivity_zero) w.sensitivity.setZero(n, block);
            w.updated.noalias() = w.f * w.sensitivity;
            for (std::size_t i = 0; i < mapping_.model_index.size(); ++i) {
              w.updated.col(mapping_.block_index[i]) += w.g.col(mapping_.model_index[i]);
            }
            w.sensitivity.swap(w.updated);
          }
          sensitivity_zero = false;
        }
        if (!model_->predict(w.x, t.u.col(k), dt, w.next)) return false;
        w.x = w.next;
      }
      row = target;
      if (!expected_outputs(*model_, *m_, positions_, t.u.col(target), &w.all_outputs, &w.expected)) return false;
      if (derivatives && !m_->outputs.empty() && !model_->output_parameter_jacobian(t.u.col(target), w.output_g)) {
        return false;
      }
      // H x + expected; a row of H that picks one state gives it directly
      // (+0 where the product's sum of zeros would), other rows the product.
      if (!m_->every_row_picks) {
        w.predicted.noalias() = m_->h * w.x;
        w.predicted += w.expected;
      }
      // A non-finite entry would spread through the products' zeros: then
      // take the products.
      const bool direct = all_finite(w.x) && (!derivatives || all_finite(w.sensitivity));
      if (!direct && m_->every_row_picks) {
        w.predicted.noalias() = m_->h * w.x;
        w.predicted += w.expected;
      }
      for (Eigen::Index c = 0; c < t.z.rows(); ++c) {
        if (!std::isfinite(t.z(c, target))) continue;
        const int picked = direct ? m_->row_picks[static_cast<std::size_t>(c)] : -1;
        const double predicted = picked >= 0 ? (w.x[picked] + 0.0) + w.expected[c] : w.predicted[c];
        double e = t.z(c, target) - predicted;
        if (m_->row_is_angle[static_cast<std::size_t>(c)]) e = sdk::wrap_angle(e);
        residuals[r] = e / m_->sigma[c];
        if (derivatives) {
          double* jacobian_row = jacobians[0] + static_cast<std::ptrdiff_t>(r) * block;
          if (picked >= 0) {
            for (int p = 0; p < block; ++p) jacobian_row[p] = -(w.sensitivity(picked, p) + 0.0) / m_->sigma[c];
          } else {
            w.d.noalias() = m_->h.row(c) * w.sensitivity;
            w.d = -w.d / m_->sigma[c];
            if (c >= m_->first_output_row) {
              const int output = positions_[static_cast<std::size_t>(c - m_->first_output_row)];
              for (std::size_t i = 0; i < mapping_.model_index.size(); ++i) {
                w.d[mapping_.block_index[i]] -= w.output_g(output, mapping_.model_index[i]) / m_->sigma[c];
              }
            }
            for (int p = 0; p < block; ++p) jacobian_row[p] = w.d[p];
          }
        }
        ++r;
      }
    }
    return all_finite(w.x);
  }

 private:
  // Eigen's allFinite() takes x - x over a temporary; this is one pass.
  static bool all_finite(const Eigen::Ref<const Eigen::MatrixXd>& m) {
    const double* v = m.data();
    for (Eigen::Index i = 0; i < m.size(); ++i) {
      if (!std::isfinite(v[i])) return false;
    }
    return true;
  }

  sdk::MotionModel* model_;
  Eigen::VectorXd base_;
  ParameterMapping mapping_;
  const MeasurementLayout* m_;
  Window window_;
  std::vector<int> positions_;  // output_positions()
  std::shared_ptr<WindowWorkspace> w_;
};

// The same residuals for Ceres' numeric differentiation, for models without
// parameter_jacobian().
struct NumericWindowResidual {
  std::unique_ptr<WindowCost> cost;
  bool operator()(double const* const* parameters, double* residuals) const {
    return cost->Evaluate(parameters, residuals, nullptr);
  }
};

// Every window of a problem as one residual block of p + 1 residuals (p
// parameters) that Ceres' Levenberg-Marquardt solver cannot tell from the
// windows' own: the same cost, gradient and Gauss-Newton matrix. Each
// evaluation runs through the windows once, accumulating
//   C = 1/2 sum_w rho(|r_w|^2),  g = sum_w J_w' r_w,  H = sum_w J_w' J_w
// (r_w, J_w corrected for the robust loss as Ceres corrects them: Triggs et
// al., "Bundle adjustment: a modern synthesis", 2000), and returns
//   r = [L^-1 g; sqrt(2C - |L^-1 g|^2)],  J = [L'; 0],  H = L L'
// (L from H's eigenvalues, so a direction the logs do not excite is a zero
// singular value of J, as in the windows' own Jacobian). Its memory is the
// p x p sums, whatever the rows; the windows' Jacobians are never stored.
class CondensedWindows : public ceres::CostFunction {
 public:
  struct Log {
    const WindowCost* windows;  // evaluates any window of the log's mode
    const Trajectory* trajectory;
    const MeasurementLayout* layout;
  };
  CondensedWindows(std::vector<Log> logs, double window, int block_size, int most_residuals,
                   std::unique_ptr<ceres::LossFunction> loss)
      : logs_(std::move(logs)), window_(window), loss_(std::move(loss)), p_(block_size) {
    mutable_parameter_block_sizes()->push_back(block_size);
    set_num_residuals(block_size + 1);
    r_.resize(most_residuals);
    j_.resize(most_residuals, block_size);
    h_.resize(block_size, block_size);
    g_.resize(block_size);
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const bool derivatives = jacobians != nullptr && jacobians[0] != nullptr;
    double cost = 0.0;
    h_.setZero();
    g_.setZero();
    bool ok = true;
    for (const Log& log : logs_) {
      for_each_window(*log.layout, *log.trajectory, window_, [&](const Window& w) {
        if (!ok) return;
        double* jacobian = j_.data();
        ok = log.windows->EvaluateWindow(w, parameters, r_.data(), derivatives ? &jacobian : nullptr);
        if (!ok) return;
        auto r = r_.head(w.residuals);
        auto j = j_.topRows(w.residuals);
        const double squared = r.squaredNorm();
        if (!loss_) {
          cost += 0.5 * squared;
          if (derivatives) accumulate(j, r);
          return;
        }
        double rho[3];
        loss_->Evaluate(squared, rho);
        cost += 0.5 * rho[0];
        if (!derivatives) return;
        // Ceres' Corrector: J <- sqrt(rho') (I - alpha r r' / |r|^2) J, r <- sqrt(rho') / (1 - alpha) r.
        const double sqrt_rho1 = std::sqrt(rho[1]);
        double alpha = 0.0;
        if (squared > 0.0 && rho[2] > 0.0) alpha = 1.0 - std::sqrt(std::max(0.0, 1.0 + 2.0 * squared * rho[2] / rho[1]));
        if (alpha != 0.0) {
          const Eigen::RowVectorXd rj = r.transpose() * j;
          j -= (alpha / squared) * r * rj;
        }
        j *= sqrt_rho1;
        r *= sqrt_rho1 / (1.0 - alpha);
        accumulate(j, r);
      });
    }
    if (!ok || !std::isfinite(cost)) return false;
    Eigen::Map<Eigen::VectorXd> out(residuals, p_ + 1);
    if (!derivatives) {
      out.setZero();
      out[0] = std::sqrt(2.0 * cost);
      return true;
    }
    const Eigen::MatrixXd h = h_.selfadjointView<Eigen::Lower>();
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(h);
    if (eigen.info() != Eigen::Success) return false;
    const Eigen::VectorXd& lambda = eigen.eigenvalues();
    const double tiny = 1e-300 + std::numeric_limits<double>::epsilon() * std::max(0.0, lambda.maxCoeff()) * p_;
    Eigen::VectorXd root(p_), whitened = eigen.eigenvectors().transpose() * g_;
    for (int i = 0; i < p_; ++i) {
      root[i] = lambda[i] > tiny ? std::sqrt(lambda[i]) : 0.0;
      whitened[i] = lambda[i] > tiny ? whitened[i] / root[i] : 0.0;
    }
    out.head(p_) = whitened;
    out[p_] = std::sqrt(std::max(0.0, 2.0 * cost - whitened.squaredNorm()));
    Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> jacobian(jacobians[0], p_ + 1, p_);
    jacobian.topRows(p_) = root.asDiagonal() * eigen.eigenvectors().transpose();
    jacobian.row(p_).setZero();
    return true;
  }

 private:
  template <typename J, typename R>
  void accumulate(const J& j, const R& r) const {
    h_.selfadjointView<Eigen::Lower>().rankUpdate(j.transpose());
    g_.noalias() += j.transpose() * r;
  }

  std::vector<Log> logs_;
  double window_;
  std::unique_ptr<ceres::LossFunction> loss_;
  int p_;
  mutable Eigen::VectorXd r_;
  mutable Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> j_;  // as Ceres lays a Jacobian out
  mutable Eigen::MatrixXd h_;
  mutable Eigen::VectorXd g_;
};

// True if the model gives exact parameter derivatives at the log's first
// row, of its outputs too when the bank measures some.
bool has_parameter_jacobian(const sdk::MotionModel& model, const MeasurementLayout& m, const Trajectory& t) {
  if (t.size() < 2) return false;
  const Eigen::Index parameters = static_cast<Eigen::Index>(model.parameter_info().size());
  Eigen::MatrixXd g(model.state_dim(), parameters);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(model.state_dim());
  Eigen::MatrixXd output_g(static_cast<Eigen::Index>(model.output_names().size()), parameters);
  return model.parameter_jacobian(x, t.u.col(0), t.t[1] - t.t[0], g) &&
         (m.outputs.empty() || model.output_parameter_jacobian(t.u.col(0), output_g));
}

ceres::LossFunction* make_loss(const FitOptions& options) {
  if (options.loss == "huber") return new ceres::HuberLoss(options.loss_scale);
  if (options.loss == "cauchy") return new ceres::CauchyLoss(options.loss_scale);
  if (options.loss == "none") return nullptr;
  throw FitError("unknown loss '" + options.loss + "' (expected huber, cauchy or none)");
}

// "[B[0,0], B[0,1]], [A[1,1]]": the parameters in each direction the logs do
// not excite (right singular vectors of the Jacobian with negligible singular
// values), largest components first.
std::string describe_unexcited(const Eigen::MatrixXd& v, const Eigen::VectorXd& singular, double threshold,
                               const std::vector<std::string>& names) {
  std::string out;
  for (Eigen::Index k = 0; k < singular.size(); ++k) {
    if (singular[k] >= threshold) continue;
    std::vector<std::pair<double, std::string>> parts;
    for (Eigen::Index i = 0; i < v.rows(); ++i) {
      if (std::abs(v(i, k)) > 0.2) parts.emplace_back(std::abs(v(i, k)), names[static_cast<std::size_t>(i)]);
    }
    std::sort(parts.rbegin(), parts.rend());
    std::string direction;
    for (const auto& p : parts) direction += (direction.empty() ? "" : ", ") + p.second;
    out += (out.empty() ? "[" : ", [") + direction + "]";
  }
  return out;
}

}  // namespace

FitReport evaluate(const Bank& bank, const ModeLogs& data, bool correlated) {
  const MeasurementLayout m = layout_of(bank.config, data.mode);
  const sdk::MotionModel& model = *bank.models[static_cast<std::size_t>(data.mode)];
  const int n = bank.config.state_dim();
  const Eigen::Index rows = static_cast<Eigen::Index>(bank.config.measurement.names.size());
  FitReport report;
  Eigen::VectorXd squared = Eigen::VectorXd::Zero(rows);
  Eigen::VectorXd counts = Eigen::VectorXd::Zero(rows);
  // Per state, the one-step errors of rows where every state's error is known
  // (for the correlations of Q).
  Eigen::MatrixXd cross = Eigen::MatrixXd::Zero(n, n);
  Eigen::VectorXd error_sum = Eigen::VectorXd::Zero(n);
  Eigen::VectorXd state_error(n);
  double complete_rows = 0.0;
  // Pairs of consecutive complete rows' errors (residual_correlation).
  Eigen::MatrixXd lag_cross = Eigen::MatrixXd::Zero(n, n);
  Eigen::MatrixXd lag_power = Eigen::MatrixXd::Zero(n, n);
  Eigen::VectorXd previous_error(n);
  double pairs = 0.0;
  const std::vector<int> positions = output_positions(model, m);
  Eigen::VectorXd all_outputs, expected = Eigen::VectorXd::Zero(rows);
  for (const Trajectory& t : data.logs) {
    // Each output row's error is the model's outputs against the measured ones.
    for (int k = 0; k < t.size() && !m.outputs.empty(); ++k) {
      if (!expected_outputs(model, m, positions, t.u.col(k), &all_outputs, &expected)) continue;
      for (Eigen::Index c = m.first_output_row; c < rows; ++c) {
        if (!std::isfinite(t.z(c, k))) continue;
        squared[c] += (t.z(c, k) - expected[c]) * (t.z(c, k) - expected[c]);
        counts[c] += 1.0;
      }
    }
    int previous = -1;
    bool have_previous_error = false;  // the last complete row's error, just before this one
    for (int k = 0; k < t.size(); ++k) {
      if (!fully_measured(m, t, k)) {
        have_previous_error = false;
        continue;
      }
      bool have_error = false;
      if (previous >= 0) {
        Eigen::VectorXd x = measured_state(m, t, previous);
        if (propagate(model, t, previous, k, &x)) {
          state_error.setConstant(std::numeric_limits<double>::quiet_NaN());
          for_each_error(m, t, k, x, expected.setZero(), [&](Eigen::Index c, double e) {
            if (c >= m.first_output_row) return;  // counted above, at every row
            squared[c] += e * e;
            counts[c] += 1.0;
            for (int s = 0; s < n; ++s) {
              if (m.state_row[static_cast<std::size_t>(s)] == c) state_error[s] = e;
            }
          });
          if (state_error.allFinite()) {
            cross += state_error * state_error.transpose();
            error_sum += state_error;
            complete_rows += 1.0;
            have_error = true;
            if (have_previous_error) {
              lag_cross.noalias() += state_error * previous_error.transpose();
              // Two outer products into the sum, no temporary matrix per row.
              lag_power.noalias() += 0.5 * state_error * state_error.transpose();
              lag_power.noalias() += 0.5 * previous_error * previous_error.transpose();
              pairs += 1.0;
            }
            previous_error = state_error;
          }
        }
      }
      have_previous_error = have_error;
      previous = k;
    }
  }
  report.rmse = (squared.array() / counts.array().max(1.0)).sqrt();

  // Process noise: the diagonal intensity that makes the mode's own filter
  // consistent on its logs (process_noise_search.h).
  const internal::ConsistentProcessNoise noise = internal::consistent_process_noise(bank, data, m);
  Eigen::MatrixXd q = noise.intensity.asDiagonal();
  const std::vector<bool>& at_floor = noise.at_floor;
  for (int s = 0; s < n; ++s) {
    if (at_floor[static_cast<std::size_t>(s)]) {
      report.warnings.push_back("the measurement noise R alone explains the innovations of '" +
                                bank.config.state_names[static_cast<std::size_t>(s)] +
                                "': its process noise is at the floor 1e-10; check R");
    }
  }
  if (correlated && n > 1) {
    if (complete_rows < 2.0 * n) {
      report.warnings.push_back("too few rows measuring every state to estimate Q's correlations; Q is diagonal");
    } else {
      const Eigen::VectorXd mean = error_sum / complete_rows;
      const Eigen::MatrixXd covariance = cross / complete_rows - mean * mean.transpose();
      const Eigen::VectorXd scale = covariance.diagonal().cwiseMax(1e-300).cwiseSqrt().cwiseInverse();
      const Eigen::MatrixXd correlation = scale.asDiagonal() * covariance * scale.asDiagonal();
      const Eigen::VectorXd deviation = q.diagonal().cwiseSqrt();
      for (int i = 0; i < n; ++i) {
        for (int j = 0; j < i; ++j) {
          q(i, j) = q(j, i) = std::clamp(correlation(i, j), -0.999, 0.999) * deviation[i] * deviation[j];
        }
      }
      // A sample correlation matrix is positive semi-definite; clamping and
      // round-off may leave it barely not so: lift the spectrum's floor.
      Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(q);
      const double floor = 1e-9 * eigen.eigenvalues().cwiseAbs().maxCoeff();
      if (eigen.eigenvalues().minCoeff() < floor) {
        const Eigen::VectorXd lifted = eigen.eigenvalues().cwiseMax(floor);
        q = eigen.eigenvectors() * lifted.asDiagonal() * eigen.eigenvectors().transpose();
        q = 0.5 * (q + q.transpose()).eval();
      }
    }
  }
  report.q_intensity = q;
  // The errors whitened by their own second moment C (so the estimate does
  // not depend on which square root whitens them): rho = tr(C^-1 G) / n.
  if (pairs >= 2.0 * n) {
    const Eigen::LDLT<Eigen::MatrixXd> power(lag_power / pairs);
    if (power.info() == Eigen::Success && power.isPositive()) {
      const double rho = power.solve(lag_cross / pairs).trace() / n;
      if (std::isfinite(rho)) report.residual_correlation = std::clamp(rho, -0.99, 0.99);
    }
  }
  return report;
}

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
  std::vector<std::vector<const ModeLogs*>> problems;
  if (options.scope == sdk::ParameterScope::kMode) {
    for (const ModeLogs* d : data) problems.push_back({d});
  } else {
    problems.emplace_back();
    for (const ModeLogs* d : data) problems.back().push_back(d);
  }

  std::map<int, FitReport> reports;
  for (const auto& group : problems) {
    std::vector<std::string> names;
    std::vector<double> lower, upper;
    std::vector<double> block;
    // Per mode: its base vector and mapping into the block.
    std::map<int, std::pair<Eigen::VectorXd, ParameterMapping>> per_mode;
    for (const ModeLogs* d : group) {
      sdk::MotionModel& model = *bank->models[static_cast<std::size_t>(d->mode)];
      const auto& info = model.parameter_info();
      Eigen::VectorXd base(static_cast<Eigen::Index>(info.size()));
      model.get_parameters(base);
      ParameterMapping mapping;
      for (std::size_t i = 0; i < info.size(); ++i) {
        if (info[i].scope != options.scope) continue;
        auto at = std::find(names.begin(), names.end(), info[i].name);
        if (at == names.end()) {
          names.push_back(info[i].name);
          lower.push_back(info[i].lower_bound);
          upper.push_back(info[i].upper_bound);
          block.push_back(base[static_cast<Eigen::Index>(i)]);
          at = names.end() - 1;
        }
        mapping.model_index.push_back(static_cast<int>(i));
        mapping.block_index.push_back(static_cast<int>(at - names.begin()));
      }
      per_mode[d->mode] = {base, mapping};
    }
    const std::string who = options.scope == sdk::ParameterScope::kMode
                                ? "mode '" + bank->config.modes[static_cast<std::size_t>(group[0]->mode)].name + "'"
                                : "the bank's shared parameters";
    if (names.empty()) {
      throw FitError(who + ": the model has no " +
                     std::string(options.scope == sdk::ParameterScope::kMode ? "per-mode" : "bank-level") +
                     " parameters to fit");
    }

    std::map<const sdk::MotionModel*, std::shared_ptr<WindowWorkspace>> workspaces;  // per model, its windows'
    ceres::Problem::Options problem_options;
    problem_options.loss_function_ownership = ceres::TAKE_OWNERSHIP;
    ceres::Problem problem(problem_options);
    int residuals = 0;
    bool all_analytic = true;
    std::vector<std::string> empty_sources;
    // Each window's largest residual (in units of R) at the starting values,
    // and the worst window, for the absurd-cell check below.
    internal::BoundedMedian start_residuals;
    double worst_residual = -1.0;
    const Trajectory* worst_log = nullptr;
    Window worst_window{};  // a copy: each log's windows go when its loop ends
    // A window whose prediction is not finite at the starting values (an
    // input of 1e200, say) would make the cost infinite and the fit
    // meaningless: name the row instead. Finite but absurd windows (an input
    // of 1e100) are compared with the others below.
    const auto check_start = [&](const WindowCost& cost, const Trajectory& t, const Window& w,
                                 std::vector<double>* r) {
      r->resize(static_cast<std::size_t>(w.residuals));
      const double* p[] = {block.data()};
      const bool ok = cost.EvaluateWindow(w, p, r->data(), nullptr);
      bool finite = ok;
      double largest_residual = 0.0;
      for (double v : *r) {
        finite = finite && std::isfinite(v) && std::abs(v) < 1e150;
        largest_residual = std::max(largest_residual, std::abs(v));
      }
      if (!finite) {
        throw FitError(window_text(t, w) + " is not finite (or absurd) with the starting values of " + who +
                       "; check the log's inputs and measurements there");
      }
      start_residuals.add(largest_residual);
      if (largest_residual > worst_residual) {
        worst_residual = largest_residual;
        worst_log = &t;
        worst_window = w;
      }
    };
    // How many residuals, and whether every log has exact derivatives: a
    // large problem so differentiated is condensed (CondensedWindows).
    long total_residuals = 0;
    int most_residuals = 0;
    bool condense = !options.numeric_derivatives;
    for (const ModeLogs* d : group) {
      const MeasurementLayout& m = layouts.at(d->mode);
      for (const Trajectory& t : d->logs) {
        condense = condense && has_parameter_jacobian(*bank->models[static_cast<std::size_t>(d->mode)], m, t);
        for_each_window(m, t, options.window, [&](const Window& w) {
          total_residuals += w.residuals;
          most_residuals = std::max(most_residuals, w.residuals);
        });
      }
    }
    condense = condense && total_residuals > options.condense_above;
    std::vector<std::unique_ptr<WindowCost>> log_windows;  // the condensed problem's, per log
    std::vector<CondensedWindows::Log> condensed_logs;
    std::vector<double> start_r;
    for (const ModeLogs* d : group) {
      if (d->logs.empty()) throw FitError(who + ": no logs given");
      const MeasurementLayout& m = layouts.at(d->mode);
      for (const Trajectory& t : d->logs) {
        sdk::MotionModel* model = bank->models[static_cast<std::size_t>(d->mode)].get();
        std::shared_ptr<WindowWorkspace>& workspace = workspaces[model];
        if (!workspace) workspace = std::make_shared<WindowWorkspace>();
        if (condense) {
          log_windows.push_back(std::make_unique<WindowCost>(model, per_mode[d->mode].first, per_mode[d->mode].second,
                                                             &m, Window{&t, 0, {}, 0}, static_cast<int>(block.size()),
                                                             workspace));
          const int before = residuals;
          for_each_window(m, t, options.window, [&](const Window& w) {
            check_start(*log_windows.back(), t, w, &start_r);
            residuals += w.residuals;
          });
          if (residuals == before) empty_sources.push_back(t.source);
          condensed_logs.push_back({log_windows.back().get(), &t, &m});
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
        all_analytic = all_analytic && analytic;
        for (const Window& w : windows) {
          auto window_cost = std::make_unique<WindowCost>(model, per_mode[d->mode].first, per_mode[d->mode].second,
                                                          &m, w, static_cast<int>(block.size()), workspace);
          check_start(*window_cost, t, w, &start_r);
          ceres::CostFunction* cost = nullptr;
          if (analytic) {
            cost = window_cost.release();
          } else {
            auto* numeric = new ceres::DynamicNumericDiffCostFunction<NumericWindowResidual, ceres::CENTRAL>(
                new NumericWindowResidual{std::move(window_cost)});
            numeric->AddParameterBlock(static_cast<int>(block.size()));
            numeric->SetNumResiduals(w.residuals);
            cost = numeric;
          }
          problem.AddResidualBlock(cost, make_loss(options), block.data());
          residuals += w.residuals;
        }
      }
    }
    if (condense && residuals > 0) {
      problem.AddResidualBlock(new CondensedWindows(std::move(condensed_logs), options.window,
                                                    static_cast<int>(block.size()), most_residuals,
                                                    std::unique_ptr<ceres::LossFunction>(make_loss(options))),
                               nullptr, block.data());
    }
    // One window a million times further from its measurements than the
    // typical one (residuals are in units of the measurement noise, R) is not
    // a poor starting value but a corrupt cell: it would dominate the fit,
    // which would then end "converged" with an RMSE of 1e80. Name it.
    if (!start_residuals.empty()) {
      const double median = start_residuals.median();
      if (worst_residual > kAbsurdWindowRatio * std::max(1.0, median)) {
        throw FitError(window_text(*worst_log, worst_window) + " misses its measurements by " +
                       format_number(worst_residual) + " times their noise (R) with the starting values of " + who +
                       ", against " + format_number(median) +
                       " for the median window: an absurd input or measurement there (a corrupt cell?); "
                       "fix or remove it");
      }
    }
    if (residuals == 0 && !empty_sources.empty()) {
      std::string states;
      for (const std::string& s : bank->config.state_names) states += (states.empty() ? "" : ", ") + s;
      throw FitError(empty_sources.front() + (empty_sources.size() > 1 ? " (and the other logs of " + who + ")" : "") +
                     ": no prediction window: no row measures every state (" + states +
                     ") with a measured row after it");
    }
    // The logs a whole-fit error is about, for its message.
    std::string logs_text;
    int listed = 0;
    for (const ModeLogs* d : group) {
      for (const Trajectory& t : d->logs) {
        if (++listed <= 3) logs_text += (logs_text.empty() ? "" : ", ") + t.source;
      }
    }
    if (listed > 3) logs_text += " and " + std::to_string(listed - 3) + " more";
    logs_text = " (logs: " + logs_text + ")";
    if (residuals <= static_cast<int>(block.size())) {
      throw FitError(who + logs_text + ": the logs are too short: " + std::to_string(residuals) + " residuals for " +
                     std::to_string(block.size()) + " parameters");
    }
    for (std::size_t i = 0; i < block.size(); ++i) {
      if (std::isfinite(lower[i])) problem.SetParameterLowerBound(block.data(), static_cast<int>(i), lower[i]);
      if (std::isfinite(upper[i])) problem.SetParameterUpperBound(block.data(), static_cast<int>(i), upper[i]);
    }

    ceres::Solver::Options solver_options;
    solver_options.linear_solver_type = ceres::DENSE_QR;
    solver_options.max_num_iterations = options.max_iterations;
    solver_options.function_tolerance = 1e-12;
    solver_options.parameter_tolerance = 1e-12;
    solver_options.num_threads = 1;  // residual blocks share the model instance
    solver_options.logging_type = ceres::SILENT;
    SolverProgress solver_progress(options.progress, who + " (window objective)");
    if (options.progress) solver_options.callbacks.push_back(&solver_progress);
    ceres::Solver::Summary summary;
    // Solve; with hold_unexcited, parameters the logs do not excite are held
    // at their starting values and the rest solved again.
    const std::vector<double> start = block;
    std::vector<int> held;
    std::vector<std::string> free_names;
    Eigen::VectorXd singular;
    double largest = 0.0, smallest = 0.0;
    double first_initial_cost = -1.0;
    while (true) {
      ceres::Solve(solver_options, &problem, &summary);
      if (first_initial_cost < 0.0) first_initial_cost = summary.initial_cost;
      if (!summary.IsSolutionUsable()) throw FitError(who + logs_text + ": the solver failed: " + summary.message);
      if (!std::isfinite(summary.initial_cost) || !std::isfinite(summary.final_cost)) {
        throw FitError(who + logs_text + ": the cost is not finite (" + std::to_string(summary.initial_cost) + " -> " +
                       std::to_string(summary.final_cost) + "); a cell of the logs is absurd");
      }

      // Identifiability: singular values of the Jacobian at the solution (in
      // the free parameters: the held ones have no column).
      ceres::CRSMatrix crs;
      double cost = 0.0;
      problem.Evaluate(ceres::Problem::EvaluateOptions(), &cost, nullptr, nullptr, &crs);
      Eigen::MatrixXd jacobian = Eigen::MatrixXd::Zero(crs.num_rows, crs.num_cols);
      for (int row = 0; row < crs.num_rows; ++row) {
        for (int k = crs.rows[static_cast<std::size_t>(row)]; k < crs.rows[static_cast<std::size_t>(row) + 1]; ++k) {
          jacobian(row, crs.cols[static_cast<std::size_t>(k)]) = crs.values[static_cast<std::size_t>(k)];
        }
      }
      free_names.clear();
      std::vector<int> free_index;
      for (std::size_t i = 0; i < names.size(); ++i) {
        if (std::find(held.begin(), held.end(), static_cast<int>(i)) == held.end()) {
          free_names.push_back(names[i]);
          free_index.push_back(static_cast<int>(i));
        }
      }
      Eigen::JacobiSVD<Eigen::MatrixXd> svd(jacobian, Eigen::ComputeThinV);
      singular = svd.singularValues();
      largest = singular[0];
      smallest = singular[singular.size() - 1];
      const double threshold = options.identifiability_threshold * largest;
      if (largest > 0.0 && smallest >= threshold) break;
      const std::string unexcited = describe_unexcited(svd.matrixV(), singular, threshold, free_names);
      if (!options.hold_unexcited || !(largest > 0.0)) {
        throw FitError(who + logs_text + ": the logs do not excite every parameter: no information on the combinations " +
                       unexcited + "; drive maneuvers that move them (turns and speed changes), or fix them" +
                       (options.hold_unexcited ? "" : " (or let the fit hold them: --hold-unexcited)"));
      }
      const std::size_t before = held.size();
      const Eigen::MatrixXd& v = svd.matrixV();
      // One parameter per unexcited direction: the one that moves most along
      // it. A combination (speed x B + c at a constant speed) keeps its other
      // members free, so what the logs do determine is still fitted.
      for (Eigen::Index k = 0; k < singular.size(); ++k) {
        if (singular[k] >= threshold) continue;
        int chosen = -1;
        double weight = 0.0;
        for (Eigen::Index i = 0; i < v.rows(); ++i) {
          const int parameter = free_index[static_cast<std::size_t>(i)];
          if (std::abs(v(i, k)) > weight && std::find(held.begin(), held.end(), parameter) == held.end()) {
            weight = std::abs(v(i, k));
            chosen = parameter;
          }
        }
        if (chosen < 0) continue;
        held.push_back(chosen);
        block[static_cast<std::size_t>(chosen)] = start[static_cast<std::size_t>(chosen)];
      }
      if (held.size() == before || held.size() == block.size()) {
        throw FitError(who + logs_text + ": the logs do not excite every parameter: no information on the combinations " +
                       unexcited + "; drive maneuvers that move them, or fix them");
      }
      std::sort(held.begin(), held.end());
      problem.SetManifold(block.data(), new ceres::SubsetManifold(static_cast<int>(block.size()), held));
    }

    std::vector<double> deviations(block.size(), std::nan(""));
    ceres::Covariance::Options covariance_options;
    covariance_options.algorithm_type = ceres::DENSE_SVD;
    ceres::Covariance covariance(covariance_options);
    const int dof = residuals - static_cast<int>(block.size());
    if (covariance.Compute({std::make_pair(block.data(), block.data())}, &problem)) {
      std::vector<double> c(block.size() * block.size());
      covariance.GetCovarianceBlock(block.data(), block.data(), c.data());
      const double variance = 2.0 * summary.final_cost / dof;  // residuals are whitened by the assumed R
      for (std::size_t i = 0; i < block.size(); ++i) deviations[i] = std::sqrt(c[i * block.size() + i] * variance);
      for (int i : held) deviations[static_cast<std::size_t>(i)] = std::nan("");
    }

    // The covariance of a mode's own parameters (parameter_covariance.h), from
    // every window's residuals and exact derivatives at the solution.
    Eigen::MatrixXd parameter_covariance;
    if (options.parameter_covariance && options.scope == sdk::ParameterScope::kMode && group.size() == 1) {
      const ModeLogs& d = *group.front();
      sdk::MotionModel* model = bank->models[static_cast<std::size_t>(d.mode)].get();
      const MeasurementLayout& m = layouts.at(d.mode);
      const int p = static_cast<int>(block.size());
      internal::ParameterCovarianceEstimate estimate(p, static_cast<int>(m.h.rows()));
      std::vector<double> r(static_cast<std::size_t>(std::max(1, most_residuals)));
      Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> j(std::max(1, most_residuals), p);
      const double* point[] = {block.data()};
      for (const Trajectory& t : d.logs) {
        if (t.size() < 2) continue;  // no window
        if (!has_parameter_jacobian(*model, m, t)) {
          throw FitError(who + ": the parameter covariance needs the model's exact derivatives (parameter_jacobian())");
        }
        WindowCost windows(model, per_mode[d.mode].first, per_mode[d.mode].second, &m, Window{&t, 0, {}, 0}, p,
                           std::make_shared<WindowWorkspace>());
        for_each_window(m, t, options.window, [&](const Window& w) {
          double* jacobian = j.data();
          if (!windows.EvaluateWindow(w, point, r.data(), &jacobian)) return;
          int row = 0;
          for (int target : w.targets) {
            for (Eigen::Index c = 0; c < t.z.rows(); ++c) {
              if (!std::isfinite(t.z(c, target))) continue;
              estimate.add(static_cast<int>(c), j.row(row), r[static_cast<std::size_t>(row)]);
              ++row;
            }
          }
        });
      }
      std::vector<bool> free(block.size(), true);
      for (int i : held) free[static_cast<std::size_t>(i)] = false;
      const Eigen::MatrixXd in_block = estimate.covariance(free);
      const ParameterMapping& mapping = per_mode[d.mode].second;
      const Eigen::Index size = per_mode[d.mode].first.size();
      parameter_covariance = Eigen::MatrixXd::Zero(size, size);
      for (std::size_t a = 0; a < mapping.model_index.size(); ++a) {
        for (std::size_t b = 0; b < mapping.model_index.size(); ++b) {
          parameter_covariance(mapping.model_index[a], mapping.model_index[b]) =
              in_block(mapping.block_index[a], mapping.block_index[b]);
        }
      }
    }

    // Leave every model of the group at the solution.
    for (const ModeLogs* d : group) {
      auto& [base, mapping] = per_mode[d->mode];
      Eigen::VectorXd full = base;
      for (std::size_t i = 0; i < mapping.model_index.size(); ++i) {
        full[mapping.model_index[i]] = block[static_cast<std::size_t>(mapping.block_index[i])];
      }
      std::string error;
      if (!bank->models[static_cast<std::size_t>(d->mode)]->set_parameters(full, &error)) {
        throw FitError(who + ": the model rejected the fitted parameters: " + error);
      }
    }
    for (const ModeLogs* d : group) {
      FitReport report = evaluate(*bank, *d, options.correlated_process_noise);
      for (std::size_t i = 0; i < block.size(); ++i) {
        report.parameters.push_back({names[i], block[i], deviations[i]});
        if (std::find(held.begin(), held.end(), static_cast<int>(i)) != held.end()) {
          report.warnings.push_back("parameter '" + names[i] + "' is held at its starting value " +
                                    std::to_string(block[i]) + ": the logs do not excite it");
          continue;
        }
        if (std::isfinite(deviations[i]) && deviations[i] > std::max(std::abs(block[i]), 1e-9)) {
          report.warnings.push_back("parameter '" + names[i] + "' is poorly determined: standard deviation " +
                                    std::to_string(deviations[i]) + " exceeds its value");
        }
        if (block[i] <= lower[i] || block[i] >= upper[i]) {
          report.warnings.push_back("parameter '" + names[i] + "' ended on its bound");
        }
      }
      if (!std::isfinite(deviations[0])) report.warnings.push_back("Ceres could not compute the covariance");
      report.parameter_covariance = parameter_covariance;
      report.residuals = residuals;
      report.derivatives = all_analytic ? "autodiff" : "numeric";
      report.iterations = static_cast<int>(summary.iterations.size());
      report.initial_cost = first_initial_cost;
      report.final_cost = summary.final_cost;
      report.condition_number = largest / smallest;
      if (report.condition_number > 1e6) {
        report.warnings.push_back("the fit is ill-conditioned (condition number " +
                                  std::to_string(report.condition_number) + "): some parameters trade off");
      }
      reports[d->mode] = report;
    }
  }
  std::vector<FitReport> out;
  for (const ModeLogs* d : data) out.push_back(reports[d->mode]);
  return out;
}

}  // namespace fitting
}  // namespace skidimm
