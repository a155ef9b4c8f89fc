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
//   alpha_l = alpha_l_inner, alpha_r = alpha_r_outer   turning left  (phi_dot_R > phi_dot_L)
//   alpha_l = alpha_l_outer, alpha_r = alpha_r_inner   turning right (phi_dot_R < phi_dot_L)
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
// traction of each side); alpha_<side>_<role>, how far outside its wheels
// each tread's ICR lies, in half tracks (1: on the wheel line, the ideal
// differential drive; larger: the tread skids more as the robot turns), for
// the tread on the outside of the turn, which pushes, and on the inside,
// which brakes; x_icr, the longitudinal position of the vehicle's ICR (m; 0
// for symmetric grip, negative when the front slides out, positive when the
// rear does). Per bank: r and b.
//
// Why an ICR per role: a tread slips under its traction force, and in a
// skid-steer turn the outer tread drives and the inner one brakes. A side
// whose wheels are slippery slips most where it has to push, so its ICR
// moves out further when it is the outer tread: a left and a right turn of
// the same radius then differ, as they do on the robot and the simulator
// (docs/simulation.md), while driving straight (no force to slip under) stays
// straight. Going straight (phi_dot_L = phi_dot_R) omega = 0 and v_x = the
// tread speed whichever ICRs apply, so the motion is continuous across the
// switch of roles.
//
// T is the state's scalar and P the parameters' (function_model.h): in the
// state Jacobian only the pose step is differentiated, and the body velocity
// is the same plain double arithmetic as in the step.
//
// With eta_l = eta_r = 1, every alpha = 1 and x_icr = 0 this is the ideal
// differential drive. With eta_l = eta_r = k, every alpha = k / m and
// x_icr = 0 it is eq. 3 with (k, m): the model contains eq. 3. What eq. 3
// cannot say and this model can: which side slips (eta_l != eta_r, or the
// alphas of one side larger), so that left and right turns differ, and which
// end slides out (x_icr).
#ifndef SKIDIMM_PLUGINS_STC_SIDED_STC_SIDED_PREDICT_H_
#define SKIDIMM_PLUGINS_STC_SIDED_STC_SIDED_PREDICT_H_

#include <cmath>

namespace skidimm {
namespace plugins {
namespace stc_sided {

enum State { kX = 0, kY = 1, kTheta = 2, kNumStates = 3 };
enum Input { kPhiDotLeft = 0, kPhiDotRight = 1, kNumInputs = 2 };
// The order of the flat parameter vector (the plugin's parameter table).
enum Parameter {
  kEtaLeft = 0,
  kEtaRight = 1,
  kAlphaLeftOuter = 2,
  kAlphaLeftInner = 3,
  kAlphaRightOuter = 4,
  kAlphaRightInner = 5,
  kXIcr = 6,
  kRadius = 7,
  kTrack = 8,
  kNumParameters = 9
};

// The tread ICRs' lateral positions (body y, m) for the turn u makes: each
// tread's alpha for its role in that turn.
template <typename P>
void tread_icrs(const double* u, const P* p, P* y_left, P* y_right) {
  const bool turning_left = u[kPhiDotRight] > u[kPhiDotLeft];
  const P& alpha_left = turning_left ? p[kAlphaLeftInner] : p[kAlphaLeftOuter];
  const P& alpha_right = turning_left ? p[kAlphaRightOuter] : p[kAlphaRightInner];
  *y_left = alpha_left * p[kTrack] / P(2.0);
  *y_right = -alpha_right * p[kTrack] / P(2.0);
}

// Body velocity (v_x, v_y, omega) from the tread ICRs y_left > 0 > y_right.
template <typename P>
void icr_body_velocity(const double* u, const P* p, const P& y_left, const P& y_right, P* v_x, P* v_y, P* omega) {
  const P v_left = p[kEtaLeft] * p[kRadius] * u[kPhiDotLeft];
  const P v_right = p[kEtaRight] * p[kRadius] * u[kPhiDotRight];
  const P spread = y_left - y_right;
  *omega = (v_right - v_left) / spread;
  *v_x = (v_right * y_left - v_left * y_right) / spread;
  *v_y = -p[kXIcr] * *omega;
}

// Body velocity (v_x, v_y, omega) from the wheel speeds u and parameters p
// (in Parameter order).
template <typename P>
void body_velocity(const double* u, const P* p, P* v_x, P* v_y, P* omega) {
  P y_left, y_right;
  tread_icrs(u, p, &y_left, &y_right);
  icr_body_velocity(u, p, y_left, y_right, v_x, v_y, omega);
}

// The pose after dt at body velocity (v_x, v_y, omega).
template <typename T, typename P>
void pose_step(const T* x, const P& v_x, const P& v_y, const P& omega, double dt, T* x_next) {
  using std::cos;
  using std::sin;
  const T c = cos(x[kTheta]);
  const T s = sin(x[kTheta]);
  x_next[kX] = x[kX] + (v_x * c - v_y * s) * dt;
  x_next[kY] = x[kY] + (v_x * s + v_y * c) * dt;
  x_next[kTheta] = x[kTheta] + omega * dt;
}

template <typename T, typename P>
void predict(const T* x, const double* u, const P* p, double dt, T* x_next) {
  P v_x, v_y, omega;
  body_velocity(u, p, &v_x, &v_y, &omega);
  pose_step(x, v_x, v_y, omega, dt, x_next);
}

}  // namespace stc_sided
}  // namespace plugins
}  // namespace skidimm

#endif  // SKIDIMM_PLUGINS_STC_SIDED_STC_SIDED_PREDICT_H_
