// The `stc_traction` model: stc_sided's tread kinematics (stc_sided/stc_sided_predict.h)
// with tread ICRs that move out as the turn tightens, and each side's motor
// current as outputs.
//
// Both depend on the wheel-speed turn ratio
//
//   s = (phi_dot_R - phi_dot_L) / (|phi_dot_L| + |phi_dot_R| + phi_floor)
//
// (0 straight, +-1 spinning in place; phi_floor = 0.5 rad/s keeps a robot at
// rest at s = 0).
//
// Skid that grows with the turn. On slippery treads the share of the wheels'
// yaw rate the body achieves falls steeply as the turn tightens: with the
// right two wheels on tarp, from about 0.45 at s = 0.04 to 0.04 at s = 0.3, on
// skidpads, clothoids, sinusoids and the spiral alike (docs/results.md, "What
// the spiral lets a filter see"). Fixed ICRs hold it constant. Here each
// side's tread ICR moves out by its own factor
//
//   y_l = +alpha_l (b / 2) (1 + k_skid_l s^2)
//   y_r = -alpha_r (b / 2) (1 + k_skid_r s^2)
//
// because a slippery side slips more the harder it is pushed, and a gripping
// side hardly at all: with one side on tarp the robot turns ever more about
// its gripping side, whose ICR stays put, so the forward speed falls from the
// mean of the treads' towards the gripping tread's as well as the yaw rate
// falling (in the simulator, right-two slip's forward speed goes from 0.71 of
// the wheels' mean on the spiral's tightest turn to 0.97 on its widest). With
// k_skid_l = k_skid_r the ICRs move out together, which divides omega and
// the lateral skid by the same factor and leaves v_x unchanged; with both 0
// this is stc_sided.
//
// Motor currents. Each side's drive holds its wheels' speed, so its motor
// draws the current of the torque its wheels' traction needs. Driving
// straight that is the rolling loss alone; in a turn a skid-steer robot
// slides its wheels sideways, the outer side pushing and the inner side
// braking, and each side's torque rises with the turn until the wheels'
// sideways sliding takes over their friction and it falls again
// (docs/simulation.md, "Motor currents"). With the turn shape
//
//   g(s) = 2 (|s| / s_peak) / (1 + (|s| / s_peak)^2)     (0 at 0, 1 at s_peak)
//
// each side draws
//
//   i_L = i_straight + i_l_<role> g(s)      i_R = i_straight + i_r_<role> g(s)
//
// with role the side's part in the turn: turning left (s > 0) the left side
// is inner and the right outer, turning right the reverse. A current is a
// magnitude (as the Husky's drivers report it), so every term is >= 0.
//
// Per mode, after stc_sided's: k_skid_l, k_skid_r (-); i_straight, the current driving
// straight (A: the drive train's own draw and the rolling loss);
// i_<side>_<role>, how much more a side draws at the turn's peak (A);
// s_peak, the turn ratio of that peak (-). What the currents say: slippery
// wheels transmit less torque, so a side on tarp draws less in turns, and a
// robot on tarp on every wheel draws less on both sides, though it turns
// like one with none.
//
// The turn ratio is computed in the parameters' scalar P (function_model.h),
// like every quantity of the inputs and parameters alone.
#ifndef SKIDIMM_PLUGINS_STC_TRACTION_STC_TRACTION_EQUATIONS_H_
#define SKIDIMM_PLUGINS_STC_TRACTION_STC_TRACTION_EQUATIONS_H_

#include <cmath>

#include "stc_sided/stc_sided_predict.h"

namespace skidimm {
namespace plugins {
namespace stc_traction {

using stc_sided::kPhiDotLeft;
using stc_sided::kPhiDotRight;

// stc_traction's own parameters follow stc_sided's in the flat vector.
enum Parameter {
  kSkidGrowthLeft = stc_sided::kNumParameters,
  kSkidGrowthRight,
  kCurrentStraight,
  kCurrentLeftOuter,
  kCurrentLeftInner,
  kCurrentRightOuter,
  kCurrentRightInner,
  kTurnPeak,
  kNumParameters
};

enum Output { kOmegaOutput = 0, kCurrentLeftOutput = 1, kCurrentRightOutput = 2, kNumOutputs = 3 };

// rad/s added to the turn ratio's denominator (see above).
constexpr double kWheelSpeedFloor = 0.5;

template <typename P>
P turn_ratio(const double* u) {
  using std::abs;
  return (P(u[kPhiDotRight]) - P(u[kPhiDotLeft])) /
         (P(abs(u[kPhiDotLeft])) + P(abs(u[kPhiDotRight])) + P(kWheelSpeedFloor));
}

// Body velocity (v_x, v_y, omega) with each tread ICR moved out by its side's
// 1 + k_skid s^2.
template <typename P>
void body_velocity(const double* u, const P* p, P* v_x, P* v_y, P* omega) {
  P y_left, y_right;
  stc_sided::tread_icrs(u, p, &y_left, &y_right);
  const P s = turn_ratio<P>(u);
  y_left *= P(1.0) + p[kSkidGrowthLeft] * s * s;
  y_right *= P(1.0) + p[kSkidGrowthRight] * s * s;
  stc_sided::icr_body_velocity(u, p, y_left, y_right, v_x, v_y, omega);
}

template <typename T, typename P>
void predict(const T* x, const double* u, const P* p, double dt, T* x_next) {
  P v_x, v_y, omega;
  body_velocity(u, p, &v_x, &v_y, &omega);
  stc_sided::pose_step(x, v_x, v_y, omega, dt, x_next);
}

// i_L, i_R (A) from the wheel speeds u and parameters p.
template <typename P>
void motor_currents(const double* u, const P* p, P* current_left, P* current_right) {
  using std::abs;
  const P relative = abs(turn_ratio<P>(u)) / p[kTurnPeak];
  const P shape = P(2.0) * relative / (P(1.0) + relative * relative);
  const bool turning_left = u[kPhiDotRight] > u[kPhiDotLeft];
  const P& left_gain = turning_left ? p[kCurrentLeftInner] : p[kCurrentLeftOuter];
  const P& right_gain = turning_left ? p[kCurrentRightOuter] : p[kCurrentRightInner];
  *current_left = p[kCurrentStraight] + left_gain * shape;
  *current_right = p[kCurrentStraight] + right_gain * shape;
}

// The outputs of stc_traction: omega (the yaw rate it predicts, for a gyro),
// i_L, i_R.
template <typename P>
void outputs(const double* u, const P* p, P* y) {
  P v_x, v_y;
  body_velocity(u, p, &v_x, &v_y, &y[kOmegaOutput]);
  motor_currents(u, p, &y[kCurrentLeftOutput], &y[kCurrentRightOutput]);
}

}  // namespace stc_traction
}  // namespace plugins
}  // namespace skidimm

#endif  // SKIDIMM_PLUGINS_STC_TRACTION_STC_TRACTION_EQUATIONS_H_
