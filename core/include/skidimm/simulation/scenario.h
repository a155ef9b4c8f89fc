// A simulation scenario: robot, traction modes, mode schedule, maneuver and
// sensors, described in YAML (configs/scenarios/*.yaml, docs/simulation.md),
// and simulate(), which writes a log in the format banks read plus truth
// columns. Deterministic for a given seed on any platform (mt19937_64 and our
// own Gaussian transform).
#ifndef SKIDIMM_SIMULATION_SCENARIO_H_
#define SKIDIMM_SIMULATION_SCENARIO_H_

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "skidimm/simulation/maneuver.h"
#include "skidimm/simulation/skid_steer_dynamics.h"
#include "skidimm/simulation/terrain.h"

namespace skidimm {
namespace simulation {

struct SensorConfig {
  double rate = 50.0;             // Hz: one log row per sample
  double jitter = 0.0;            // each interval is (1 +- jitter) / rate, uniformly
  double wheel_speed_std = 0.05;  // rad/s, encoder speed noise
  double velocity_std = 0.05;     // m/s, body forward speed V_B
  double yaw_rate_std = 0.02;     // rad/s, IMU
  double yaw_rate_bias = 0.0;     // rad/s, IMU
  double accel_std = 0.05;        // m/s^2, IMU
  double gps_rate = 10.0;         // Hz; 0 = no GPS
  double gps_std = 0.03;          // m
  double heading_std = 0.03;      // rad, GPS-derived heading
  double velocity_dropout = 0.0;  // probability that a row lacks V_B
  double imu_dropout = 0.0;       // ... lacks the IMU
  double gps_dropout = 0.0;       // ... lacks a due GPS fix
};

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

// Throws ConfigError with file, line and field.
Scenario load_scenario(const std::filesystem::path& file);

struct SimulationSummary {
  long rows = 0;
  double max_horizontal_accel = 0.0;  // m/s^2, |(ax, ay)| of the body
  double max_friction_accel = 0.0;    // m/s^2, max over modes of mu_max g
  std::vector<std::string> modes_driven;
};

// Simulates and writes the log (atomically) to `output`.
// Columns: t, phi_dot_L, phi_dot_R (measured), V, omega, ax, ay, X, Y, theta
// (empty when not measured), mode, then truth: true_V, true_vy, true_omega,
// true_X, true_Y, true_theta, true_phi_dot_L, true_phi_dot_R.
SimulationSummary simulate(const Scenario& scenario, std::uint64_t seed, const std::filesystem::path& output);

}  // namespace simulation
}  // namespace skidimm

#endif  // SKIDIMM_SIMULATION_SCENARIO_H_
