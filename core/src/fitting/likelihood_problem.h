// Fitting by likelihood, its fourth part: the problem the solver sees:
// feasibility transforms from its coordinates to natural values (bounded
// parameters, Q through a Cholesky factor, R positive), the modes' blocks,
// and the scaled objective handed to Ceres. Private to the fitting library.
#ifndef SKIDIMM_CORE_SRC_FITTING_LIKELIHOOD_PROBLEM_H_
#define SKIDIMM_CORE_SRC_FITTING_LIKELIHOOD_PROBLEM_H_

#include <ceres/gradient_problem.h>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "bounded_median.h"
#include "covariance.h"
#include "sensitivity_filter.h"

namespace skidimm {
namespace fitting {
namespace internal {
// Internal linkage, as when these parts were one file: likelihood_fitter.cc
// is the one translation unit that includes them.
namespace {

// ---------------------------------------------------------------------------
// Feasibility transforms: the solver's coordinates phi -> natural values.

// A model parameter: logistic between two bounds, exponential off one,
// identity without.
struct Bounded {
  double lower = -kInfinity, upper = kInfinity;

  double natural(double phi) const {
    const bool low = std::isfinite(lower), high = std::isfinite(upper);
    if (low && high) return lower + (upper - lower) / (1.0 + std::exp(-phi));
    if (low) return lower + std::exp(phi);
    if (high) return upper - std::exp(phi);
    return phi;
  }
  double derivative(double phi) const {  // d natural / d phi
    const bool low = std::isfinite(lower), high = std::isfinite(upper);
    if (low && high) {
      const double sigma = 1.0 / (1.0 + std::exp(-phi));
      return (upper - lower) * sigma * (1.0 - sigma);
    }
    if (low) return std::exp(phi);
    if (high) return -std::exp(phi);
    return 1.0;
  }
  double coordinate(double value) const {
    const bool low = std::isfinite(lower), high = std::isfinite(upper);
    if (low && high) return std::log((value - lower) / (upper - value));
    if (low) return std::log(value - lower);
    if (high) return std::log(upper - value);
    return value;
  }
  // A start on or outside a bound is moved just inside it: the transforms
  // reach the bounds only at infinity.
  double inside(double value) const {
    const bool low = std::isfinite(lower), high = std::isfinite(upper);
    if (low && high) {
      const double margin = 1e-6 * (upper - lower);
      return std::clamp(value, lower + margin, upper - margin);
    }
    if (low) return std::max(value, lower + 1e-6 * std::max(1.0, std::abs(lower)));
    if (high) return std::min(value, upper - 1e-6 * std::max(1.0, std::abs(upper)));
    return value;
  }
  // Within 1e-5 of the range (two bounds) or 1e-6 of the bound's scale (one).
  bool near_bound(double value) const {
    const bool low = std::isfinite(lower), high = std::isfinite(upper);
    if (low && high) return value - lower <= 1e-5 * (upper - lower) || upper - value <= 1e-5 * (upper - lower);
    if (low) return value - lower <= 1e-6 * std::max(1.0, std::abs(lower));
    if (high) return upper - value <= 1e-6 * std::max(1.0, std::abs(upper));
    return false;
  }
};

// One mode of the problem.
struct ModeBlock {
  int mode = 0;
  sdk::MotionModel* model = nullptr;
  std::vector<const Trajectory*> logs;
  Parameterization par;
  std::vector<Bounded> bounds;       // per free model parameter
  Eigen::VectorXd start_parameters;  // the model's full vector at the start
  Eigen::MatrixXd fixed_q;           // kKeep: the bank's Q
  ProcessNoise q_form = ProcessNoise::kDiagonal;
  int offset = 0;  // of its coordinates in the solver's vector
  int num_q_coordinates = 0;
  std::vector<int> local_to_global;   // its natural parameters' coordinates: [model, q, r]
  std::vector<std::string> warnings;  // about its start
};

// The solver's vector: per mode [model parameters, Q coordinates], then R.
// Natural values of a mode and d natural / d coordinates.
struct NaturalValues {
  Eigen::VectorXd parameters;  // the model's full vector
  Eigen::MatrixXd q;
  Eigen::MatrixXd jacobian;  // natural (par order) x local coordinates [model, q, r]
};

int q_coordinates(ProcessNoise form, int n) {
  switch (form) {
    case ProcessNoise::kKeep:
      return 0;
    case ProcessNoise::kDiagonal:
      return n;
    case ProcessNoise::kFull:
      return n * (n + 1) / 2;
  }
  return 0;
}

// Q from its coordinates: diagonal q_i = exp(phi_i); full Q = L L' with L
// lower triangular (row by row, i >= j), L_ii = exp(phi).
Eigen::MatrixXd q_from(ProcessNoise form, int n, const double* phi, Eigen::MatrixXd* cholesky) {
  Eigen::MatrixXd q = Eigen::MatrixXd::Zero(n, n);
  if (form == ProcessNoise::kDiagonal) {
    for (int i = 0; i < n; ++i) q(i, i) = std::exp(phi[i]);
  } else if (form == ProcessNoise::kFull) {
    Eigen::MatrixXd l = Eigen::MatrixXd::Zero(n, n);
    int at = 0;
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j <= i; ++j, ++at) l(i, j) = i == j ? std::exp(phi[at]) : phi[at];
    }
    q.noalias() = l * l.transpose();
    symmetrize(q);
    if (cholesky != nullptr) *cholesky = l;
  }
  return q;
}

class Problem {
 public:
  Problem(const BankConfig& config, std::vector<ModeBlock> blocks, bool fit_r, int r_offset, bool numeric)
      : config_(config), blocks_(std::move(blocks)), fit_r_(fit_r), r_offset_(r_offset), numeric_(numeric) {
    size_ = r_offset_ + (fit_r_ ? static_cast<int>(config.measurement.h.rows()) : 0);
  }

