#include "skidimm/simulation/scenario.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <random>
#include <set>

#include "../yaml_fields.h"
#include "random.h"
#include "skidimm/errors.h"
#include "skidimm/io/csv.h"
#include "skidimm/printable.h"
#include "skidimm/sdk/angles.h"

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

// Any sign; NaN and infinity fail at load, naming the line, not mid-run.
double finite(const YamlFields& y, const YAML::Node& node, const std::string& field) {
  const double value = y.number(node, field);
  if (!std::isfinite(value)) y.fail(node, field, "must be a finite number");
  return value;
}

std::uint64_t seed_of(const YamlFields& y, const YAML::Node& node, const std::string& field) {
  const std::string text = y.string(node, field);
  const std::optional<std::uint64_t> seed = parse_seed(text);
  if (!seed) y.fail(node, field, "must be a whole number from 0 to 18446744073709551615, got '" + text + "'");
  return *seed;
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
  if (node["speed"]) m->speed = finite(y, node["speed"], "maneuver.speed");
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
    m->initial_curvature = finite(y, node["initial_curvature"], "maneuver.initial_curvature");
  if (node["curvature_rate"]) m->curvature_rate = finite(y, node["curvature_rate"], "maneuver.curvature_rate");
  if (node["yaw_rate_amplitude"]) {
    m->yaw_rate_amplitude = non_negative(y, node["yaw_rate_amplitude"], "maneuver.yaw_rate_amplitude");
  }
  if (node["period"]) m->period = positive(y, node["period"], "maneuver.period");
}

void parse_sensors(const YamlFields& y, const YAML::Node& node, SensorConfig* s) {
  y.check_keys(node,
               {"preset",
                "rate",
                "jitter",
                "wheel_speed_std",
                "speed",
                "velocity_std",
                "odometry_scale_error",
                "yaw_rate_std",
                "yaw_rate_bias",
                "yaw_rate_bias_std",
                "accel_std",
                "gps_rate",
                "gps_std",
                "gps_correlated_std",
                "gps_correlation_time",
                "heading",
                "heading_std",
                "gps_velocity_std",
                "course_min_speed",
                "velocity_dropout",
                "imu_dropout",
                "gps_dropout",
                "gps_outage_rate",
                "gps_outage_duration",
                "current_rate",
                "current_per_torque",
                "current_no_load",
                "current_std",
                "current_dropout"},
               "sensors");
  // A preset first; every other key overrides it.
  if (node["preset"]) {
    const std::string preset = y.string(node["preset"], "sensors.preset");
    if (preset == "husky") {
      *s = husky_sensors();
    } else if (preset == "ideal") {
      *s = SensorConfig();
    } else {
      y.fail(node["preset"], "sensors.preset", "expected ideal or husky");
    }
  }
  if (node["rate"]) s->rate = positive(y, node["rate"], "sensors.rate");
  if (node["jitter"]) {
    s->jitter = non_negative(y, node["jitter"], "sensors.jitter");
    if (s->jitter >= 1.0) y.fail(node["jitter"], "sensors.jitter", "must be below 1 (time must increase)");
  }
  // Noise, biases and gains (`in_readings`: what goes into a reading) as
  // large as 1e308 are finite, and their draws and products are not: the
  // log would hold `inf` cells no reader takes. Rates and thresholds are not
  // in a reading and have no such bound.
  constexpr double kLargestInReading = 1e9;
  auto set = [&](const char* key, double* out, bool allow_negative, bool in_readings = true) {
    if (!node[key]) return;
    const std::string field = std::string("sensors.") + key;
    *out = allow_negative ? finite(y, node[key], field) : non_negative(y, node[key], field);
    if (in_readings && std::abs(*out) > kLargestInReading) {
      y.fail(node[key], field,
             "expected at most 1e9 in size (its draws would overflow to infinity), got " + CsvWriter::format(*out));
    }
  };
  set("wheel_speed_std", &s->wheel_speed_std, false);
  set("velocity_std", &s->velocity_std, false);
  set("odometry_scale_error", &s->odometry_scale_error, true);
  set("yaw_rate_std", &s->yaw_rate_std, false);
  set("yaw_rate_bias", &s->yaw_rate_bias, true);
  set("yaw_rate_bias_std", &s->yaw_rate_bias_std, false);
  set("accel_std", &s->accel_std, false);
  set("gps_rate", &s->gps_rate, false, false);
  set("gps_std", &s->gps_std, false);
  set("gps_correlated_std", &s->gps_correlated_std, false);
  set("heading_std", &s->heading_std, false);
  set("gps_velocity_std", &s->gps_velocity_std, false);
  set("course_min_speed", &s->course_min_speed, false, false);
  set("gps_outage_rate", &s->gps_outage_rate, false, false);
  set("current_rate", &s->current_rate, false, false);
  set("current_per_torque", &s->current_per_torque, false);
  set("current_no_load", &s->current_no_load, false);
  set("current_std", &s->current_std, false);
  if (node["gps_correlation_time"]) {
    s->gps_correlation_time = positive(y, node["gps_correlation_time"], "sensors.gps_correlation_time");
  }
  if (node["gps_outage_duration"]) {
    s->gps_outage_duration = positive(y, node["gps_outage_duration"], "sensors.gps_outage_duration");
  }
  if (node["speed"]) {
    const std::string speed = y.string(node["speed"], "sensors.speed");
    if (speed != "body" && speed != "odometry") y.fail(node["speed"], "sensors.speed", "expected body or odometry");
    s->speed = speed == "body" ? SensorConfig::Speed::kBody : SensorConfig::Speed::kOdometry;
  }
  if (node["heading"]) {
    const std::string heading = y.string(node["heading"], "sensors.heading");
    if (heading != "direct" && heading != "gps_course") {
      y.fail(node["heading"], "sensors.heading", "expected direct or gps_course");
    }
    s->heading = heading == "direct" ? SensorConfig::Heading::kDirect : SensorConfig::Heading::kGpsCourse;
  }
  auto set_probability = [&](const char* key, double* out) {
    if (node[key]) *out = probability(y, node[key], std::string("sensors.") + key);
  };
  set_probability("velocity_dropout", &s->velocity_dropout);
  set_probability("imu_dropout", &s->imu_dropout);
  set_probability("gps_dropout", &s->gps_dropout);
  set_probability("current_dropout", &s->current_dropout);
}

