// Kinematics of a skid-steer robot from the instantaneous centres of rotation
// (ICRs) of its treads (Mandow et al., "Experimental kinematics for wheeled
// skid-steer mobile robots", IROS 2007).
//
// Body frame: x forward, y to the left, yaw counter-clockwise. Each side's
// wheels act as one tread whose ground speed is efficiency * r * phi_dot.
// The left tread's ICR lies at lateral position y_l > 0, the right one's at
// y_r < 0: the points of the body that move with the tread's speed. Then
//
//   omega = (v_r - v_l) / (y_l - y_r)
//   v_x   = (v_r y_l - v_l y_r) / (y_l - y_r)
//   v_y   = -x_v omega
//
// where x_v is the longitudinal position of the vehicle's ICR (0 for a
// symmetric load). With y_l = -y_r = b/2, x_v = 0 and efficiency 1 this is the
// ideal differential drive; y_l - y_r > b models the skidding every turn needs.
// The pose follows with the forward-Euler step of the paper's eq. 1.
#ifndef ICR_KINEMATIC_PREDICT_H_
#define ICR_KINEMATIC_PREDICT_H_

#include <cmath>

namespace icr_kinematic {

enum State { kX = 0, kY = 1, kTheta = 2 };
enum Input { kPhiDotLeft = 0, kPhiDotRight = 1 };

template <typename T>
struct IcrParameters {
  T y_left;      // m, > 0
  T y_right;     // m, < 0
  T x_vehicle;   // m
  T efficiency;  // tread speed / (r * wheel speed)
  T r;           // m, wheel radius
};

template <typename T>
void icr_body_velocity(const T* u, const IcrParameters<T>& p, T* v_x, T* v_y, T* omega) {
  const T v_l = p.efficiency * p.r * u[kPhiDotLeft];
  const T v_r = p.efficiency * p.r * u[kPhiDotRight];
  const T spread = p.y_left - p.y_right;
  *omega = (v_r - v_l) / spread;
  *v_x = (v_r * p.y_left - v_l * p.y_right) / spread;
  *v_y = -p.x_vehicle * *omega;
}

template <typename T>
void icr_predict(const T* x, const T* u, const IcrParameters<T>& p, const T& dt, T* x_next) {
  using std::cos;
  using std::sin;
  T v_x, v_y, omega;
  icr_body_velocity(u, p, &v_x, &v_y, &omega);
  const T c = cos(x[kTheta]);
  const T s = sin(x[kTheta]);
  x_next[kX] = x[kX] + (v_x * c - v_y * s) * dt;
  x_next[kY] = x[kY] + (v_x * s + v_y * c) * dt;
  x_next[kTheta] = x[kTheta] + omega * dt;
}

}  // namespace icr_kinematic

#endif  // ICR_KINEMATIC_PREDICT_H_