  int size() const { return size_; }
  const std::vector<ModeBlock>& blocks() const { return blocks_; }

  NaturalValues natural(const ModeBlock& b, const double* phi) const {
    NaturalValues v;
    const int nm = b.par.num_model(), nq = b.par.num_q(), nr = b.par.num_r();
    const int n = config_.state_dim();
    v.parameters = b.start_parameters;
    v.jacobian = Eigen::MatrixXd::Zero(b.par.size(), nm + b.num_q_coordinates + nr);
    for (int p = 0; p < nm; ++p) {
      const double c = phi[b.offset + p];
      v.parameters[b.par.model_index[static_cast<std::size_t>(p)]] = b.bounds[static_cast<std::size_t>(p)].natural(c);
      v.jacobian(p, p) = b.bounds[static_cast<std::size_t>(p)].derivative(c);
    }
    const double* q_phi = phi + b.offset + nm;
    if (b.q_form == ProcessNoise::kKeep) {
      v.q = b.fixed_q;
    } else if (b.q_form == ProcessNoise::kDiagonal) {
      v.q = q_from(b.q_form, n, q_phi, nullptr);
      for (int i = 0; i < n; ++i) v.jacobian(nm + i, nm + i) = v.q(i, i);
    } else {
      Eigen::MatrixXd l;
      v.q = q_from(b.q_form, n, q_phi, &l);
      // d Q / d L_ac = E_ac L' + L E_ca; times L_aa on the (log) diagonal.
      int coordinate = 0;
      for (int a = 0; a < n; ++a) {
        for (int c = 0; c <= a; ++c, ++coordinate) {
          Eigen::MatrixXd d = Eigen::MatrixXd::Zero(n, n);
          d.row(a) += l.col(c).transpose();  // E_ac L': row a gets row c of L', i.e. column c of L
          d.col(a) += l.col(c);              // L E_ca: column a gets column c of L
          if (a == c) d *= l(a, a);
          for (int e = 0; e < nq; ++e) {
            const auto& [i, j] = b.par.q_entries[static_cast<std::size_t>(e)];
            v.jacobian(nm + e, nm + coordinate) = d(i, j);
          }
        }
      }
    }
    for (int e = 0; e < nr; ++e) {
      v.jacobian(nm + nq + e, nm + b.num_q_coordinates + e) = std::exp(phi[r_offset_ + e]);
    }
    return v;
  }

