// Tuned settings: the knobs' names, a setting's description, and a bank's
// fitted values read out and put back with the settings applied.
#include "tuned_settings.h"

#include <cstddef>
#include <cstdio>
#include <string>

#include "skidimm/engine/parameter_uncertainty.h"
#include "skidimm/errors.h"
#include "skidimm/fitting/tuning.h"

namespace skidimm {
namespace fitting {

namespace internal {

std::string brief(double v) {
  char b[32];
  std::snprintf(b, sizeof(b), "%.4g", v);
  return b;
}

}  // namespace internal

using internal::brief;

const char* to_string(Knob knob) {
  switch (knob) {
    case Knob::kRScale:
      return "r-scale";
    case Knob::kRComponents:
      return "r-components";
    case Knob::kQScale:
      return "q-scale";
    case Knob::kQModes:
      return "q-modes";
    case Knob::kDwell:
      return "dwell";
    case Knob::kFloor:
      return "floor";
    case Knob::kLikelihoodWeight:
      return "likelihood-weight";
    case Knob::kLikelihoodDof:
      return "likelihood-dof";
    case Knob::kUnknownInflation:
      return "unknown-inflation";
    case Knob::kExtrapolationScale:
      return "extrapolation-scale";
  }
  return "?";
}

Knob knob_from_string(const std::string& name) {
  for (Knob k : {Knob::kRScale, Knob::kRComponents, Knob::kQScale, Knob::kQModes, Knob::kDwell, Knob::kFloor,
                 Knob::kLikelihoodWeight, Knob::kLikelihoodDof, Knob::kUnknownInflation, Knob::kExtrapolationScale}) {
    if (name == to_string(k)) return k;
  }
  throw Error("unknown setting '" + name +
              "' (expected r-scale, r-components, q-scale, q-modes, dwell, floor, likelihood-weight, likelihood-dof, "
              "unknown-inflation, extrapolation-scale)");
}

std::string TunedSettings::describe(const BankConfig& config) const {
  std::string out = "objective " + objective + ", R x " + brief(r_scale);
  for (Eigen::Index i = 0; i < r_component.size(); ++i) {
    if (r_component[i] != 1.0) out += ", R[" + config.measurement.names[static_cast<std::size_t>(i)] + "] std x " + brief(r_component[i]);
  }
  out += ", Q x " + brief(q_scale);
  for (Eigen::Index j = 0; j < q_mode.size(); ++j) {
    if (q_mode[j] != 1.0) out += ", Q[" + config.modes[static_cast<std::size_t>(j)].name + "] x " + brief(q_mode[j]);
  }
  if (dwell_seconds > 0.0) out += ", dwell " + brief(dwell_seconds) + " s";
  if (probability_floor >= 0.0) out += ", floor " + brief(probability_floor);
  // Only when not 1, the plain IMM: the description of a bank tuned without it stays as it was.
  if (likelihood_weight > 0.0 && likelihood_weight != 1.0) out += ", likelihood weight " + brief(likelihood_weight);
  // Only when Student-t, for the same reason.
  if (likelihood_dof > 0.0) out += ", likelihood dof " + brief(likelihood_dof);
  if (unknown_inflation > 0.0) out += ", unknown inflation " + brief(unknown_inflation);
  // Only once searched: "off" where the search kept it off.
  if (extrapolation_scale >= 0.0) {
    out += ", extrapolation scale " + (extrapolation_scale > 0.0 ? brief(extrapolation_scale) : std::string("off"));
  }
  return out;
}

FittedValues values_of(const Bank& bank) {
  FittedValues v;
  for (std::size_t j = 0; j < bank.models.size(); ++j) {
    Eigen::VectorXd p(static_cast<Eigen::Index>(bank.models[j]->parameter_info().size()));
    bank.models[j]->get_parameters(p);
    v.parameters.push_back(p);
    v.q.push_back(bank.config.modes[j].q_intensity);
    v.mode_r.push_back(bank.config.modes[j].r);
    v.parameter_covariance.push_back(bank.config.modes[j].parameter_covariance);
    v.residual_correlation.push_back(bank.config.modes[j].residual_correlation);
    v.fitted_inputs.push_back(bank.config.modes[j].fitted_inputs);
  }
  v.r = bank.config.measurement.r;
  return v;
}

void apply(const FittedValues& fitted, const TunedSettings& s, Bank* bank) {
  internal::apply(fitted, s, bank, nullptr);
}

namespace internal {

void apply(const FittedValues& fitted, const TunedSettings& s, Bank* bank, KeptCovarianceModels* kept) {
  BankConfig& config = bank->config;
  for (std::size_t j = 0; j < bank->models.size(); ++j) {
    std::string error;
    if (!bank->models[j]->set_parameters(fitted.parameters[j], &error)) {
      throw FitError("mode '" + config.modes[j].name + "' rejected its fitted parameters: " + error);
    }
    const double mode_scale = s.q_mode.size() > 0 ? s.q_mode[static_cast<Eigen::Index>(j)] : 1.0;
    config.modes[j].q_intensity = fitted.q[j] * (s.q_scale * mode_scale);
  }
  const auto scaled = [&](const Eigen::MatrixXd& r) -> Eigen::MatrixXd {
    if (s.r_component.size() == 0) return r * s.r_scale;
    return s.r_component.asDiagonal() * (r * s.r_scale) * s.r_component.asDiagonal();
  };
  config.measurement.r = scaled(fitted.r);
  for (std::size_t j = 0; j < fitted.mode_r.size() && j < config.modes.size(); ++j) {
    config.modes[j].r = fitted.mode_r[j].size() > 0 ? scaled(fitted.mode_r[j]) : Eigen::MatrixXd();
  }
  if (s.dwell_seconds > 0.0) {
    config.transition.kind = TransitionConfig::Kind::kDwellTimes;
    config.transition.dwell_seconds = Eigen::VectorXd::Constant(config.num_modes(), s.dwell_seconds);
  }
  if (s.probability_floor >= 0.0) config.mode_probability_floor = s.probability_floor;
  if (s.likelihood_weight > 0.0) config.likelihood_weight = s.likelihood_weight;
  if (s.likelihood_dof >= 0.0) config.likelihood_dof = s.likelihood_dof;
  if (s.unknown_inflation > 0.0) config.unknown.inflation = s.unknown_inflation;
  if (s.extrapolation_scale >= 0.0) config.extrapolation_scale = s.extrapolation_scale;
  for (std::size_t j = 0; j < fitted.residual_correlation.size() && j < config.modes.size(); ++j) {
    config.modes[j].residual_correlation = fitted.residual_correlation[j];
  }
  for (std::size_t j = 0; j < fitted.fitted_inputs.size() && j < config.modes.size(); ++j) {
    config.modes[j].fitted_inputs = fitted.fitted_inputs[j];
  }
  for (std::size_t j = 0; j < fitted.parameter_covariance.size() && j < bank->models.size(); ++j) {
    // An unchanged covariance leaves the model as it is (the hundreds of scorings of one fold).
    const Eigen::MatrixXd& covariance = fitted.parameter_covariance[j];
    const Eigen::MatrixXd& now = config.modes[j].parameter_covariance;
    if (now.size() != covariance.size() || now != covariance) {
      if (kept != nullptr) {
        kept->set(bank, static_cast<int>(j), covariance);
      } else {
        set_fitted_parameter_covariance(bank, static_cast<int>(j), covariance);
      }
    }
  }
}

}  // namespace internal

}  // namespace fitting
}  // namespace skidimm
