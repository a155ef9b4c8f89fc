// evaluate() (model_fitter.h): a mode's one-step prediction errors on its
// logs at the model's current parameters, and what they estimate: the RMSE
// per measured row, the process noise Q (diagonal, or with the correlations
// of the errors), and the lag-1 residual correlation.
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "bounded_median.h"
#include "measurement_layout.h"
#include "not_a_number.h"
#include "process_noise_search.h"
#include "skidimm/fitting/model_fitter.h"

namespace skidimm {
namespace fitting {

namespace {

using internal::expected_outputs;
using internal::for_each_error;
using internal::fully_measured;
using internal::layout_of;
using internal::measured_state;
using internal::MeasurementLayout;
using internal::output_positions;

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

}  // namespace

std::string failed_predictions_text(const FitReport& report) {
  return "the model failed " + std::to_string(report.failed_predictions) + " of its " +
         std::to_string(report.predictions) +
         " predictions on these logs (the first: " + report.first_failed_prediction + ")";
}

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
  // Predictions the model failed (its refusal or error) cannot be scored:
  // counted, the first named, and said in a warning, not left out silently.
  const auto count_prediction = [&](bool ok, const Trajectory& t, int k) {
    ++report.predictions;
    if (ok) return true;
    if (report.failed_predictions++ == 0) {
      const char* reason = model.failure_reason();
      report.first_failed_prediction =
          t.source + ": step " + std::to_string(k + 1) + " (t = " + std::to_string(t.t[k]) + " s)" +
          (reason != nullptr && *reason != '\0' ? std::string(": ") + reason : std::string());
    }
    return false;
  };
  // Each error in units of its measurement's noise (R): the median, and the
  // largest and where it is. One a million times the median is a corrupt
  // cell (an input of 1e308 that no window of the fit reached), which would
  // otherwise print as an RMSE of inf or 1e90 and pin Q at a bound.
  internal::BoundedMedian error_sizes(4096);  // a median's size, in memory that does not grow with the logs
  double largest_error = 0.0;
  std::string largest_at;
  const auto note_error = [&](const Trajectory& t, int from, int k, Eigen::Index c, double e) {
    const double size = std::abs(e) / std::sqrt(std::max(bank.config.measurement.r(c, c), 1e-300));
    error_sizes.add(size);
    if (!(size <= largest_error)) {
      largest_error = size;
      largest_at = t.source + ": step " + std::to_string(k + 1) + " (t = " + std::to_string(t.t[k]) + " s" +
                   (from < k ? ", predicted from step " + std::to_string(from + 1) + " with the inputs between" : "") +
                   ") misses '" + bank.config.measurement.names[static_cast<std::size_t>(c)] + "'";
    }
  };
  for (const Trajectory& t : data.logs) {
    // Each output row's error is the model's outputs against the measured ones.
    for (int k = 0; k < t.size() && !m.outputs.empty(); ++k) {
      if (!count_prediction(expected_outputs(model, m, positions, t.u.col(k), &all_outputs, &expected), t, k)) {
        continue;
      }
      for (Eigen::Index c = m.first_output_row; c < rows; ++c) {
        if (!std::isfinite(t.z(c, k))) continue;
        squared[c] += (t.z(c, k) - expected[c]) * (t.z(c, k) - expected[c]);
        counts[c] += 1.0;
        note_error(t, k, k, c, t.z(c, k) - expected[c]);
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
        if (count_prediction(propagate(model, t, previous, k, &x), t, previous)) {
          state_error.setConstant(std::numeric_limits<double>::quiet_NaN());
          for_each_error(m, t, k, x, expected.setZero(), [&](Eigen::Index c, double e) {
            if (c >= m.first_output_row) return;  // counted above, at every row
            squared[c] += e * e;
            counts[c] += 1.0;
            note_error(t, previous, k, c, e);
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
  if (!error_sizes.empty() && internal::is_absurd_miss(largest_error, error_sizes.median())) {
    throw FitError("the one-step prediction of " + largest_at + " by " + internal::miss_text(largest_error) +
                   " times its noise (R), against " + internal::miss_text(error_sizes.median()) +
                   " for the median: an absurd input or measurement there (a corrupt cell?); fix or remove it");
  }
  if (report.failed_predictions > 0) {
    report.warnings.push_back(failed_predictions_text(report) +
                              "; the RMSE leaves them out, and Q is estimated from each log's steps before its "
                              "first failure");
  }
  // A component never measured twice in a row has no one-step error: NaN,
  // not 0, so that nothing downstream (output_noise_from_fit) takes it for
  // a perfect prediction.
  report.rmse =
      (counts.array() > 0.0).select((squared.array() / counts.array().max(1.0)).sqrt(), ::skidimm::internal::kNaN);

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
    if (noise.at_ceiling[static_cast<std::size_t>(s)]) {
      report.warnings.push_back(
          "the process noise of '" + bank.config.state_names[static_cast<std::size_t>(s)] +
          "' is at the ceiling of its search, 1000, and its filter is still overconfident there (mean NIS above 1): "
          "its Q is too small for these logs. A state in large units (mA for A) needs a Q beyond the search: "
          "rescale it, or fit by the likelihood objective, whose Q has no ceiling");
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

}  // namespace fitting
}  // namespace skidimm
