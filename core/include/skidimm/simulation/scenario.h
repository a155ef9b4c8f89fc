// A simulation scenario: robot, traction modes, mode schedule, maneuver and
// sensors, described in YAML (configs/scenarios/*.yaml, docs/simulation.md),
// and simulate(), which writes a log in the format banks read plus truth
// columns. Deterministic for a given seed on any platform (mt19937_64 and our
// own Gaussian transform).
#ifndef SKIDIMM_SIMULATION_SCENARIO_H_
#define SKIDIMM_SIMULATION_SCENARIO_H_

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "skidimm/simulation/maneuver.h"
#include "skidimm/simulation/skid_steer_dynamics.h"
#include "skidimm/simulation/terrain.h"

namespace skidimm {
namespace simulation {

// What the robot's sensors report (docs/simulation.md, "Sensors"). The
// defaults are the "ideal" sensors of the earlier results: white noise on the
// true body speed, the true heading and 3 cm GPS fixes, no bias. `preset:
// husky` (husky_sensors()) is a Husky-class robot: speed from wheel
// odometry, heading from the course over ground of an RTK receiver, a gyro
// turn-on bias, time-correlated GPS errors, dropouts and outages.
struct SensorConfig {
  enum class Speed { kBody, kOdometry };
  enum class Heading { kDirect, kGpsCourse };

