// The function-model spec behind `stc_traction`: stc_sided's states, inputs
// and parameters, and its own (equations in stc_traction_equations.h). In a
// header so tests can run it in-process; the plugin .cc only exports it.
#ifndef SKIDIMM_PLUGINS_STC_TRACTION_STC_TRACTION_MODEL_H_
#define SKIDIMM_PLUGINS_STC_TRACTION_STC_TRACTION_MODEL_H_

#include "skidimm/sdk/function_model.h"
#include "stc_sided/stc_sided_model.h"
#include "stc_traction/stc_traction_equations.h"

namespace skidimm {
namespace plugins {

struct StcTraction {
  static constexpr const char* kName = "stc_traction";
  static constexpr const char* kVersion = "1.0.0";
  static constexpr const char* kDescription =
      "stc_sided's pose model [X, Y, theta] with turn-dependent skid, predicting each side's motor current (omega, "
      "i_L, i_R outputs)";
  static constexpr const auto& kStates = StcSided::kStates;
  static constexpr const auto& kInputs = StcSided::kInputs;
  static constexpr sdk::VariableDoc kOutputs[] = {
      StcSided::kOutputs[0],
      {"i_L", "left motor current, a magnitude (A)", false},
      {"i_R", "right motor current, a magnitude (A)", false},
  };
  // In stc_traction::Parameter order, after stc_sided's.
  static constexpr sdk::ParameterSpec kOwnParameters[] = {
      {"k_skid_l", "how fast the left tread ICR moves out as the turn tightens: by 1 + k_skid_l s^2 (-)", 0.0, 1e4},
      {"k_skid_r", "how fast the right tread ICR moves out as the turn tightens: by 1 + k_skid_r s^2 (-)", 0.0, 1e4},
      {"i_straight", "motor current of each side driving straight (A)", 0.0, 1000.0},
      {"i_l_outer", "left side's extra current at the turn's peak, outer side (A)", 0.0, 1000.0},
      {"i_l_inner", "left side's extra current at the turn's peak, inner side (A)", 0.0, 1000.0},
      {"i_r_outer", "right side's extra current at the turn's peak, outer side (A)", 0.0, 1000.0},
      {"i_r_inner", "right side's extra current at the turn's peak, inner side (A)", 0.0, 1000.0},
      {"s_peak", "wheel-speed turn ratio where the turn current peaks (-)", 0.001, 1.0},
  };
  static constexpr auto kParameters = sdk::join_parameters(StcSided::kParameters, kOwnParameters);
  static_assert(sdk::flat_parameter_count(kParameters) == stc_traction::kNumParameters, "one row per parameter");
  static_assert(sdk::parameter_offset(kParameters, "s_peak") == stc_traction::kTurnPeak,
                "the table in Parameter order");

  template <typename T, typename P>
  static void predict(const T* x, const double* u, const P* p, double dt, T* x_next) {
    stc_traction::predict(x, u, p, dt, x_next);
  }

  template <typename P>
  static void outputs(const double* u, const P* p, P* y) {
    stc_traction::outputs(u, p, y);
  }
};

using StcTractionModel = sdk::FunctionModel<StcTraction>;

}  // namespace plugins
}  // namespace skidimm

#endif  // SKIDIMM_PLUGINS_STC_TRACTION_STC_TRACTION_MODEL_H_
