// Sided slip model for small traction changes: per-side tread traction and
// lateral skid, from the instantaneous centres of rotation (ICRs) of the
// treads (Mandow, Martinez, Morales, Blanco, Garcia-Cerezo and Gonzalez,
// "Experimental kinematics for wheeled skid-steer mobile robots", IROS 2007,
// the paper's reference [1]; the ICR formulation of Martinez et al., "Approximating
// kinematics for tracked mobile robots", IJRR 24(10), 2005).
//
// Body frame: x forward, y to the left, yaw counter-clockwise; world frame X
// east, Y north, theta from X. The two wheels of a side act as one tread.
//
//   v_l = eta_l r phi_dot_L       v_r = eta_r r phi_dot_R       tread speeds (m/s)
//   y_l = +alpha_l b / 2          y_r = -alpha_r b / 2          tread ICRs, body y (m)
//   omega = (v_r - v_l) / (y_l - y_r)
//   v_x   = (v_r y_l - v_l y_r) / (y_l - y_r)
//   v_y   = -x_icr omega
//
// and the pose follows with the forward-Euler step of the paper's eq. 1:
//
//   X' = X + (v_x cos theta - v_y sin theta) dt
//   Y' = Y + (v_x sin theta + v_y cos theta) dt
//   theta' = theta + omega dt
//
// Per mode: eta_l, eta_r, the tread efficiencies (ground speed of a side's
// contact points over r phi_dot: below 1 when the side's wheels spin, the
// traction of each side); alpha_l, alpha_r, how far outside its wheels each
// tread's ICR lies, in half tracks (1: on the wheel line, the ideal
// differential drive; larger: the side skids more as the robot turns);
// x_icr, the longitudinal position of the vehicle's ICR (m; 0 for symmetric
// grip, negative when the front slides out, positive when the rear does).
// Per bank: r and b.
//
// With eta_l = eta_r = 1, alpha_l = alpha_r = 1 and x_icr = 0 this is the
// ideal differential drive. With eta_l = eta_r = k, alpha_l = alpha_r = k / m
// and x_icr = 0 it is eq. 3 with (k, m): the model contains eq. 3. What eq. 3
// cannot say and this model can: which side slips (eta_l != eta_r), so that a
// left and a right turn at the same speed differ (the speed-weighted term
// (eta_r - eta_l) r (phi_dot_L + phi_dot_R) / 2 of omega changes sign with
// nothing but the turn), and which end slides out (x_icr).
#ifndef SKIDIMM_PLUGINS_STC_SIDED_STC_SIDED_PREDICT_H_
#define SKIDIMM_PLUGINS_STC_SIDED_STC_SIDED_PREDICT_H_

#include <cmath>

namespace skidimm {
namespace plugins {
namespace stc_sided {

enum State { kX = 0, kY = 1, kTheta = 2, kNumStates = 3 };
enum Input { kPhiDotLeft = 0, kPhiDotRight = 1, kNumInputs = 2 };
// The order of the flat parameter vector (MotionModel::get_parameters).
enum Parameter {
  kEtaLeft = 0,
  kEtaRight = 1,
  kAlphaLeft = 2,
  kAlphaRight = 3,
  kXIcr = 4,
  kRadius = 5,
  kTrack = 6,
  kNumParameters = 7
};

// Body velocity (v_x, v_y, omega) from the wheel speeds u and parameters p
// (in Parameter order).
template <typename T>
void body_velocity(const T* u, const T* p, T* v_x, T* v_y, T* omega) {
  const T v_left = p[kEtaLeft] * p[kRadius] * u[kPhiDotLeft];
  const T v_right = p[kEtaRight] * p[kRadius] * u[kPhiDotRight];
  const T y_left = p[kAlphaLeft] * p[kTrack] / T(2.0);
  const T y_right = -p[kAlphaRight] * p[kTrack] / T(2.0);
  const T spread = y_left - y_right;
  *omega = (v_right - v_left) / spread;
  *v_x = (v_right * y_left - v_left * y_right) / spread;
  *v_y = -p[kXIcr] * *omega;
}

template <typename T>
void predict(const T* x, const T* u, const T* p, const T& dt, T* x_next) {
  using std::cos;
  using std::sin;
  T v_x, v_y, omega;
  body_velocity(u, p, &v_x, &v_y, &omega);
  const T c = cos(x[kTheta]);
  const T s = sin(x[kTheta]);
  x_next[kX] = x[kX] + (v_x * c - v_y * s) * dt;
  x_next[kY] = x[kY] + (v_x * s + v_y * c) * dt;
  x_next[kTheta] = x[kTheta] + omega * dt;
}

// Row-major 3x3 Jacobian d x_next / d x of predict(): the identity plus the
// heading column.
inline void state_jacobian(const double* x, const double* u, const double* p, double dt, double* jacobian) {
  double v_x, v_y, omega;
  body_velocity(u, p, &v_x, &v_y, &omega);
  const double c = std::cos(x[kTheta]);
  const double s = std::sin(x[kTheta]);
  const double rows[9] = {1.0, 0.0, (-v_x * s - v_y * c) * dt,  //
                          0.0, 1.0, (v_x * c - v_y * s) * dt,   //
                          0.0, 0.0, 1.0};
  for (int i = 0; i < 9; ++i) jacobian[i] = rows[i];
}

}  // namespace stc_sided
}  // namespace plugins
}  // namespace skidimm

#endif  // SKIDIMM_PLUGINS_STC_SIDED_STC_SIDED_PREDICT_H_
