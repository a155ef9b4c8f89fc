// The covariance of a least-squares fit's parameters, by Gauss-Newton, with
// one residual variance per measurement channel.
//
// The window objective's residuals are the prediction errors divided by the
// measurement standard deviations of R, so their scale says how well R
// matches the model's real errors, and it differs by channel (a motor
// current missed by 25 sigma of R, a vibration level by 3). The usual
// sigma^2 (J'J)^-1 with one sigma^2 would give the parameters of the
// well-predicted channels the variance of the badly predicted ones. Instead
// each channel c gets its own variance
//
//   s_c^2 = SSE_c / n_c * N / (N - p)       (N rows, p free parameters)
//
// and the covariance is the inverse of the information
//
//   Sigma = (sum_c J_c' J_c / s_c^2)^-1     over the free parameters,
//
// zero rows and columns for the others. For a model whose channels each
// depend on their own parameters (linear_features with a diagonal A) this
// is, channel by channel, the textbook s^2 (X'X)^-1 of a linear regression.
//
// Assumes the residual rows independent: correlated errors over a run make
// it smaller than the parameters' real uncertainty (docs/fitting.md,
// "Parameter uncertainty"). Given which log each row came from (add() with
// a log index), each channel's variance is instead scaled by its design
// effect over the logs,
//
//   deff_c = G / (G - 1) * sum_g (sum of log g's residuals of c)^2 / SSE_c
//
// (G logs with rows of the channel; at least 1, and 1 with fewer than two
// logs): about 1 where a log's errors are independent from row to row, and
// about the rows per log where each log is missed by an offset of its own,
// as if each log were one row. The sums over a log are what a persistent
// miss adds up in; G / (G - 1) undoes their being centred on the fit's own
// line (with an intercept they sum to zero over all logs).
#ifndef SKIDIMM_CORE_SRC_FITTING_PARAMETER_COVARIANCE_H_
#define SKIDIMM_CORE_SRC_FITTING_PARAMETER_COVARIANCE_H_

#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <limits>
#include <vector>

#include "coupled_blocks.h"

namespace skidimm {
namespace fitting {
namespace internal {

class ParameterCovarianceEstimate {
 public:
  ParameterCovarianceEstimate(int parameters, int channels)
      : information_(static_cast<std::size_t>(channels), Eigen::MatrixXd::Zero(parameters, parameters)),
        squares_(Eigen::VectorXd::Zero(channels)),
        counts_(Eigen::VectorXd::Zero(channels)),
        log_sums_(static_cast<std::size_t>(channels)) {}

  // One residual row of `channel`: its value and its derivatives in the
  // parameters; `log` (0, 1, ...), the log it came from, for the design
  // effect, or -1 to count the rows independent.
  void add(int channel, const Eigen::Ref<const Eigen::RowVectorXd>& jacobian_row, double residual, int log = -1) {
    information_[static_cast<std::size_t>(channel)].selfadjointView<Eigen::Lower>().rankUpdate(
        jacobian_row.transpose());
    squares_[channel] += residual * residual;
    counts_[channel] += 1.0;
    if (log >= 0) {
      std::vector<LogSum>& sums = log_sums_[static_cast<std::size_t>(channel)];
      if (sums.size() <= static_cast<std::size_t>(log)) sums.resize(static_cast<std::size_t>(log) + 1);
      sums[static_cast<std::size_t>(log)].residuals += residual;
      ++sums[static_cast<std::size_t>(log)].rows;
    }
  }

  // Channel c's design effect over the logs (above); 1 where no row of it
  // came with a log.
  double design_effect(int channel) const {
    double between = 0.0;
    int logs = 0;
    for (const LogSum& sum : log_sums_[static_cast<std::size_t>(channel)]) {
      if (sum.rows == 0) continue;  // a log without rows of the channel
      between += sum.residuals * sum.residuals;
      ++logs;
    }
    const double squares = squares_[channel];
    if (logs < 2 || !(squares > 0.0)) return 1.0;
    return std::max(1.0, logs / (logs - 1.0) * between / squares);
  }