std::string approx(double v) { return CsvWriter::format(std::round(v * 1e6) / 1e6); }

// A rate in a message: six significant digits (approx() rounds to 1e-6,
// which wrote a rate of 1e-9 Hz as 0).
std::string rate_text(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.6g", v);
  return text;
}

struct Problem {
  std::string field;
  std::string message;
};

std::optional<Problem> simulation_problem(const Scenario& s) {
  const double h = s.integration_step;
  const SkidSteerDynamics dynamics(s.robot);
  for (const TractionMode& mode : s.modes) {
    const FastestResponse fastest = dynamics.fastest_response(mode);
    if (!(h * fastest.rate <= kMaxStepTimesRate)) {
      // The wheel loop and the yaw response are set by robot parameters (an
      // implausible one is the usual cause); the body's sliding by the terrain.
      const std::string what = fastest.what;
      const std::string knob = what == "wheel speed loop" ? "robot.motor_time_constant"
                               : what == "yaw"            ? "robot.yaw_inertia"
                                                          : "";
      char text[512];
      std::snprintf(text, sizeof(text),
                    "integration_step %.6g s does not resolve the %s response on mode '%s' (time constant %.3g s): "
                    "RK4 diverges beyond 2.785 time constants a step, and the step must be <= %.2g of them, %.3g s. "
                    "Lower integration_step%s%s%s%s",
                    h, fastest.what, printable(mode.name).c_str(), 1.0 / fastest.rate, kMaxStepTimesRate,
                    kMaxStepTimesRate / fastest.rate, knob.empty() ? "" : " or raise ", knob.c_str(),
                    knob.empty() ? "" : " to a physical value",
                    // The yaw response is the inertia against the wheels' moment arms: the geometry may be what is off.
                    what == "yaw" ? " (or check robot.track and robot.wheelbase, the wheels' moment arms)" : "");
      // At the default step the robot is what changed; a chosen step is named.
      const bool default_step = h == Scenario().integration_step;
      return Problem{knob.empty() || !default_step ? "integration_step" : knob, text};
    }
  }
  const double steps = std::ceil(s.duration / h);
  if (!(steps <= static_cast<double>(kMaxIntegrationSteps))) {
    char text[256];
    std::snprintf(text, sizeof(text),
                  "%.6g s at integration_step %.6g s is %.4g integration steps, more than the limit of %ld: "
                  "shorten the run or split it into several scenarios",
                  s.duration, h, steps, kMaxIntegrationSteps);
    return Problem{"duration", text};
  }
  if (s.sensors.rate * h > 1.0 + 1e-9) {
    return Problem{"sensors.rate",
                   "a row is written at most once per integration step, so the rate must be <= 1 / "
                   "integration_step = " +
                       rate_text(1.0 / h) + " Hz, got " + rate_text(s.sensors.rate) + " Hz"};
  }
  if (s.sensors.gps_rate > s.sensors.rate * (1.0 + 1e-9)) {
    return Problem{"sensors.gps_rate", "a GPS fix is written on a sensor row, so it must be <= sensors.rate = " +
                                           rate_text(s.sensors.rate) + " Hz, got " + rate_text(s.sensors.gps_rate) +
                                           " Hz"};
  }
  if (s.sensors.current_rate > s.sensors.rate * (1.0 + 1e-9)) {
    return Problem{"sensors.current_rate",
                   "a current sample is written on a sensor row, so it must be <= sensors.rate = " +
                       rate_text(s.sensors.rate) + " Hz, got " + rate_text(s.sensors.current_rate) + " Hz"};
  }
  return std::nullopt;
}

