#include "condensed_windows.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>

namespace skidimm {
namespace fitting {
namespace internal {

template <typename J, typename R>
void CondensedWindows::accumulate(const J& j, const R& r) const {
  h_.selfadjointView<Eigen::Lower>().rankUpdate(j.transpose());
  g_.noalias() += j.transpose() * r;
}

bool CondensedWindows::Evaluate(double const* const* parameters, double* residuals, double** jacobians) const {
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

}  // namespace internal
}  // namespace fitting
}  // namespace skidimm
