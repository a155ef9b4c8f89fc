#include "skidimm/simulation/scenario.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <map>

#include "core/temp_files.h"
#include "skidimm/engine/imm.h"
#include "skidimm/errors.h"
#include "skidimm/io/csv.h"
#include "skidimm/sdk/angles.h"

namespace skidimm {
namespace simulation {
namespace {

using skidimm_test::read_file;
using skidimm_test::replace_first;
using skidimm_test::test_directory;
using skidimm_test::write_file;
using ::testing::HasSubstr;

const std::string kSource = SKIDIMM_SOURCE_DIR;

const std::string kScenario = R"(name: test
duration: 4
modes:
  grass: {terrain: grass}
  slip: {terrain: asphalt, tarp: [FL, RL]}
schedule:
  - {at: 0, mode: grass}
  - {at: 2, mode: slip}
maneuver: {type: sinusoidal, speed: 0.6}
sensors: {rate: 50, jitter: 0.2, gps_rate: 10}
)";

TEST(Scenario, IsDeterministicForASeedAndVariesAcrossSeeds) {
  const auto dir = test_directory();
  const Scenario s = load_scenario(write_file(dir / "s.yaml", kScenario));
  simulate(s, 5, dir / "a.csv");
  simulate(s, 5, dir / "b.csv");
  simulate(s, 6, dir / "c.csv");
  EXPECT_EQ(read_file(dir / "a.csv"), read_file(dir / "b.csv"));
  EXPECT_NE(read_file(dir / "a.csv"), read_file(dir / "c.csv"));
}

TEST(Scenario, WritesTheScheduleSensorsAndTruth) {
  const auto dir = test_directory();
  const Scenario s = load_scenario(write_file(dir / "s.yaml", kScenario));
  const SimulationSummary summary = simulate(s, 1, dir / "log.csv");
  EXPECT_EQ(summary.modes_driven, (std::vector<std::string>{"grass", "slip"}));
  CsvReader reader(dir / "log.csv");
  ASSERT_EQ(reader.header().size(), 19u);
  std::vector<std::string> f;
  long rows = 0, gps = 0;
  double last_t = -1.0;
  while (reader.next(&f)) {
    ++rows;
    const double t = std::stod(f[0]);
    EXPECT_GT(t, last_t);
    last_t = t;
    EXPECT_EQ(f[10], t < 2.0 ? "grass" : "slip") << "t = " << t;
    gps += !f[7].empty();
    EXPECT_FALSE(f[1].empty() || f[3].empty() || f[4].empty());
  }
  EXPECT_EQ(summary.rows, rows);
  EXPECT_NEAR(rows, 4.0 * 50.0, 10.0);  // 50 Hz with jitter
  EXPECT_NEAR(gps, 4.0 * 10.0, 2.0);    // 10 Hz GPS fixes
}

TEST(Scenario, DropoutsLeaveCellsEmpty) {
  const auto dir = test_directory();
  const Scenario s = load_scenario(
      write_file(dir / "s.yaml", replace_first(kScenario, "gps_rate: 10}", "gps_rate: 10, velocity_dropout: 1.0}")));
  simulate(s, 1, dir / "log.csv");
  CsvReader reader(dir / "log.csv");
  std::vector<std::string> f;
  while (reader.next(&f)) ASSERT_TRUE(f[3].empty());
}

// One log's columns by name, as numbers (NaN for an empty cell).
std::map<std::string, std::vector<double>> read_columns(const std::filesystem::path& file) {
  CsvReader reader(file);
  std::map<std::string, std::vector<double>> columns;
  std::vector<std::string> f;
  while (reader.next(&f)) {
    for (std::size_t i = 0; i < f.size(); ++i) {
      const std::string& name = reader.header()[i];
      if (name == "mode") continue;
      columns[name].push_back(f[i].empty() ? std::nan("") : std::stod(f[i]));
    }
  }
  return columns;
}

double mean(const std::vector<double>& v) {
  double sum = 0.0;
  for (double x : v) sum += x;
  return sum / static_cast<double>(v.size());
}

double standard_deviation(const std::vector<double>& v) {
  const double m = mean(v);
  double sum = 0.0;
  for (double x : v) sum += (x - m) * (x - m);
  return std::sqrt(sum / static_cast<double>(v.size()));
}

const std::string kHuskyScenario = R"(name: husky
duration: 240
modes: {front: {terrain: asphalt, tarp: [FL, FR]}}
mode: front
maneuver: {type: skidpad, speed: 0.8, radius: 1.5}
sensors: {preset: husky}
)";

// The ideal sensors are what every earlier result used: `preset: ideal` is
// the default, byte for byte.
TEST(Scenario, IdealPresetIsTheDefault) {
  const auto dir = test_directory();
  simulate(load_scenario(write_file(dir / "a.yaml", kScenario)), 3, dir / "a.csv");
  simulate(load_scenario(write_file(dir / "b.yaml", replace_first(kScenario, "sensors: {", "sensors: {preset: ideal, "))), 3,
           dir / "b.csv");
  EXPECT_EQ(read_file(dir / "a.csv"), read_file(dir / "b.csv"));
}

// The Husky preset: speed from wheel odometry, heading from the GPS course
// over ground, a gyro turn-on bias, RTK fixes with correlated errors,
// dropouts and outages (docs/simulation.md).
TEST(Scenario, HuskyPresetSensorsAreWhatARobotHas) {
  const auto dir = test_directory();
  const Scenario s = load_scenario(write_file(dir / "s.yaml", kHuskyScenario));
  EXPECT_EQ(s.sensors.speed, SensorConfig::Speed::kOdometry);
  EXPECT_EQ(s.sensors.heading, SensorConfig::Heading::kGpsCourse);
  simulate(s, 11, dir / "log.csv");
  auto c = read_columns(dir / "log.csv");
  const std::size_t rows = c["t"].size();

  // V is odometry from the logged wheel speeds, blind to slip.
  std::vector<double> odometry_error;
  for (std::size_t k = 0; k < rows; ++k) {
    if (std::isnan(c["V"][k])) continue;
    const double odometry = 1.02 * 0.165 * (c["phi_dot_L"][k] + c["phi_dot_R"][k]) / 2.0;
    EXPECT_NEAR(c["V"][k], odometry, 2e-6) << "row " << k;
    odometry_error.push_back(c["V"][k] - c["true_V"][k]);
  }
  EXPECT_NEAR(static_cast<double>(odometry_error.size()) / rows, 0.995, 0.01);

  // theta is the course over ground: here the front slides out, so the body
  // moves at a sideslip to its heading that the course includes.
  std::vector<double> course_minus_heading, course_minus_course;
  long fixes = 0, gaps = 0;
  double last_fix = 0.0;
  for (std::size_t k = 0; k < rows; ++k) {
    if (std::isnan(c["X"][k])) continue;
    ++fixes;
    gaps += c["t"][k] - last_fix > 0.5;
    last_fix = c["t"][k];
    if (std::isnan(c["theta"][k]) || c["t"][k] < 5.0) continue;
    const double sideslip = std::atan2(c["true_vy"][k], c["true_V"][k]);
    course_minus_heading.push_back(sdk::wrap_angle(c["theta"][k] - c["true_theta"][k]));
    course_minus_course.push_back(sdk::wrap_angle(c["theta"][k] - c["true_theta"][k] - sideslip));
  }
  EXPECT_GT(mean(course_minus_heading), 0.1);  // front tarps: the body slides about 7 deg to the left
  EXPECT_NEAR(mean(course_minus_course), 0.0, 0.005);
  EXPECT_NEAR(standard_deviation(course_minus_course), 0.035 / 0.8, 0.01);
  // 10 Hz RTK fixes, 2% lost singly and an outage a minute.
  EXPECT_NEAR(static_cast<double>(fixes), 240.0 * 10.0 * 0.95, 240.0 * 10.0 * 0.04);
  EXPECT_GE(gaps, 1);

  // One gyro bias for the run, another for another run.
  std::vector<double> gyro_error;
  for (std::size_t k = 0; k < rows; ++k) {
    if (!std::isnan(c["omega"][k])) gyro_error.push_back(c["omega"][k] - c["true_omega"][k]);
  }
  simulate(s, 12, dir / "other.csv");
  auto other = read_columns(dir / "other.csv");
  std::vector<double> other_error;
  for (std::size_t k = 0; k < other["t"].size(); ++k) {
    if (!std::isnan(other["omega"][k])) other_error.push_back(other["omega"][k] - other["true_omega"][k]);
  }
  EXPECT_NEAR(standard_deviation(gyro_error), 0.02, 0.002);
  EXPECT_GT(std::abs(mean(gyro_error) - mean(other_error)), 1e-3);
}

// Motor currents are what the ground resists with. On a 3 m skidpad, where
// four tarps turn like none (docs/simulation.md), the motors on four tarps
// carry far less: current_per_torque |T| against the hand-computed
// rolling-resistance floor on a straight run. Adding the sensor leaves every
// other column as it was (its noise has its own stream).
TEST(Scenario, MotorCurrentsSeeWhatTheGroundResistsWith) {
  const auto dir = test_directory();
  const std::string skidpad = R"(name: current
duration: 20
modes: {MODE: {terrain: asphalt TARP}}
mode: MODE
maneuver: {type: MANEUVER, speed: 0.8, radius: 3}
sensors: {preset: husky, current_dropout: 0}
)";
  auto mean_current_after = [&](const std::string& mode, const std::string& tarp, const std::string& maneuver,
                                double start, double* rate) {
    std::string text = replace_first(replace_first(replace_first(skidpad, "MODE", mode), "MODE", mode), "TARP", tarp);
    text = replace_first(text, "MANEUVER", maneuver);
    simulate(load_scenario(write_file(dir / (mode + ".yaml"), text)), 4, dir / (mode + ".csv"));
    auto c = read_columns(dir / (mode + ".csv"));
    std::vector<double> current;
    long samples = 0;
    for (std::size_t k = 0; k < c["t"].size(); ++k) {
      EXPECT_EQ(std::isnan(c["i_L"][k]), std::isnan(c["i_R"][k]));
      if (std::isnan(c["i_L"][k])) continue;
      ++samples;
      EXPECT_GE(c["i_L"][k], 0.0);  // a magnitude
      if (c["t"][k] >= start) current.push_back((c["i_L"][k] + c["i_R"][k]) / 2.0);
    }
    if (rate != nullptr) *rate = samples / 20.0;
    return mean(current);
  };
  double rate = 0.0;
  const double no_tarp = mean_current_after("none", "", "skidpad", 10.0, &rate);
  const double four_tarps = mean_current_after("four", ", tarp: [FL, FR, RL, RR]", "skidpad", 10.0, nullptr);
  EXPECT_NEAR(rate, 6.5, 0.1);
  EXPECT_GT(no_tarp, 5.0);
  EXPECT_LT(four_tarps, 0.6 * no_tarp);
  // Straight at a steady 0.8 m/s the motors only roll the robot: rolling
  // resistance c_rr m g / 2 per side at radius r, 0.015 x 50 x 9.81 / 2 x
  // 0.165 = 0.607 N m, so 1.5 A + 0.4 A/(N m) x 0.607 N m = 1.74 A.
  EXPECT_NEAR(mean_current_after("straight", "", "straight", 5.0, nullptr), 1.743, 0.05);