// The node a dotted field names, or its deepest ancestor present (for a line).
YAML::Node node_of(const YAML::Node& root, const std::string& field) {
  YAML::Node node = root;
  std::size_t begin = 0;
  while (begin <= field.size()) {
    const std::size_t end = std::min(field.find('.', begin), field.size());
    const YAML::Node child = node[field.substr(begin, end - begin)];
    if (!child) break;
    node = child;
    begin = end + 1;
  }
  return node;
}

}  // namespace

void check_simulable(const Scenario& scenario) {
  if (const std::optional<Problem> problem = simulation_problem(scenario)) {
    throw ConfigError(scenario.file.string(), 0, problem->field, problem->message);
  }
}

SensorConfig husky_sensors() {
  // Sources and reasoning: docs/simulation.md, "Sensors".
  SensorConfig s;
  s.rate = 50.0;  // wheel and IMU rows (the Husky's joint states and a 50 Hz IMU stream)
  s.jitter = 0.3;
  s.wheel_speed_std = 0.05;
  s.speed = SensorConfig::Speed::kOdometry;  // the Husky's velocity is wheel odometry
  s.odometry_scale_error = 0.02;             // rolling radius 2% off the nominal one (assumed)
  s.yaw_rate_std = 0.02;
  s.yaw_rate_bias_std = 0.005;  // rad/s (0.3 deg/s) turn-on bias of a MEMS gyro (assumed)
  s.accel_std = 0.05;
  s.gps_rate = 10.0;              // RTK fixes at 10 Hz
  s.gps_std = 0.006;              // m per axis, white
  s.gps_correlated_std = 0.006;   // m per axis, multipath: 0.0085 m in all, 1 cm CEP (RTK fix)
  s.gps_correlation_time = 60.0;  // s
  s.heading = SensorConfig::Heading::kGpsCourse;
  s.gps_velocity_std = 0.035;  // m/s per axis: 0.05 m/s velocity accuracy
  s.course_min_speed = 0.1;    // m/s: receivers give no course below it
  s.velocity_dropout = 0.005;
  s.imu_dropout = 0.005;
  s.gps_dropout = 0.02;            // single lost fixes
  s.gps_outage_rate = 1.0 / 60.0;  // an outage a minute on average ...
  s.gps_outage_duration = 2.0;     // ... of 2 s on average (lost corrections, shading)
  s.current_rate = 6.5;            // the rate of BorealTC's Husky A200 current logs
  s.current_per_torque = 0.4;      // A / (N m) (assumed; real Husky currents, docs/simulation.md)
  s.current_no_load = 1.5;         // A (assumed)
  s.current_std = 0.3;             // A (assumed)
  s.current_dropout = 0.005;
  return s;
}

