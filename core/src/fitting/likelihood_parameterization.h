// Fitting by likelihood (likelihood_fitter.h), its first part: what the
// sensitivities are taken with respect to (a mode's free model parameters,
// entries of Q, diagonal entries of R) and the constants and helpers the
// other parts share. Private to the fitting library; the parts are
// likelihood_parameterization.h, step_derivatives.h, sensitivity_filter.h,
// likelihood_problem.h and the driver, likelihood_fitter.cc.
#ifndef SKIDIMM_CORE_SRC_FITTING_LIKELIHOOD_PARAMETERIZATION_H_
#define SKIDIMM_CORE_SRC_FITTING_LIKELIHOOD_PARAMETERIZATION_H_

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

#include "not_a_number.h"
#include "skidimm/fitting/likelihood_fitter.h"
#include "skidimm/sdk/motion_model.h"

namespace skidimm {
namespace fitting {
namespace internal {
// Internal linkage, as when these parts were one file: likelihood_fitter.cc
// is the one translation unit that includes them.
namespace {

constexpr double kLog2Pi = 1.8378770664093454835606594728112;
using ::skidimm::internal::kNaN;
constexpr double kInfinity = std::numeric_limits<double>::infinity();
using ProcessNoise = LikelihoodFitOptions::ProcessNoise;

// cbrt(eps) balances truncation and round-off for central differences, as in
// sdk/numeric_jacobian.h.
double difference_step(double value) {
  static const double relative = std::cbrt(std::numeric_limits<double>::epsilon());
  return relative * std::max(1.0, std::abs(value));
}

std::string number(double value) {
  std::ostringstream out;
  out.precision(6);
  out << value;
  return out.str();
}

// ---------------------------------------------------------------------------
// What the sensitivities are taken with respect to, in natural units: the
// mode's free model parameters, then entries of Q, then diagonal entries of R.

struct Parameterization {
  std::vector<int> model_index;                // index in the model's flat parameter vector
  std::vector<std::pair<int, int>> q_entries;  // (i, j), i >= j: Q_ij and Q_ji move together
  std::vector<int> r_entries;                  // components c of R_cc

  int num_model() const { return static_cast<int>(model_index.size()); }
  int num_q() const { return static_cast<int>(q_entries.size()); }
  int num_r() const { return static_cast<int>(r_entries.size()); }
  int size() const { return num_model() + num_q() + num_r(); }
};

Parameterization parameterization_of(const sdk::MotionModel& model, int state_dim, int measurement_dim,
                                            const LikelihoodFitOptions& options) {
  Parameterization par;
  if (options.fit_model_parameters) {
    const auto& info = model.parameter_info();
    for (std::size_t i = 0; i < info.size(); ++i) {
      if (info[i].scope == sdk::ParameterScope::kMode) par.model_index.push_back(static_cast<int>(i));
    }
  }
  for (int i = 0; i < state_dim; ++i) {
    if (options.process_noise == ProcessNoise::kDiagonal) par.q_entries.emplace_back(i, i);
    if (options.process_noise == ProcessNoise::kFull) {
      for (int j = 0; j <= i; ++j) par.q_entries.emplace_back(i, j);
    }
  }
  if (options.fit_measurement_noise) {
    for (int c = 0; c < measurement_dim; ++c) par.r_entries.push_back(c);
  }
  return par;
}

std::string q_name(int i, int j) { return "Q[" + std::to_string(i) + "," + std::to_string(j) + "]"; }
std::string r_name(int c) { return "R[" + std::to_string(c) + "," + std::to_string(c) + "]"; }

std::vector<std::string> names_of(const Parameterization& par, const sdk::MotionModel& model) {
  std::vector<std::string> names;
  for (int i : par.model_index) names.push_back(model.parameter_info()[static_cast<std::size_t>(i)].name);
  for (const auto& [i, j] : par.q_entries) names.push_back(q_name(i, j));
  for (int c : par.r_entries) names.push_back(r_name(c));
  return names;
}

// The symmetric basis matrix of entry (i, j): d Q / d Q_ij.
Eigen::MatrixXd basis(int n, int i, int j) {
  Eigen::MatrixXd e = Eigen::MatrixXd::Zero(n, n);
  e(i, j) = e(j, i) = 1.0;
  return e;
}

}  // namespace
}  // namespace internal
}  // namespace fitting
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_FITTING_LIKELIHOOD_PARAMETERIZATION_H_
