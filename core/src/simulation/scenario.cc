#include "skidimm/simulation/scenario.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <set>

#include "../yaml_fields.h"
#include "skidimm/errors.h"
#include "skidimm/log_io.h"
#include "skidimm/sdk/angles.h"
#include "skidimm/simulation/random.h"

namespace skidimm {
namespace simulation {

namespace fs = std::filesystem;
using internal::YamlFields;

namespace {

double positive(const YamlFields& y, const YAML::Node& node, const std::string& field) {
  const double value = y.number(node, field);
  if (!(value > 0.0) || !std::isfinite(value)) y.fail(node, field, "must be a finite number > 0");
  return value;
}

double non_negative(const YamlFields& y, const YAML::Node& node, const std::string& field) {
  const double value = y.number(node, field);
  if (!(value >= 0.0) || !std::isfinite(value)) y.fail(node, field, "must be a finite number >= 0");
  return value;
}

double probability(const YamlFields& y, const YAML::Node& node, const std::string& field) {
  const double value = y.number(node, field);
  if (!(value >= 0.0 && value <= 1.0)) y.fail(node, field, "must be a probability in [0, 1]");
  return value;
}

void parse_robot(const YamlFields& y, const YAML::Node& node, RobotParameters* robot) {
  y.check_keys(node, {"mass", "yaw_inertia", "wheel_radius", "track", "wheelbase", "motor_time_constant"}, "robot");
  if (node["mass"]) robot->mass = positive(y, node["mass"], "robot.mass");
  if (node["yaw_inertia"]) robot->yaw_inertia = positive(y, node["yaw_inertia"], "robot.yaw_inertia");
  if (node["wheel_radius"]) robot->wheel_radius = positive(y, node["wheel_radius"], "robot.wheel_radius");
  if (node["track"]) robot->track = positive(y, node["track"], "robot.track");
  if (node["wheelbase"]) robot->wheelbase = positive(y, node["wheelbase"], "robot.wheelbase");
  if (node["motor_time_constant"]) {
    robot->motor_time_constant = positive(y, node["motor_time_constant"], "robot.motor_time_constant");
  }
}

void parse_maneuver(const YamlFields& y, const YAML::Node& node, Maneuver* m) {
  y.check_keys(node,
               {"type", "speed", "ramp", "direction", "radius", "initial_radius", "radius_rate", "initial_curvature",
                "curvature_rate", "yaw_rate_amplitude", "period"},
               "maneuver");
  const YAML::Node type = y.required(node, "type", "maneuver");
  if (!parse_maneuver_type(y.string(type, "maneuver.type"), &m->type)) {
    y.fail(type, "maneuver.type", "expected straight, skidpad, clothoid, sinusoidal or spiral");
  }
  if (node["speed"]) m->speed = y.number(node["speed"], "maneuver.speed");
  if (node["ramp"]) m->ramp = non_negative(y, node["ramp"], "maneuver.ramp");
  if (node["direction"]) {
    const std::string d = y.string(node["direction"], "maneuver.direction");
    if (d != "left" && d != "right") y.fail(node["direction"], "maneuver.direction", "expected left or right");
    m->direction = d == "left" ? 1.0 : -1.0;
  }
  if (node["radius"]) m->radius = positive(y, node["radius"], "maneuver.radius");
  if (node["initial_radius"]) m->initial_radius = positive(y, node["initial_radius"], "maneuver.initial_radius");
  if (node["radius_rate"]) m->radius_rate = non_negative(y, node["radius_rate"], "maneuver.radius_rate");
  if (node["initial_curvature"])
    m->initial_curvature = y.number(node["initial_curvature"], "maneuver.initial_curvature");
  if (node["curvature_rate"]) m->curvature_rate = y.number(node["curvature_rate"], "maneuver.curvature_rate");
  if (node["yaw_rate_amplitude"]) {
    m->yaw_rate_amplitude = non_negative(y, node["yaw_rate_amplitude"], "maneuver.yaw_rate_amplitude");
  }
  if (node["period"]) m->period = positive(y, node["period"], "maneuver.period");
}

void parse_sensors(const YamlFields& y, const YAML::Node& node, SensorConfig* s) {
  y.check_keys(node,
               {"rate", "jitter", "wheel_speed_std", "velocity_std", "yaw_rate_std", "yaw_rate_bias", "accel_std",
                "gps_rate", "gps_std", "heading_std", "velocity_dropout", "imu_dropout", "gps_dropout"},
               "sensors");
  if (node["rate"]) s->rate = positive(y, node["rate"], "sensors.rate");
  if (node["jitter"]) {
    s->jitter = non_negative(y, node["jitter"], "sensors.jitter");
    if (s->jitter >= 1.0) y.fail(node["jitter"], "sensors.jitter", "must be below 1 (time must increase)");
  }
  auto set = [&](const char* key, double* out, bool allow_negative) {
    if (!node[key]) return;
    *out = allow_negative ? y.number(node[key], std::string("sensors.") + key)
                          : non_negative(y, node[key], std::string("sensors.") + key);
  };
  set("wheel_speed_std", &s->wheel_speed_std, false);
  set("velocity_std", &s->velocity_std, false);
  set("yaw_rate_std", &s->yaw_rate_std, false);
  set("yaw_rate_bias", &s->yaw_rate_bias, true);
  set("accel_std", &s->accel_std, false);
  set("gps_rate", &s->gps_rate, false);
  set("gps_std", &s->gps_std, false);
  set("heading_std", &s->heading_std, false);
  auto set_probability = [&](const char* key, double* out) {
    if (node[key]) *out = probability(y, node[key], std::string("sensors.") + key);
  };
  set_probability("velocity_dropout", &s->velocity_dropout);
  set_probability("imu_dropout", &s->imu_dropout);
  set_probability("gps_dropout", &s->gps_dropout);
}

std::string number(double v) { return CsvWriter::format(std::round(v * 1e6) / 1e6); }

}  // namespace

Scenario load_scenario(const fs::path& file) {
  const YamlFields y(file.string());
  const YAML::Node root = y.load_mapping("scenario");
  y.check_keys(root,
               {"name", "description", "duration", "seed", "integration_step", "robot", "modes", "mode", "schedule",
                "maneuver", "sensors"},
               "");
  Scenario s;
  s.file = file;
  s.name = y.string(y.required(root, "name", ""), "name");
  if (root["description"]) s.description = y.string(root["description"], "description");
  s.duration = positive(y, y.required(root, "duration", ""), "duration");
  if (root["seed"]) s.seed = static_cast<std::uint64_t>(non_negative(y, root["seed"], "seed"));
  if (root["integration_step"]) {
    s.integration_step = positive(y, root["integration_step"], "integration_step");
    if (s.integration_step > 0.005) y.fail(root["integration_step"], "integration_step", "must be <= 0.005 s");
  }
  if (root["robot"]) parse_robot(y, root["robot"], &s.robot);

  const YAML::Node modes = y.required(root, "modes", "");
  if (!modes.IsMap() || modes.size() == 0)
    y.fail(modes, "modes", "expected a mapping from mode name to {terrain, tarp}");
  for (const auto& entry : modes) {
    const std::string name = entry.first.as<std::string>();
    const std::string field = "modes." + name;
    y.check_keys(entry.second, {"terrain", "tarp"}, field);
    const std::string terrain = y.string(y.required(entry.second, "terrain", field), field + ".terrain");
    std::vector<std::string> tarp;
    if (entry.second["tarp"]) tarp = y.string_list(entry.second["tarp"], field + ".tarp");
    try {
      s.modes.push_back(make_traction_mode(name, terrain, tarp));
    } catch (const std::invalid_argument& e) {
      y.fail(entry.second, field, e.what());
    }
  }
  auto mode_exists = [&s](const std::string& name) {
    return std::any_of(s.modes.begin(), s.modes.end(), [&](const TractionMode& m) { return m.name == name; });
  };
  if (root["mode"] && root["schedule"]) y.fail(root, "schedule", "give either 'mode' (singular) or 'schedule'");
  if (root["mode"]) {
    s.schedule.push_back({0.0, y.string(root["mode"], "mode")});
    if (!mode_exists(s.schedule[0].mode))
      y.fail(root["mode"], "mode", "no mode '" + s.schedule[0].mode + "' under modes");
  } else {
    const YAML::Node schedule = y.required(root, "schedule", "");
    if (!schedule.IsSequence() || schedule.size() == 0) y.fail(schedule, "schedule", "expected a list of {at, mode}");
    for (std::size_t i = 0; i < schedule.size(); ++i) {
      const std::string field = "schedule[" + std::to_string(i) + "]";
      y.check_keys(schedule[i], {"at", "mode"}, field);
      ScheduleEntry entry{non_negative(y, y.required(schedule[i], "at", field), field + ".at"),
                          y.string(y.required(schedule[i], "mode", field), field + ".mode")};
      if (!mode_exists(entry.mode)) y.fail(schedule[i], field + ".mode", "no mode '" + entry.mode + "' under modes");
      if (i == 0 && entry.start != 0.0) y.fail(schedule[i], field + ".at", "the first entry must start at 0");
      if (i > 0 && !(entry.start > s.schedule.back().start)) {
        y.fail(schedule[i], field + ".at", "switch times must increase");
      }
      s.schedule.push_back(entry);
    }
  }
  parse_maneuver(y, y.required(root, "maneuver", ""), &s.maneuver);
  if (root["sensors"]) parse_sensors(y, root["sensors"], &s.sensors);
  return s;
}

SimulationSummary simulate(const Scenario& scenario, std::uint64_t seed, const fs::path& output) {
  const SkidSteerDynamics dynamics(scenario.robot);
  const RobotParameters& robot = scenario.robot;
  const SensorConfig& sensors = scenario.sensors;
  Random random(seed);
  SimulationSummary summary;
  for (const TractionMode& m : scenario.modes) {
    double mu = 0.0;
    for (const WheelGroundContact& c : m.wheels) mu = std::max(mu, c.friction * std::max(1.0, c.lateral_ratio));
    summary.max_friction_accel = std::max(summary.max_friction_accel, mu * 9.81);
  }

  CsvWriter out(
      output, {"t", "phi_dot_L", "phi_dot_R", "V", "omega", "ax", "ay", "X", "Y", "theta", "mode", "true_V", "true_vy",
               "true_omega", "true_X", "true_Y", "true_theta", "true_phi_dot_L", "true_phi_dot_R"});
  RobotState state;
  const double h = scenario.integration_step;
  const double period = 1.0 / sensors.rate;
  double next_sample = 0.0;
  double next_gps = 0.0;
  const long steps = static_cast<long>(std::ceil(scenario.duration / h));
  std::size_t segment = 0;
  std::vector<std::string> row(19);
  for (long k = 0; k <= steps; ++k) {
    const double t = k * h;
    while (segment + 1 < scenario.schedule.size() && t >= scenario.schedule[segment + 1].start) ++segment;
    const std::string& mode_name = scenario.schedule[segment].mode;
    const TractionMode* mode = nullptr;
    for (const TractionMode& m : scenario.modes) {
      if (m.name == mode_name) mode = &m;
    }
    if (summary.modes_driven.empty() || summary.modes_driven.back() != mode_name) {
      summary.modes_driven.push_back(mode_name);
    }
    double v = 0.0, omega = 0.0;
    scenario.maneuver.desired(t, &v, &omega);
    const double left = (v - omega * robot.track / 2.0) / robot.wheel_radius;
    const double right = (v + omega * robot.track / 2.0) / robot.wheel_radius;

    if (t + 1e-12 >= next_sample) {
      const ContactForces forces = dynamics.forces(state, *mode);
      summary.max_horizontal_accel = std::max(summary.max_horizontal_accel, std::hypot(forces.ax, forces.ay));
      const double true_left = (state.wheel_speed[kFrontLeft] + state.wheel_speed[kRearLeft]) / 2.0;
      const double true_right = (state.wheel_speed[kFrontRight] + state.wheel_speed[kRearRight]) / 2.0;
      const double heading = sdk::wrap_angle(state.psi);
      std::fill(row.begin(), row.end(), std::string());
      row[0] = number(t);
      row[1] = number(true_left + sensors.wheel_speed_std * random.gaussian());
      row[2] = number(true_right + sensors.wheel_speed_std * random.gaussian());
      const double noise_v = sensors.velocity_std * random.gaussian();
      if (random.uniform() >= sensors.velocity_dropout) row[3] = number(state.vx + noise_v);
      const double noise_w = sensors.yaw_rate_std * random.gaussian();
      const double noise_ax = sensors.accel_std * random.gaussian();
      const double noise_ay = sensors.accel_std * random.gaussian();
      if (random.uniform() >= sensors.imu_dropout) {
        row[4] = number(state.omega + sensors.yaw_rate_bias + noise_w);
        row[5] = number(forces.ax + noise_ax);
        row[6] = number(forces.ay + noise_ay);
      }
      if (sensors.gps_rate > 0.0 && t + 1e-12 >= next_gps) {
        const double nx = sensors.gps_std * random.gaussian(), ny = sensors.gps_std * random.gaussian();
        const double nh = sensors.heading_std * random.gaussian();
        if (random.uniform() >= sensors.gps_dropout) {
          row[7] = number(state.x + nx);
          row[8] = number(state.y + ny);
          row[9] = number(sdk::wrap_angle(heading + nh));
        }
        next_gps += 1.0 / sensors.gps_rate;
      }
      row[10] = mode_name;
      row[11] = number(state.vx);
      row[12] = number(state.vy);
      row[13] = number(state.omega);
      row[14] = number(state.x);
      row[15] = number(state.y);
      row[16] = number(heading);
      row[17] = number(true_left);
      row[18] = number(true_right);
      out.write_row(row);
      ++summary.rows;
      const double jitter = sensors.jitter > 0.0 ? sensors.jitter * (2.0 * random.uniform() - 1.0) : 0.0;
      next_sample = t + period * (1.0 + jitter);
    }
    dynamics.step(SkidSteerDynamics::side_commands(left, right), *mode, h, &state);
  }
  out.commit();
  return summary;
}

}  // namespace simulation
}  // namespace skidimm