  Eigen::MatrixXd r(const double* phi) const {
    if (!fit_r_) return config_.measurement.r;
    const Eigen::Index m = config_.measurement.h.rows();
    Eigen::MatrixXd out = Eigen::MatrixXd::Zero(m, m);
    for (Eigen::Index c = 0; c < m; ++c) out(c, c) = std::exp(phi[r_offset_ + c]);
    return out;
  }

  // Sets every mode's model to phi and evaluates. With `derivatives`, also
  // d cost / d phi; with `information`, each mode's BHHH information in
  // natural units (modes[j].acc) and the whole in phi (information_phi).
  // `use` / `observe`: one StepStructure per block, or nullptr (see
  // StepDifferentiator).
  struct Result {
    double cost = 0.0;
    Eigen::VectorXd gradient;
    Eigen::MatrixXd information_phi;
    std::vector<ModeEvaluation> modes;
    std::vector<NaturalValues> natural;
    std::string failure;
    bool used_numeric = false;
  };

  bool evaluate(const double* phi, bool derivatives, bool information, Result* out,
                const std::vector<StepStructure>* use = nullptr, std::vector<StepStructure>* observe = nullptr) const {
    out->cost = 0.0;
    if (derivatives) out->gradient = Eigen::VectorXd::Zero(size_);
    if (information) out->information_phi = Eigen::MatrixXd::Zero(size_, size_);
    out->modes.clear();
    out->natural.clear();
    const Eigen::MatrixXd r_matrix = r(phi);
    for (std::size_t j = 0; j < blocks_.size(); ++j) {
      const ModeBlock& b = blocks_[j];
      NaturalValues v = natural(b, phi);
      std::string error;
      if (!v.parameters.allFinite() || !v.q.allFinite() || !b.model->set_parameters(v.parameters, &error)) {
        out->failure = "mode '" + config_.modes[static_cast<std::size_t>(b.mode)].name +
                       "': the model rejected the parameters" + (error.empty() ? "" : ": " + error);
        return false;
      }
      ModeEvaluation e =
          evaluate_mode(config_, b.model, b.logs, b.par, v.q, r_matrix, derivatives, numeric_, information, false,
                        use != nullptr ? &(*use)[j] : nullptr, observe != nullptr ? &(*observe)[j] : nullptr);
      if (!e.ok() || !std::isfinite(e.acc.nll)) {
        out->failure = "mode '" + config_.modes[static_cast<std::size_t>(b.mode)].name +
                       "': " + (e.failure.empty() ? std::string("the likelihood is not finite") : e.failure);
        return false;
      }
      out->cost += e.acc.nll;
      out->used_numeric = out->used_numeric || e.acc.used_numeric;
      if (derivatives) {
        const Eigen::VectorXd local = v.jacobian.transpose() * e.acc.gradient;
        for (Eigen::Index i = 0; i < local.size(); ++i)
          out->gradient[b.local_to_global[static_cast<std::size_t>(i)]] += local[i];
        if (information) {
          const Eigen::MatrixXd local_information = v.jacobian.transpose() * e.acc.information * v.jacobian;
          for (Eigen::Index i = 0; i < local.size(); ++i) {
            for (Eigen::Index j = 0; j < local.size(); ++j) {
              out->information_phi(b.local_to_global[static_cast<std::size_t>(i)],
                                   b.local_to_global[static_cast<std::size_t>(j)]) += local_information(i, j);
            }
          }
        }
      }
      out->modes.push_back(std::move(e));
      out->natural.push_back(std::move(v));
    }
    if (!std::isfinite(out->cost) || (derivatives && !out->gradient.allFinite())) {
      out->failure = "the likelihood or its gradient is not finite";
      return false;
    }
    return true;
  }