  double rate = 50.0;             // Hz: one log row per sample
  double jitter = 0.0;            // each interval is (1 +- jitter) / rate, uniformly
  double wheel_speed_std = 0.05;  // rad/s, encoder speed noise (the phi_dot columns)
  // The V column: the true body speed plus white noise (kBody), or wheel
  // odometry r (1 + odometry_scale_error) (phi_L + phi_R) / 2 from the
  // measured wheel speeds (kOdometry), which sees no slip at all.
  Speed speed = Speed::kBody;
  double velocity_std = 0.05;          // m/s, kBody
  double odometry_scale_error = 0.0;   // kOdometry: relative error of the radius odometry assumes
  double yaw_rate_std = 0.02;          // rad/s, IMU
  double yaw_rate_bias = 0.0;          // rad/s, IMU, every run
  double yaw_rate_bias_std = 0.0;      // rad/s, IMU turn-on bias drawn once per run
  double accel_std = 0.05;             // m/s^2, IMU
  double gps_rate = 10.0;              // Hz; 0 = no GPS
  double gps_std = 0.03;               // m, white position noise per axis
  double gps_correlated_std = 0.0;     // m, first-order Gauss-Markov position error per axis (multipath)
  double gps_correlation_time = 60.0;  // s, of that error
  // The theta column: the true heading plus white noise (kDirect), or the
  // course over ground of the GPS velocity (kGpsCourse: atan2 of the noisy
  // velocity, empty below course_min_speed, as receivers do), which differs
  // from the heading by the body's sideslip.
  Heading heading = Heading::kDirect;
  double heading_std = 0.03;         // rad, kDirect
  double gps_velocity_std = 0.035;   // m/s per horizontal axis, kGpsCourse
  double course_min_speed = 0.1;     // m/s, kGpsCourse
  double velocity_dropout = 0.0;     // probability that a row lacks V_B
  double imu_dropout = 0.0;          // ... lacks the IMU
  double gps_dropout = 0.0;          // ... lacks a due GPS fix
  double gps_outage_rate = 0.0;      // 1/s: outages (no fix at all) start at this rate
  double gps_outage_duration = 2.0;  // s, mean (exponential) length of an outage
  // Motor currents, the i_L and i_R columns, written only when current_rate
  // is above 0. Each side's drive holds its wheels' speed, so its motor
  // carries the torque T = r (F_front + F_rear) its two wheels' traction
  // forces need (ContactForces::traction), and reports current_no_load + current_per_torque |T| +
  // noise: a magnitude, as the Husky's drivers do. The current is what the
  // ground resists with, which no kinematic sensor sees: a robot with every
  // wheel on tarp turns like one without, but its motors work far less.
  double current_rate = 0.0;        // Hz; 0 = no current columns
  double current_per_torque = 0.0;  // A / (N m) at the wheel: 1 / (torque constant x gear ratio)
  double current_no_load = 0.0;     // A, drawn at any speed (friction in the drive train)
  double current_std = 0.0;         // A, white noise
  double current_dropout = 0.0;     // probability that a due current sample is lost
};

// The sensors of a Husky-class robot with an RTK receiver (`preset: husky`);
// the values and their sources are in docs/simulation.md.
SensorConfig husky_sensors();

struct ScheduleEntry {
  double start = 0.0;  // s
  std::string mode;
};

struct Scenario {
  std::string name;
  std::string description;
  std::filesystem::path file;
  double duration = 30.0;  // s
  std::uint64_t seed = 1;
  double integration_step = 0.0005;  // s
  RobotParameters robot;
  std::vector<TractionMode> modes;
  std::vector<ScheduleEntry> schedule;  // sorted by start, first at 0
  Maneuver maneuver;
  SensorConfig sensors;
};

// Bounds on what simulate() integrates (docs/simulation.md, "Integration
// step"). Classical RK4 on a response decaying at rate r diverges once
// integration_step * r exceeds 2.785; the step must stay below
// kMaxStepTimesRate / r for the fastest response of every mode
// (SkidSteerDynamics::fastest_response), a margin under that limit.
inline constexpr double kMaxStepTimesRate = 2.5;
// duration / integration_step may not exceed this: 20 million steps is
// 10,000 s at the default step of 0.5 ms, minutes of CPU and a log of
// 500,000 rows at 50 Hz. Longer runs are several scenarios with other seeds.
inline constexpr long kMaxIntegrationSteps = 20000000;

// A seed as a scenario's `seed:` and `simulate --seed` take it: a whole
// number that fits 64 bits, read as one (a double cast to an integer is
// undefined behaviour for 1e103, and a signed read wraps -1). Empty when
// `text` is anything else.
std::optional<std::uint64_t> parse_seed(std::string_view text);

// Throws ConfigError with file, line and field: for a malformed file, and for
// a scenario simulate() cannot integrate (check_simulable()).
Scenario load_scenario(const std::filesystem::path& file);

// Throws ConfigError naming the field (no line: the scenario may have been
// changed after loading, e.g. by --duration) when the integration step does
// not resolve the fastest response of some mode, the run needs more than
// kMaxIntegrationSteps steps, or a sensor rate asks for rows more often than
// integration steps (sensors.rate > 1 / integration_step) or GPS fixes more
// often than rows (they are written on rows: gps_rate > rate).
void check_simulable(const Scenario& scenario);

struct SimulationSummary {
  long rows = 0;
  double max_horizontal_accel = 0.0;  // m/s^2, |(ax, ay)| of the body
  double max_friction_accel = 0.0;    // m/s^2, max over modes of mu_max g
  std::vector<std::string> modes_driven;
  // How well the robot followed the maneuver's forward speed, over the rows
  // where it commanded at least 0.1 m/s. A start from rest lags for a
  // moment, so only the rows from the first at which the body went at least
  // half the commanded speed count: the share of them at which it went less
  // (1 when it never did), and the speeds of the worst of them (the
  // commanded and the body's, m/s; where it never did, the largest command
  // and the body's fastest in its direction).
  bool reached_half_command = false;
  double share_behind_command = 0.0;
  double commanded_speed = 0.0;
  double body_speed = 0.0;
};

// Simulates and writes the log (atomically) to `output`. Calls
// check_simulable() first; throws Error naming the time (and writes nothing)
// if the simulated state nevertheless stops being finite.
// Columns: t, phi_dot_L, phi_dot_R (measured), V, omega, ax, ay, X, Y, theta
// (as SensorConfig describes; empty when not measured), mode, then truth:
// true_V, true_vy, true_omega, true_X, true_Y, true_theta, true_phi_dot_L,
// true_phi_dot_R, and last i_L, i_R when the sensors measure motor current
// (sensors.current_rate > 0; empty between samples). The sensors of the default (ideal) SensorConfig draw the
// same random numbers as before the realistic ones existed, so their logs
// are unchanged; the realistic sensors draw from a second stream, and the
// motor currents from a third, so that adding them changed no other column.
SimulationSummary simulate(const Scenario& scenario, std::uint64_t seed, const std::filesystem::path& output);

}  // namespace simulation
}  // namespace skidimm

#endif  // SKIDIMM_SIMULATION_SCENARIO_H_
