// Linear terrain model for large traction changes (paper, eq. 2):
//
//   d/dt [V, omega]' = A [V, omega]' + B [phi_dot_L, phi_dot_R]'
//
// discretised with the paper's forward-Euler step (eq. 1):
//   x_{k+1} = x_k + (A x_k + B u_k) dt.
//
// V: body longitudinal velocity (m/s); omega: body yaw rate (rad/s);
// phi_dot_L/R: left/right wheel angular speeds (rad/s).
// A and B are row-major 2x2 arrays. T is the state's scalar and P the
// parameters' (function_model.h), so Ceres can differentiate it.
#ifndef SKIDIMM_PLUGINS_LTC_COMMON_LTC_PREDICT_H_
#define SKIDIMM_PLUGINS_LTC_COMMON_LTC_PREDICT_H_

namespace skidimm {
namespace plugins {

enum LtcState { kV = 0, kOmega = 1 };
enum LtcInput { kPhiDotLeft = 0, kPhiDotRight = 1 };

template <typename T, typename P>
void ltc_predict(const T* x, const double* u, const P* a, const P* b, double dt, T* x_next) {
  const T v_dot = a[0] * x[kV] + a[1] * x[kOmega] + b[0] * u[kPhiDotLeft] + b[1] * u[kPhiDotRight];
  const T omega_dot = a[2] * x[kV] + a[3] * x[kOmega] + b[2] * u[kPhiDotLeft] + b[3] * u[kPhiDotRight];
  x_next[kV] = x[kV] + v_dot * dt;
  x_next[kOmega] = x[kOmega] + omega_dot * dt;
}

// d x_next / d x = I + A dt, row-major, each entry summed as Ceres' jets
// differentiate ltc_predict(): the identity's entry plus A's times dt.
inline void ltc_jacobian(const double* a, double dt, double* f) {
  for (int r = 0; r < 2; ++r) {
    for (int c = 0; c < 2; ++c) f[2 * r + c] = (r == c ? 1.0 : 0.0) + a[2 * r + c] * dt;
  }
}

}  // namespace plugins
}  // namespace skidimm

#endif  // SKIDIMM_PLUGINS_LTC_COMMON_LTC_PREDICT_H_