std::optional<std::uint64_t> parse_seed(std::string_view text) {
  std::uint64_t value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size() || text.empty()) return std::nullopt;
  return value;
}

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
  if (root["seed"]) s.seed = seed_of(y, root["seed"], "seed");
  if (root["integration_step"]) {
    s.integration_step = positive(y, root["integration_step"], "integration_step");
    if (s.integration_step > 0.005) y.fail(root["integration_step"], "integration_step", "must be <= 0.005 s");
  }
  if (root["robot"]) parse_robot(y, root["robot"], &s.robot);

  const YAML::Node modes = y.required(root, "modes", "");
  if (!modes.IsMap() || modes.size() == 0)
    y.fail(modes, "modes", "expected a mapping from mode name to {terrain, tarp}");
  for (const auto& entry : modes) {
    const std::string name = y.key(entry.first, "modes");
    const std::string field = "modes." + name;
    // The name is each row's truth label: an empty one reads as unlabelled.
    if (name.empty()) y.fail(entry.first, "modes", "a mode's name cannot be empty: it is the log's truth label");
    if (printable(name) != name || name.find_first_of("\t\n\r") != std::string::npos) {
      y.fail(entry.first, "modes", "'" + printable(name) + "' has control characters or invalid UTF-8");
    }
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
  if (const std::optional<Problem> problem = simulation_problem(s)) {
    y.fail(node_of(root, problem->field), problem->field, problem->message);
  }
  return s;
}

namespace {

// The realistic sensors' error states over a run, drawn from their own
// random stream so that the ideal sensors' draws (and logs) are unchanged.
class RealisticErrors {
 public:
  RealisticErrors(const SensorConfig& sensors, std::uint64_t seed)
      : sensors_(sensors), random_(seed ^ 0x9E3779B97F4A7C15ULL) {
    if (sensors_.yaw_rate_bias_std > 0.0) yaw_rate_bias_ = sensors_.yaw_rate_bias_std * random_.gaussian();
    if (sensors_.gps_correlated_std > 0.0) {
      gps_error_[0] = sensors_.gps_correlated_std * random_.gaussian();
      gps_error_[1] = sensors_.gps_correlated_std * random_.gaussian();
    }
  }

  double yaw_rate_bias() const { return sensors_.yaw_rate_bias + yaw_rate_bias_; }

  // Advances the GPS error states to a fix due at time t; false during an outage.
  bool gps_epoch(double t) {
    const double elapsed = last_epoch_ < 0.0 ? 0.0 : t - last_epoch_;
    last_epoch_ = t;
    if (sensors_.gps_correlated_std > 0.0 && elapsed > 0.0) {
      const double a = std::exp(-elapsed / sensors_.gps_correlation_time);
      const double spread = sensors_.gps_correlated_std * std::sqrt(1.0 - a * a);
      gps_error_[0] = a * gps_error_[0] + spread * random_.gaussian();
      gps_error_[1] = a * gps_error_[1] + spread * random_.gaussian();
    }
    if (sensors_.gps_outage_rate > 0.0) {
      if (t < outage_end_) return false;
      if (elapsed > 0.0 && random_.uniform() < 1.0 - std::exp(-sensors_.gps_outage_rate * elapsed)) {
        outage_end_ = t - sensors_.gps_outage_duration * std::log(random_.uniform());
        return false;
      }
    }
    return true;
  }
  double gps_error(int axis) const { return gps_error_[axis]; }

  // Course over ground of the world velocity (vx, vy) measured with noise;
  // NaN below the receiver's minimum speed.
  double course(double world_vx, double world_vy) {
    const double vx = world_vx + sensors_.gps_velocity_std * random_.gaussian();
    const double vy = world_vy + sensors_.gps_velocity_std * random_.gaussian();
    if (std::hypot(vx, vy) < sensors_.course_min_speed) return std::numeric_limits<double>::quiet_NaN();
    return std::atan2(vy, vx);
  }

 private:
  const SensorConfig& sensors_;
  Random random_;
  double yaw_rate_bias_ = 0.0;
  double gps_error_[2] = {0.0, 0.0};
  double last_epoch_ = -1.0;
  double outage_end_ = -1.0;
};

bool finite(const RobotState& s) {
  bool ok = std::isfinite(s.x) && std::isfinite(s.y) && std::isfinite(s.psi) && std::isfinite(s.vx) &&
            std::isfinite(s.vy) && std::isfinite(s.omega);
  for (const double w : s.wheel_speed) ok = ok && std::isfinite(w);
  return ok;
}

}  // namespace