  // Sigma over every parameter, in the directions `free_basis` spans
  // (parameters x free directions, orthonormal columns; the identity when
  // the fit holds nothing) and none in those the fit held. Directions the
  // information does not determine (eigenvalues below 1e-12 of the largest)
  // get no variance rather than an infinite one; the fit holds or reports
  // such parameters itself.
  Eigen::MatrixXd covariance(const Eigen::MatrixXd& free_basis) const {
    const Eigen::Index p = free_basis.rows();
    const Eigen::Index q = free_basis.cols();
    const double rows = counts_.sum();
    Eigen::MatrixXd out = Eigen::MatrixXd::Zero(p, p);
    if (q == 0 || rows <= static_cast<double>(q)) return out;
    const double dof = rows / (rows - static_cast<double>(q));
    Eigen::MatrixXd information = Eigen::MatrixXd::Zero(p, p);
    for (std::size_t c = 0; c < information_.size(); ++c) {
      if (counts_[static_cast<Eigen::Index>(c)] == 0.0) continue;
      const double variance = squares_[static_cast<Eigen::Index>(c)] / counts_[static_cast<Eigen::Index>(c)] * dof *
                              design_effect(static_cast<int>(c));
      if (!(variance > 0.0)) continue;  // a channel predicted exactly says nothing of the scale
      information += Eigen::MatrixXd(information_[c].selfadjointView<Eigen::Lower>()) / variance;
    }
    // The information in the free directions only: projected, the held ones
    // have none and get no variance below. A projector of the identity or of
    // whole parameters (0 and 1 on its diagonal) leaves the other entries
    // exactly as they were.
    const Eigen::MatrixXd projector = free_basis * free_basis.transpose();
    information = projector * information * projector;
    // The information is block diagonal when groups of parameters are
    // estimated from separate residuals (each feature's regression in
    // linear_features), and so is its inverse: inverted a block at a time,
    // the zeros between blocks stay exact, which the filter's use of the
    // covariance skips (parameter_uncertainty.cc), instead of rounding
    // noise. The same eigenvalues, so the same threshold: relative to the
    // largest of all blocks.
    const std::vector<std::vector<Eigen::Index>> blocks = coupled_blocks(information);
    std::vector<Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>> eigen(blocks.size());
    double largest = 0.0;
    for (std::size_t k = 0; k < blocks.size(); ++k) {
      const std::vector<Eigen::Index>& b = blocks[k];
      eigen[k].compute(information(b, b));
      if (eigen[k].info() != Eigen::Success) return out;
      largest = std::max(largest, eigen[k].eigenvalues().maxCoeff());
    }
    const double tiny = 1e-12 * largest + std::numeric_limits<double>::min();
    for (std::size_t k = 0; k < blocks.size(); ++k) {
      const std::vector<Eigen::Index>& b = blocks[k];
      const Eigen::VectorXd& lambda = eigen[k].eigenvalues();
      Eigen::VectorXd inverse(lambda.size());
      for (Eigen::Index i = 0; i < lambda.size(); ++i) inverse[i] = lambda[i] > tiny ? 1.0 / lambda[i] : 0.0;
      const Eigen::MatrixXd sigma = eigen[k].eigenvectors() * inverse.asDiagonal() * eigen[k].eigenvectors().transpose();
      for (std::size_t a = 0; a < b.size(); ++a) {
        for (std::size_t c = 0; c < b.size(); ++c) {
          out(b[a], b[c]) = 0.5 * (sigma(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(c)) +
                                   sigma(static_cast<Eigen::Index>(c), static_cast<Eigen::Index>(a)));
        }
      }
    }
    return out;
  }

 private:
  std::vector<Eigen::MatrixXd> information_;  // per channel, sum J_c' J_c (lower triangle)
  Eigen::VectorXd squares_;                   // per channel, the sum of squared residuals
  Eigen::VectorXd counts_;                    // per channel, its residual rows
  struct LogSum {
    double residuals = 0.0;
    long rows = 0;
  };
  std::vector<std::vector<LogSum>> log_sums_;  // per channel, per log
};

}  // namespace internal
}  // namespace fitting
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_FITTING_PARAMETER_COVARIANCE_H_
