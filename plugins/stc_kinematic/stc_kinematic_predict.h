// Kinematic slip model for small traction changes (paper, eq. 3):
//
//   u1 = r (phi_dot_L + phi_dot_R) / 2      requested forward speed (m/s)
//   u2 = r (phi_dot_R - phi_dot_L) / b      requested yaw rate (rad/s)
//   dX/dt = k cos(theta) u1,  dY/dt = k sin(theta) u1,  dtheta/dt = m u2
//
// with the forward-Euler step of eq. 1. k and m scale the requested
// velocities; each slip mode has its own pair. (The paper prints phi_L in u1;
// wheel speeds phi_dot are meant, as in u2.) The Jacobian is the exact one of
// the Euler step, I + dt * df/dx.
#ifndef SKIDIMM_PLUGINS_STC_KINEMATIC_STC_KINEMATIC_PREDICT_H_
#define SKIDIMM_PLUGINS_STC_KINEMATIC_STC_KINEMATIC_PREDICT_H_

#include <cmath>

namespace skidimm {
namespace plugins {

enum StcState { kX = 0, kY = 1, kTheta = 2 };
enum StcInput { kStcPhiDotLeft = 0, kStcPhiDotRight = 1 };

struct StcParameters {
  double k;  // longitudinal efficiency (-)
  double m;  // yaw efficiency (-)
  double r;  // wheel radius (m)
  double b;  // track width (m)
};

template <typename T>
void stc_requested_velocities(const T* u, const T& r, const T& b, T* forward, T* yaw_rate) {
  *forward = r * (u[kStcPhiDotLeft] + u[kStcPhiDotRight]) / T(2.0);
  *yaw_rate = r * (u[kStcPhiDotRight] - u[kStcPhiDotLeft]) / b;
}

// The step with sin(theta), cos(theta) given (computed once for the
// prediction and its Jacobian).
template <typename T>
void stc_predict_trig(const T* x, const T* u, const T& sin_theta, const T& cos_theta, const T& k, const T& m,
                      const T& r, const T& b, const T& dt, T* x_next) {
  T forward, yaw_rate;
  stc_requested_velocities(u, r, b, &forward, &yaw_rate);
  x_next[kX] = x[kX] + k * cos_theta * forward * dt;
  x_next[kY] = x[kY] + k * sin_theta * forward * dt;
  x_next[kTheta] = x[kTheta] + m * yaw_rate * dt;
}

template <typename T>
void stc_predict(const T* x, const T* u, const T& k, const T& m, const T& r, const T& b, const T& dt, T* x_next) {
  using std::cos;
  using std::sin;
  stc_predict_trig(x, u, T(sin(x[kTheta])), T(cos(x[kTheta])), k, m, r, b, dt, x_next);
}

// Row-major 3x3 Jacobian d x_next / d x, with sin(theta), cos(theta) given.
inline void stc_jacobian_trig(const double* u, double sin_theta, double cos_theta, const StcParameters& p, double dt,
                              double* jacobian) {
  double forward, yaw_rate;
  stc_requested_velocities(u, p.r, p.b, &forward, &yaw_rate);
  const double rows[9] = {1.0, 0.0, -p.k * sin_theta * forward * dt,  //
                          0.0, 1.0, p.k * cos_theta * forward * dt,   //
                          0.0, 0.0, 1.0};
  for (int i = 0; i < 9; ++i) jacobian[i] = rows[i];
}

inline void stc_jacobian(const double* x, const double* u, const StcParameters& p, double dt, double* jacobian) {
  stc_jacobian_trig(u, std::sin(x[kTheta]), std::cos(x[kTheta]), p, dt, jacobian);
}

}  // namespace plugins
}  // namespace skidimm

#endif  // SKIDIMM_PLUGINS_STC_KINEMATIC_STC_KINEMATIC_PREDICT_H_
