// What simulate() refuses to integrate: a step that does
// not resolve the robot's fastest response, runs of unbounded length, sensor
// rates the integration cannot deliver, and a state that stops being finite.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "core/temp_files.h"
#include "skidimm/errors.h"
#include "skidimm/simulation/scenario.h"
#include "skidimm/simulation/skid_steer_dynamics.h"

namespace skidimm {
namespace simulation {
namespace {

using skidimm_test::replace_first;
using skidimm_test::test_directory;
using skidimm_test::write_file;
using ::testing::HasSubstr;

const std::string kBoundsScenario = R"(name: bounds
duration: 4
robot: {yaw_inertia: 6.0}
mode: asphalt
modes:
  asphalt: {terrain: asphalt}
maneuver: {type: sinusoidal, speed: 0.6}
sensors: {rate: 50, gps_rate: 10}
)";

std::string load_error(const std::string& yaml) {
  const auto dir = test_directory();
  try {
    load_scenario(write_file(dir / "s.yaml", yaml));
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "no error";
}

// The Husky on asphalt (mu 0.9, B 12, C 1.9, isotropic) at rest, slips over
// the floor v0 = 0.05 m/s: each wheel's force slope is
// mu (m g / 4) C B / v0 = 0.9 * 122.625 * 1.9 * 12 / 0.05 = 50,325.3 N s/m.
// Yaw: 4 * 50,325.3 * (0.256^2 + 0.2775^2) / 6 kg m^2 = 4,782.3 1/s;
// longitudinal and lateral: 4 * 50,325.3 / 50 kg = 4,026.0 1/s; wheel loop 20.
TEST(FastestResponse, IsTheYawResponseOfTheHuskyOnAsphalt) {
  const SkidSteerDynamics dynamics{RobotParameters{}};
  const FastestResponse fastest = dynamics.fastest_response(make_traction_mode("a", "asphalt", {}));
  EXPECT_STREQ(fastest.what, "yaw");
  EXPECT_NEAR(fastest.rate, 4782.3, 0.5);
  RobotParameters slow_motor;
  slow_motor.motor_time_constant = 1e-4;  // 10,000 1/s
  EXPECT_STREQ(SkidSteerDynamics(slow_motor).fastest_response(make_traction_mode("a", "asphalt", {})).what,
               "wheel speed loop");
}

// 2.5 / 4,782.3 = 0.52276 ms: the default 0.5 ms step is inside, 0.53 ms not.
TEST(SimulationBounds, TheStepMustResolveTheFastestResponse) {
  EXPECT_EQ(load_error(kBoundsScenario), "no error");
  EXPECT_EQ(load_error(replace_first(kBoundsScenario, "duration: 4", "duration: 4\nintegration_step: 0.00052")), "no error");
  const std::string error = load_error(replace_first(kBoundsScenario, "duration: 4", "duration: 4\nintegration_step: 0.00053"));
  EXPECT_THAT(error, HasSubstr("s.yaml:3: integration_step: integration_step 0.00053 s does not resolve the yaw "
                               "response on mode 'asphalt' (time constant 0.000209 s)"));
  EXPECT_THAT(error, HasSubstr("must be <= 2.5 of them, 0.000523 s"));
}

TEST(SimulationBounds, AnImplausibleRobotIsNamed) {
  // 1 / 1e-4 s * 0.5 ms = 5 time constants a step.
  EXPECT_THAT(load_error(replace_first(kBoundsScenario, "{yaw_inertia: 6.0}", "{yaw_inertia: 6.0, motor_time_constant: 0.0001}")),
              HasSubstr("s.yaml:3: robot.motor_time_constant: integration_step 0.0005 s does not resolve the wheel "
                        "speed loop response on mode 'asphalt' (time constant 0.0001 s)"));
  EXPECT_THAT(load_error(replace_first(kBoundsScenario, "{yaw_inertia: 6.0}", "{yaw_inertia: 1e-12}")),
              HasSubstr("s.yaml:3: robot.yaw_inertia: integration_step 0.0005 s does not resolve the yaw response"));
  // The yaw response is the inertia against the wheels' moment arms: an absurd wheelbase was blamed on the inertia
  // alone.
  EXPECT_THAT(load_error(replace_first(kBoundsScenario, "{yaw_inertia: 6.0}", "{yaw_inertia: 6.0, wheelbase: 1e300}")),
              HasSubstr("(or check robot.track and robot.wheelbase, the wheels' moment arms)"));
}

TEST(SimulationBounds, TheNumberOfStepsIsBounded) {
  EXPECT_THAT(load_error(replace_first(kBoundsScenario, "duration: 4", "duration: 4\nintegration_step: 1e-9")),
              HasSubstr("duration: 4 s at integration_step 1e-09 s is 4e+09 integration steps, more than the limit "
                        "of 20000000"));
  EXPECT_THAT(load_error(replace_first(kBoundsScenario, "duration: 4", "duration: 1e9")),
              HasSubstr("s.yaml:2: duration: 1e+09 s at integration_step 0.0005 s is 2e+12 integration steps"));
  // 20,000,000 steps of 0.5 ms: 10,000 s loads, a step more does not.
  EXPECT_EQ(load_error(replace_first(kBoundsScenario, "duration: 4", "duration: 10000")), "no error");
  EXPECT_THAT(load_error(replace_first(kBoundsScenario, "duration: 4", "duration: 10000.001")),
              HasSubstr("is 2e+07 integration steps, more than the limit of 20000000"));
}

TEST(SimulationBounds, AChangedDurationIsCheckedBeforeSimulating) {
  const auto dir = test_directory();
  Scenario s = load_scenario(write_file(dir / "s.yaml", kBoundsScenario));
  s.duration = 1e9;  // as `skidimm simulate --duration 1e9` does
  EXPECT_THROW(check_simulable(s), ConfigError);
  try {
    simulate(s, 1, dir / "log.csv");
    ADD_FAILURE() << "simulated 2e12 steps";
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr("duration: 1e+09 s at integration_step 0.0005 s"));
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "log.csv"));
}

TEST(SimulationBounds, SensorRatesTheIntegrationCannotDeliverAreErrors) {
  // One row per step at most: 1 / 0.5 ms = 2000 Hz.
  EXPECT_EQ(load_error(replace_first(kBoundsScenario, "rate: 50,", "rate: 2000,")), "no error");
  EXPECT_THAT(load_error(replace_first(kBoundsScenario, "rate: 50,", "rate: 2001,")),
              HasSubstr("s.yaml:8: sensors.rate: a row is written at most once per integration step, so the rate "
                        "must be <= 1 / integration_step = 2000 Hz, got 2001 Hz"));
  EXPECT_THAT(load_error(replace_first(kBoundsScenario, "gps_rate: 10", "gps_rate: 60")),
              HasSubstr("sensors.gps_rate: a GPS fix is written on a sensor row, so it must be <= sensors.rate = 50 "
                        "Hz, got 60 Hz"));
  EXPECT_THAT(load_error(replace_first(kBoundsScenario, "gps_rate: 10", "gps_rate: 10, current_rate: 51")),
              HasSubstr("sensors.current_rate: a current sample is written on a sensor row, so it must be <= "
                        "sensors.rate = 50 Hz, got 51 Hz"));
  // A rate too small for six decimals is shown, not rounded to 0 Hz.
  EXPECT_THAT(load_error(replace_first(kBoundsScenario, "rate: 50,", "rate: 1e-9,")),
              HasSubstr("must be <= sensors.rate = 1e-09 Hz, got 10 Hz"));
  EXPECT_THAT(load_error(replace_first(kBoundsScenario, "gps_rate: 10", "gps_rate: 10, current_std: -1")),
              HasSubstr("sensors.current_std"));
  EXPECT_THAT(load_error(replace_first(kBoundsScenario, "gps_rate: 10", "gps_rate: 10, current_dropout: 2")),
              HasSubstr("sensors.current_dropout"));
}

TEST(SimulationBounds, AStateThatStopsBeingFiniteIsAnErrorNamingTheTime) {
  const auto dir = test_directory();
  // Wheel commands of 1e308 / 0.165 m overflow to infinity in the first step.
  const Scenario s =
      load_scenario(write_file(dir / "s.yaml", replace_first(kBoundsScenario, "speed: 0.6", "speed: 1e308, ramp: 0")));
  try {
    simulate(s, 1, dir / "log.csv");
    ADD_FAILURE() << "simulated an infinite state";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("s.yaml: the simulated state is not finite at t = 0.0005 s (mode 'asphalt')"));
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "log.csv"));
}

}  // namespace
}  // namespace simulation
}  // namespace skidimm