  // The row whose term of the negative log-likelihood at phi is over
  // kAbsurdRowTerm above the median row's, as "<source>: row <r> (t = ... s)
  // has a term of X against a median row's Y", or "" if none is. Half a
  // normalized innovation squared of 1e12 is an innovation of a million
  // standard deviations: no sensor's noise, a corrupt cell (or starting
  // values nowhere near the logs). The fit would be that one row's.
  std::string absurd_row(const double* phi) const {
    constexpr double kAbsurdRowTerm = 0.5e12;
    const Eigen::MatrixXd r_matrix = r(phi);
    std::string worst;
    double worst_excess = kAbsurdRowTerm;
    for (const ModeBlock& b : blocks_) {
      const NaturalValues v = natural(b, phi);
      if (!b.model->set_parameters(v.parameters, nullptr)) continue;  // evaluate() reports this
      // The rows' terms stream by: the median of the finite ones, and the
      // first largest (an infinite one, where the filter failed, included).
      internal::BoundedMedian finite;
      double largest = -kInfinity;
      std::size_t largest_log = 0;
      int largest_row = 0;
      evaluate_mode(config_, b.model, b.logs, b.par, v.q, r_matrix, false, numeric_, false, /*rows=*/false, nullptr,
                    nullptr, [&](std::size_t log, int row, double term) {
                      if (std::isfinite(term)) finite.add(term);
                      if (term > largest) {
                        largest = term;
                        largest_log = log;
                        largest_row = row;
                      }
                    });
      if (finite.empty()) continue;
      const double median = finite.median();
      if (largest - median > worst_excess) {
        worst_excess = largest - median;
        const Trajectory& t = *b.logs[largest_log];
        worst = t.source + ": row " + std::to_string(largest_row + 1) +
                " (t = " + number(t.t[static_cast<std::size_t>(largest_row)]) + " s) has a term of " + number(largest) +
                " against a median row's " + number(median);
      }
    }
    return worst;
  }

 private:
  const BankConfig& config_;
  std::vector<ModeBlock> blocks_;
  bool fit_r_;
  int r_offset_;
  bool numeric_;
  int size_ = 0;
};

// Ceres' view: phi = phi_0 + T psi, with T from the information at phi_0
// (whitening()), so that LBFGS starts on a problem whose Hessian is near the
// identity.
class ScaledObjective : public ceres::FirstOrderFunction {
 public:
  // `structure`: what the model's steps were seen to depend on (nullptr:
  // compute every derivative).
  ScaledObjective(const Problem* problem, Eigen::VectorXd start, Eigen::MatrixXd transform,
                  const std::vector<StepStructure>* structure)
      : problem_(problem), start_(std::move(start)), transform_(std::move(transform)), structure_(structure) {}

  bool Evaluate(const double* psi, double* cost, double* gradient) const override {
    const Eigen::VectorXd phi = phi_of(psi);
    Problem::Result result;
    // A failure (the model rejects the values, S not positive definite, a
    // non-finite value) is a failed evaluation for the line search, never NaN.
    if (!problem_->evaluate(phi.data(), gradient != nullptr, false, &result, structure_)) return false;
    *cost = result.cost;
    if (gradient != nullptr) {
      Eigen::Map<Eigen::VectorXd>(gradient, NumParameters()).noalias() = transform_.transpose() * result.gradient;
    }
    return true;
  }
  int NumParameters() const override { return static_cast<int>(start_.size()); }

  Eigen::VectorXd phi_of(const double* psi) const {
    return start_ + transform_ * Eigen::Map<const Eigen::VectorXd>(psi, NumParameters());
  }

 private:
  const Problem* problem_;
  Eigen::VectorXd start_;
  Eigen::MatrixXd transform_;
  const std::vector<StepStructure>* structure_;
};

}  // namespace
}  // namespace internal
}  // namespace fitting
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_FITTING_LIKELIHOOD_PROBLEM_H_
