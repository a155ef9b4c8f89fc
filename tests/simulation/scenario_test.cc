#include "skidimm/simulation/scenario.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "core/temp_files.h"
#include "skidimm/errors.h"
#include "skidimm/imm.h"
#include "skidimm/log_io.h"

namespace skidimm {
namespace simulation {
namespace {

using skidimm_test::read_file;
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

std::string replace(std::string text, const std::string& from, const std::string& to) {
  return text.replace(text.find(from), from.size(), to);
}

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
      write_file(dir / "s.yaml", replace(kScenario, "gps_rate: 10}", "gps_rate: 10, velocity_dropout: 1.0}")));
  simulate(s, 1, dir / "log.csv");
  CsvReader reader(dir / "log.csv");
  std::vector<std::string> f;
  while (reader.next(&f)) ASSERT_TRUE(f[3].empty());
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
      error(replace(kScenario, "terrain: grass", "terrain: mud")),
      HasSubstr("bad.yaml:4: modes.grass: unknown terrain 'mud' (known: asphalt, crushed_concrete, grass, ice)"));
  EXPECT_THAT(error(replace(kScenario, "{at: 0, mode: grass}", "{at: 1, mode: grass}")),
              HasSubstr("schedule[0].at: the first entry must start at 0"));
  EXPECT_THAT(error(replace(kScenario, "{at: 2, mode: slip}", "{at: 2, mode: ice}")),
              HasSubstr("schedule[1].mode: no mode 'ice' under modes"));
  EXPECT_THAT(error(replace(kScenario, "type: sinusoidal", "type: zigzag")),
              HasSubstr("maneuver.type: expected straight, skidpad, clothoid, sinusoidal or spiral"));
  EXPECT_THAT(error(replace(kScenario, "jitter: 0.2", "jitter: 1.5")), HasSubstr("sensors.jitter: must be below 1"));
  EXPECT_THAT(error(replace(kScenario, "duration: 4", "duration: -4")),
              HasSubstr("duration: must be a finite number > 0"));
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
