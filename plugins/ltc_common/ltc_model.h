// The function-model spec behind `ltc_linear` and `ltc_shared`
// (function_model.h).
//
// Both plugins integrate eq. 2 with the same code; they differ only in where A
// and B live. `ltc_linear` gives each mode its own A_i, B_i; `ltc_shared` (the
// paper's alternative, section III-A) takes one A, B from the bank's `shared:`
// block, so modes differ only in their process noise Q_i. The scope is part of
// the parameter table, so the bank loader and the fitter treat A, B as one set
// for the whole bank without knowing this plugin.
#ifndef SKIDIMM_PLUGINS_LTC_COMMON_LTC_MODEL_H_
#define SKIDIMM_PLUGINS_LTC_COMMON_LTC_MODEL_H_

#include "ltc_common/ltc_predict.h"
#include "skidimm/sdk/function_model.h"

namespace skidimm {
namespace plugins {

template <sdk::ParameterScope kScope>
struct LtcSpec {
  static constexpr sdk::VariableDoc kStates[] = {
      {"V", "forward speed (m/s)", false},
      {"omega", "yaw rate (rad/s)", false},
  };
  static constexpr sdk::VariableDoc kInputs[] = {
      {"phi_dot_L", "left wheel speed (rad/s)", false},
      {"phi_dot_R", "right wheel speed (rad/s)", false},
  };
  static constexpr sdk::ParameterSpec kParameters[] = {
      {"A", "state matrix of d[V,omega]/dt = A [V,omega] + B [phi_dot_L,phi_dot_R] (1/s)", sdk::Shape{2, 2}, kScope},
      {"B", "input matrix: row V in m/rad/s, row omega in 1/s", sdk::Shape{2, 2}, kScope},
  };
  static constexpr int kA = sdk::parameter_offset(kParameters, "A");
  static constexpr int kB = sdk::parameter_offset(kParameters, "B");

  template <typename T, typename P>
  static void predict(const T* x, const double* u, const P* p, double dt, T* x_next) {
    ltc_predict(x, u, p + kA, p + kB, dt, x_next);
  }

  // F = I + A dt, row-major (ltc_jacobian): what jets of predict give, bit for
  // bit, without their cost on the IMM's every step.
  static void jacobian(const double* /*x*/, const double* /*u*/, const double* p, double dt, double* f) {
    ltc_jacobian(p + kA, dt, f);
  }
  // F above and the default noise Q dt: the engine reuses both while dt repeats.
  static constexpr bool kJacobianAndNoiseDependOnlyOnDt = true;
};

struct LtcLinear : LtcSpec<sdk::ParameterScope::kMode> {
  static constexpr const char* kName = "ltc_linear";
  static constexpr const char* kVersion = "1.0.0";
  static constexpr const char* kDescription =
      "Linear terrain model [V, omega] driven by wheel speeds, per-mode A_i, B_i (paper eq. 2)";
};

struct LtcShared : LtcSpec<sdk::ParameterScope::kBank> {
  static constexpr const char* kName = "ltc_shared";
  static constexpr const char* kVersion = "1.0.0";
  static constexpr const char* kDescription =
      "Linear terrain model [V, omega] with one A, B shared by all modes; modes differ by Q_i";
};

// The models, for tests that run them in-process.
template <sdk::ParameterScope kScope>
using LtcModel = sdk::FunctionModel<std::conditional_t<kScope == sdk::ParameterScope::kMode, LtcLinear, LtcShared>>;

}  // namespace plugins
}  // namespace skidimm

#endif  // SKIDIMM_PLUGINS_LTC_COMMON_LTC_MODEL_H_