  // Without the sensor, the same log less the two columns.
  const std::string with = read_file(dir / "none.csv");
  std::string text = replace_first(replace_first(replace_first(skidpad, "MODE", "none"), "MODE", "none"), "TARP", "");
  text = replace_first(replace_first(text, "MANEUVER", "skidpad"), "current_dropout: 0", "current_rate: 0");
  simulate(load_scenario(write_file(dir / "without.yaml", text)), 4, dir / "without.csv");
  CsvReader a(dir / "none.csv"), b(dir / "without.csv");
  ASSERT_EQ(a.header().size(), 21u);
  ASSERT_EQ(b.header().size(), 19u);
  std::vector<std::string> fa, fb;
  while (a.next(&fa)) {
    ASSERT_TRUE(b.next(&fb));
    fa.resize(19);
    ASSERT_EQ(fa, fb);
  }
  EXPECT_FALSE(b.next(&fb));
}

// Below 0.1 m/s a receiver gives no course: standing, only when the
// velocity noise (0.035 m/s per axis) happens to exceed it.
TEST(Scenario, GpsCourseIsEmptyWhenStanding) {
  const auto dir = test_directory();
  const Scenario s = load_scenario(write_file(
      dir / "s.yaml", replace_first(replace_first(kHuskyScenario, "duration: 240", "duration: 60"), "speed: 0.8", "speed: 0")));
  simulate(s, 1, dir / "log.csv");
  auto c = read_columns(dir / "log.csv");
  long fixes = 0, courses = 0;
  for (std::size_t k = 0; k < c["t"].size(); ++k) {
    fixes += !std::isnan(c["X"][k]);
    courses += !std::isnan(c["theta"][k]);
  }
  EXPECT_GT(fixes, 500);
  EXPECT_LT(courses, 0.05 * fixes);  // exp(-0.1^2 / (2 0.035^2)) = 1.7% expected
}

