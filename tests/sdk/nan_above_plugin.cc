// A [V, omega] model in the function form whose yaw rate turns NaN once the
// speed V exceeds the parameter `above` (m/s): sqrt(above - V) is NaN there,
// and so is its derivative. The engine and the conformance kit must name the
// entry that is not finite, not just say that the model failed.
#include <cmath>

#include "skidimm/sdk/function_model.h"

struct NanAbove {
  static constexpr const char* kName = "nan_above";
  static constexpr const char* kVersion = "0.0.1";
  static constexpr const char* kDescription = "[V, omega] whose omega is NaN above a speed";
  static constexpr skidimm::sdk::VariableDoc kStates[] = {{"V", "forward speed (m/s)", false},
                                                          {"omega", "yaw rate (rad/s)", false}};
  static constexpr skidimm::sdk::VariableDoc kInputs[] = {{"phi_dot_L", "left wheel speed (rad/s)", false},
                                                          {"phi_dot_R", "right wheel speed (rad/s)", false}};
  static constexpr skidimm::sdk::ParameterSpec kParameters[] = {
      {"above", "speed above which omega is NaN (m/s)", -10.0, 10.0}};

  template <typename T, typename P>
  static void predict(const T* x, const double* u, const P* p, double dt, T* x_next) {
    using std::sqrt;
    x_next[0] = x[0] + dt * (0.1 * (u[0] + u[1]) - x[0]);
    x_next[1] = x[1] + dt * (sqrt(p[0] - x[0]) - x[1]);
  }
};

SKIDIMM_EXPORT_FUNCTION_MODEL(NanAbove)
