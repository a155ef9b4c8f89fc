// Kinematic slip model for small traction changes (paper, eq. 3):
//
//   u1 = r (phi_dot_L + phi_dot_R) / 2      requested forward speed (m/s)
//   u2 = r (phi_dot_R - phi_dot_L) / b      requested yaw rate (rad/s)
//   dX/dt = k cos(theta) u1,  dY/dt = k sin(theta) u1,  dtheta/dt = m u2
//
// with the forward-Euler step of eq. 1. k and m scale the requested
// velocities; each slip mode has its own pair. (The paper prints phi_L in u1;
// wheel speeds phi_dot are meant, as in u2.) T is the state's scalar and P
// the parameters' (function_model.h).
#ifndef SKIDIMM_PLUGINS_STC_KINEMATIC_STC_KINEMATIC_PREDICT_H_
#define SKIDIMM_PLUGINS_STC_KINEMATIC_STC_KINEMATIC_PREDICT_H_

#include <cmath>

namespace skidimm {
namespace plugins {

enum StcState { kX = 0, kY = 1, kTheta = 2 };
enum StcInput { kStcPhiDotLeft = 0, kStcPhiDotRight = 1 };

template <typename P>
void stc_requested_velocities(const double* u, const P& r, const P& b, P* forward, P* yaw_rate) {
  *forward = r * (u[kStcPhiDotLeft] + u[kStcPhiDotRight]) / P(2.0);
  *yaw_rate = r * (u[kStcPhiDotRight] - u[kStcPhiDotLeft]) / b;
}

template <typename T, typename P>
void stc_predict(const T* x, const double* u, const P& k, const P& m, const P& r, const P& b, double dt, T* x_next) {
  using std::cos;
  using std::sin;
  P forward, yaw_rate;
  stc_requested_velocities(u, r, b, &forward, &yaw_rate);
  const T cos_theta = cos(x[kTheta]);
  const T sin_theta = sin(x[kTheta]);
  x_next[kX] = x[kX] + k * cos_theta * forward * dt;
  x_next[kY] = x[kY] + k * sin_theta * forward * dt;
  x_next[kTheta] = x[kTheta] + m * yaw_rate * dt;
}

}  // namespace plugins
}  // namespace skidimm

#endif  // SKIDIMM_PLUGINS_STC_KINEMATIC_STC_KINEMATIC_PREDICT_H_