TEST(Scenario, ErrorsNameFileLineAndField) {
  const auto dir = test_directory();
  auto error = [&](const std::string& yaml) {
    try {
      load_scenario(write_file(dir / "bad.yaml", yaml));
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_THAT(
      error(replace_first(kScenario, "terrain: grass", "terrain: mud")),
      HasSubstr("bad.yaml:4: modes.grass: unknown terrain 'mud' (known: asphalt, crushed_concrete, grass, ice)"));
  EXPECT_THAT(error(replace_first(kScenario, "{at: 0, mode: grass}", "{at: 1, mode: grass}")),
              HasSubstr("schedule[0].at: the first entry must start at 0"));
  EXPECT_THAT(error(replace_first(kScenario, "{at: 2, mode: slip}", "{at: 2, mode: ice}")),
              HasSubstr("schedule[1].mode: no mode 'ice' under modes"));
  EXPECT_THAT(error(replace_first(kScenario, "type: sinusoidal", "type: zigzag")),
              HasSubstr("maneuver.type: expected straight, skidpad, clothoid, sinusoidal or spiral"));
  EXPECT_THAT(error(replace_first(kScenario, "jitter: 0.2", "jitter: 1.5")), HasSubstr("sensors.jitter: must be below 1"));
  // NaN failed mid-run, "the simulated state is not finite", without a line.
  EXPECT_THAT(error(replace_first(kScenario, "speed: 0.6", "speed: .nan")),
              HasSubstr("maneuver.speed: must be a finite number"));
  EXPECT_THAT(error(replace_first(kScenario, "jitter: 0.2", "jitter: 0.2, yaw_rate_bias: .nan")),
              HasSubstr("sensors.yaw_rate_bias: must be a finite number"));
  // Finite, but its draws are not: the log would hold `inf` cells.
  EXPECT_THAT(error(replace_first(kScenario, "jitter: 0.2", "jitter: 0.2, yaw_rate_std: 1e308")),
              HasSubstr("sensors.yaw_rate_std: expected at most 1e9 in size (its draws would overflow to infinity), "
                        "got 1e+308"));
  EXPECT_THAT(error(replace_first(kScenario, "duration: 4", "duration: -4")),
              HasSubstr("duration: must be a finite number > 0"));
  EXPECT_THAT(error(replace_first(kScenario, "sensors: {", "sensors: {preset: robot, ")),
              HasSubstr("sensors.preset: expected ideal or husky"));
  EXPECT_THAT(error(replace_first(kScenario, "sensors: {", "sensors: {heading: compass, ")),
              HasSubstr("sensors.heading: expected direct or gps_course"));
  EXPECT_THAT(error(replace_first(kScenario, "sensors: {", "sensors: {gps_correlation_time: 0, ")),
              HasSubstr("sensors.gps_correlation_time: must be a finite number > 0"));
  // A mode's name is each row's truth label: "" wrote blank cells, read back as unlabelled.
  EXPECT_THAT(error(replace_first(replace_first(kScenario, "  grass: {terrain", "  \"\": {terrain"), "mode: grass}",
                                  "mode: \"\"}")),
              HasSubstr("a mode's name cannot be empty: it is the log's truth label"));
}

// The bundled, fitted LTC bank identifies each terrain on spirals it was not
// fitted on (fresh seeds, the evaluation maneuver).
TEST(FittedBanks, LtcTerrainsAreIdentifiedOnFreshSingularRuns) {
  const auto dir = test_directory();
  for (const std::string terrain : {"crushed_concrete", "grass", "asphalt"}) {
    const Scenario s = load_scenario(kSource + "/configs/scenarios/ltc_singular_" + terrain + ".yaml");
    simulate(s, 9001, dir / (terrain + ".csv"));
    Imm imm = Imm::from_yaml(kSource + "/configs/ltc_terrains.yaml", {SKIDIMM_PLUGIN_DIR});
    LogReader reader(imm.config(), {dir / (terrain + ".csv")});
    LogSample sample;
    long rows = 0, correct = 0;
    while (reader.next(&sample)) {
      const ImmEstimate& e = imm.step(sample.t, sample.u, sample.z);
      if (sample.t < 5.0) continue;  // give it the paper's 5 s to settle
      ++rows;
      correct += imm.config().modes[static_cast<std::size_t>(e.most_likely_mode)].name == terrain;
    }
    EXPECT_GT(static_cast<double>(correct) / rows, 0.8) << terrain;
  }
}

}  // namespace
}  // namespace simulation
}  // namespace skidimm