SimulationSummary simulate(const Scenario& scenario, std::uint64_t seed, const fs::path& output) {
  check_simulable(scenario);
  const SkidSteerDynamics dynamics(scenario.robot);
  const RobotParameters& robot = scenario.robot;
  const SensorConfig& sensors = scenario.sensors;
  Random random(seed);
  RealisticErrors realistic(sensors, seed);
  SimulationSummary summary;
  for (const TractionMode& m : scenario.modes) {
    double mu = 0.0;
    for (const WheelGroundContact& c : m.wheels) mu = std::max(mu, c.friction * std::max(1.0, c.lateral_ratio));
    summary.max_friction_accel = std::max(summary.max_friction_accel, mu * 9.81);
  }

  std::vector<std::string> columns{
      "t",          "phi_dot_L",      "phi_dot_R",     "V",      "omega",   "ax",         "ay",     "X",
      "Y",          "theta",          "mode",          "true_V", "true_vy", "true_omega", "true_X", "true_Y",
      "true_theta", "true_phi_dot_L", "true_phi_dot_R"};
  const bool measures_current = sensors.current_rate > 0.0;
  if (measures_current) columns.insert(columns.end(), {"i_L", "i_R"});
  CsvWriter out(output, columns);
  // The currents' own stream: the other columns stay as they were without them.
  Random current_random(seed ^ 0xC2B2AE3D27D4EB4FULL);
  double next_current = 0.0;
  RobotState state;
  const double h = scenario.integration_step;
  const double period = 1.0 / sensors.rate;
  double next_sample = 0.0;
  double next_gps = 0.0;
  const long steps = static_cast<long>(std::ceil(scenario.duration / h));
  std::size_t segment = 0;
  std::vector<std::string> row(columns.size());
  long commanded_rows = 0, behind_rows = 0;
  double worst_achieved = HUGE_VAL, fastest_along_command = -HUGE_VAL;
  for (long k = 0; k <= steps; ++k) {
    const double t = k * h;
    while (segment + 1 < scenario.schedule.size() && t >= scenario.schedule[segment + 1].start) ++segment;
    const std::string& mode_name = scenario.schedule[segment].mode;
    const TractionMode* mode = nullptr;
    for (const TractionMode& m : scenario.modes) {
      if (m.name == mode_name) mode = &m;
    }
    double v = 0.0, omega = 0.0;
    scenario.maneuver.desired(t, &v, &omega);
    const double left = (v - omega * robot.track / 2.0) / robot.wheel_radius;
    const double right = (v + omega * robot.track / 2.0) / robot.wheel_radius;

    if (t + 1e-12 >= next_sample) {
      // The modes of the rows written: a switch at the very end is not in the log.
      if (summary.modes_driven.empty() || summary.modes_driven.back() != mode_name) {
        summary.modes_driven.push_back(mode_name);
      }
      if (std::abs(v) >= 0.1) {
        const double achieved = state.vx / v;  // negative when the body goes the other way
        if (!summary.reached_half_command) {
          summary.reached_half_command = achieved >= 0.5;
          // Until then: the largest command and the body's fastest in its direction.
          if (std::abs(v) > std::abs(summary.commanded_speed)) summary.commanded_speed = v;
          if (achieved * std::abs(v) > fastest_along_command) {
            fastest_along_command = achieved * std::abs(v);
            summary.body_speed = state.vx;
          }
          worst_achieved = HUGE_VAL;
        }
        if (summary.reached_half_command) {
          ++commanded_rows;
          if (achieved < 0.5) ++behind_rows;
          if (achieved < worst_achieved) {
            worst_achieved = achieved;
            summary.commanded_speed = v;
            summary.body_speed = state.vx;
          }
        }
      }
      const ContactForces forces = dynamics.forces(state, *mode);
      summary.max_horizontal_accel = std::max(summary.max_horizontal_accel, std::hypot(forces.ax, forces.ay));
      const double true_left = (state.wheel_speed[kFrontLeft] + state.wheel_speed[kRearLeft]) / 2.0;
      const double true_right = (state.wheel_speed[kFrontRight] + state.wheel_speed[kRearRight]) / 2.0;
      const double heading = sdk::wrap_angle(state.psi);
      std::fill(row.begin(), row.end(), std::string());
      row[0] = approx(t);
      const double measured_left = true_left + sensors.wheel_speed_std * random.gaussian();
      const double measured_right = true_right + sensors.wheel_speed_std * random.gaussian();
      row[1] = approx(measured_left);
      row[2] = approx(measured_right);
      const double noise_v = sensors.velocity_std * random.gaussian();
      if (random.uniform() >= sensors.velocity_dropout) {
        const double speed =
            sensors.speed == SensorConfig::Speed::kBody
                ? state.vx + noise_v
                : (1.0 + sensors.odometry_scale_error) * robot.wheel_radius * (measured_left + measured_right) / 2.0;
        row[3] = approx(speed);
      }
      const double noise_w = sensors.yaw_rate_std * random.gaussian();
      const double noise_ax = sensors.accel_std * random.gaussian();
      const double noise_ay = sensors.accel_std * random.gaussian();
      if (random.uniform() >= sensors.imu_dropout) {
        row[4] = approx(state.omega + realistic.yaw_rate_bias() + noise_w);
        row[5] = approx(forces.ax + noise_ax);
        row[6] = approx(forces.ay + noise_ay);
      }
      if (sensors.gps_rate > 0.0 && t + 1e-12 >= next_gps) {
        const double nx = sensors.gps_std * random.gaussian(), ny = sensors.gps_std * random.gaussian();
        const double nh = sensors.heading_std * random.gaussian();
        const bool received = random.uniform() >= sensors.gps_dropout;
        if (realistic.gps_epoch(t) && received) {
          row[7] = approx(state.x + nx + realistic.gps_error(0));
          row[8] = approx(state.y + ny + realistic.gps_error(1));
          if (sensors.heading == SensorConfig::Heading::kDirect) {
            row[9] = approx(sdk::wrap_angle(heading + nh));
          } else {
            const double c = std::cos(state.psi), s = std::sin(state.psi);
            const double course = realistic.course(state.vx * c - state.vy * s, state.vx * s + state.vy * c);
            if (std::isfinite(course)) row[9] = approx(sdk::wrap_angle(course));
          }
        }
        next_gps += 1.0 / sensors.gps_rate;
      }
      row[10] = mode_name;
      row[11] = approx(state.vx);
      row[12] = approx(state.vy);
      row[13] = approx(state.omega);
      row[14] = approx(state.x);
      row[15] = approx(state.y);
      row[16] = approx(heading);
      row[17] = approx(true_left);
      row[18] = approx(true_right);
      if (measures_current && t + 1e-12 >= next_current) {
        // The torque each side's motor holds its wheels' speed against.
        const double torque_left = robot.wheel_radius * (forces.traction[kFrontLeft] + forces.traction[kRearLeft]);
        const double torque_right = robot.wheel_radius * (forces.traction[kFrontRight] + forces.traction[kRearRight]);
        const double noise_left = sensors.current_std * current_random.gaussian();
        const double noise_right = sensors.current_std * current_random.gaussian();
        if (current_random.uniform() >= sensors.current_dropout) {
          // A magnitude, as the drivers report it: noise cannot make it negative.
          row[19] = approx(
              std::abs(sensors.current_no_load + sensors.current_per_torque * std::abs(torque_left) + noise_left));
          row[20] = approx(
              std::abs(sensors.current_no_load + sensors.current_per_torque * std::abs(torque_right) + noise_right));
        }
        next_current += 1.0 / sensors.current_rate;
      }
      out.write_row(row);
      ++summary.rows;
      const double jitter = sensors.jitter > 0.0 ? sensors.jitter * (2.0 * random.uniform() - 1.0) : 0.0;
      next_sample = t + period * (1.0 + jitter);
    }
    dynamics.step(SkidSteerDynamics::side_commands(left, right), *mode, h, &state);
    if (!finite(state)) {
      // The checks above bound the step by the fastest linear response; a
      // state that still blows up must stop the run, not fill the log with NaN.
      char time[32];
      std::snprintf(time, sizeof(time), "%.9g", t + h);
      throw Error(scenario.file.string() + ": the simulated state is not finite at t = " + time + " s (mode '" +
                  mode_name + "'): the robot or maneuver is outside what the simulator integrates; "
                  "lower integration_step or check robot and maneuver");
    }
  }
  out.commit();
  if (commanded_rows > 0) {
    summary.share_behind_command = static_cast<double>(behind_rows) / static_cast<double>(commanded_rows);
  } else if (!summary.reached_half_command && summary.commanded_speed != 0.0) {
    summary.share_behind_command = 1.0;
  }
  return summary;
}

}  // namespace simulation
}  // namespace skidimm
