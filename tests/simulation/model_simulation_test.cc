#include "skidimm/simulation/model_simulation.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <map>

#include "core/temp_files.h"
#include "skidimm/errors.h"
#include "skidimm/io/csv.h"

namespace skidimm {
namespace simulation {
namespace {

using skidimm_test::read_file;
using skidimm_test::test_directory;
using skidimm_test::write_file;
using ::testing::HasSubstr;

const std::string kExample = std::string(SKIDIMM_SOURCE_DIR) + "/configs/examples/ltc_switching.csv";

// Two ltc_linear modes, no process noise, a prior without spread and a
// negligible sensor: the log is the models' own deterministic response.
const std::string kBank = R"(name: known
states: [V, omega]
inputs: [phi_dot_L, phi_dot_R]
columns: {time: t, truth_mode: mode}
measurement: {observe: [V, omega], R: {std: [1e-9, 1e-9]}}
transition: {stay: 0.99}
initial: {state: [0.1, 0], covariance: {diagonal: [0, 0]}}
modes:
  - {name: crushed_concrete, model: ltc_linear, params: {A: [[-5, 0], [0, -4]], B: [[0.4, 0.4], [-0.8, 0.8]]}, Q: {diagonal: [0, 0]}}
  - {name: grass, model: ltc_linear, params: {A: [[-3, 0], [0, -2]], B: [[0.2, 0.2], [-0.5, 0.5]]}, Q: {diagonal: [0, 0]}}
  - {name: asphalt, model: ltc_linear, params: {A: [[-6, 0], [0, -5]], B: [[0.5, 0.5], [-1, 1]]}, Q: {diagonal: [0, 0]}}
)";

std::vector<std::vector<std::string>> read_csv(const std::filesystem::path& path) {
  CsvReader reader(path);
  std::vector<std::vector<std::string>> rows{reader.header()};
  std::vector<std::string> fields;
  while (reader.next(&fields)) rows.push_back(fields);
  return rows;
}

TEST(ModelSimulation, ReplaysInputsAndModesThroughTheBanksOwnModels) {
  const auto dir = test_directory();
  const Bank bank = Bank::load(write_file(dir / "known.yaml", kBank), {SKIDIMM_PLUGIN_DIR});
  const auto summary = simulate_models(bank, parse_log_spec(kExample), bank.config.sampling, 7, dir / "out.csv");
  EXPECT_EQ(summary.mode_switches, 2);
  const auto rows = read_csv(dir / "out.csv");
  const auto source = read_csv(kExample);
  ASSERT_EQ(rows.size(), source.size());
  EXPECT_EQ(rows[0], (std::vector<std::string>{"t", "phi_dot_L", "phi_dot_R", "V", "omega", "mode", "true_V", "true_omega"}));
  // An independent Euler integration of eq. 2 with each row's mode.
  double v = 0.1, w = 0.0;
  const std::map<std::string, std::array<double, 8>> modes{
      {"crushed_concrete", {-5, 0, 0, -4, 0.4, 0.4, -0.8, 0.8}},
      {"grass", {-3, 0, 0, -2, 0.2, 0.2, -0.5, 0.5}},
      {"asphalt", {-6, 0, 0, -5, 0.5, 0.5, -1, 1}}};
  for (std::size_t k = 1; k < rows.size(); ++k) {
    EXPECT_EQ(rows[k][5], source[k][10]) << "the source's mode, row " << k;
    if (k > 1) {
      const auto& p = modes.at(rows[k][5]);
      const double dt = std::stod(rows[k][0]) - std::stod(rows[k - 1][0]);
      const double l = std::stod(rows[k - 1][1]), r = std::stod(rows[k - 1][2]);
      const double v_next = v + dt * (p[0] * v + p[1] * w + p[4] * l + p[5] * r);
      const double w_next = w + dt * (p[2] * v + p[3] * w + p[6] * l + p[7] * r);
      v = v_next;
      w = w_next;
    }
    ASSERT_NEAR(std::stod(rows[k][6]), v, 1e-9) << "row " << k;
    ASSERT_NEAR(std::stod(rows[k][7]), w, 1e-9) << "row " << k;
    ASSERT_NEAR(std::stod(rows[k][3]), v, 1e-6) << "measured V, row " << k;
  }
}

TEST(ModelSimulation, NoiseHasTheBanksStatisticsAndASeedReproducesTheLog) {
  const auto dir = test_directory();
  std::string yaml = kBank;
  yaml.replace(yaml.find("R: {std: [1e-9, 1e-9]}"), 22, "R: {std: [0.05, 0.02]}");
  const Bank bank = Bank::load(write_file(dir / "noisy.yaml", yaml), {SKIDIMM_PLUGIN_DIR});
  simulate_models(bank, parse_log_spec(kExample), bank.config.sampling, 11, dir / "a.csv");
  simulate_models(bank, parse_log_spec(kExample), bank.config.sampling, 11, dir / "b.csv");
  simulate_models(bank, parse_log_spec(kExample), bank.config.sampling, 12, dir / "c.csv");
  EXPECT_EQ(read_file(dir / "a.csv"), read_file(dir / "b.csv"));
  EXPECT_NE(read_file(dir / "a.csv"), read_file(dir / "c.csv"));
  const auto rows = read_csv(dir / "a.csv");
  double sum_v = 0.0, sum_w = 0.0;
  for (std::size_t k = 1; k < rows.size(); ++k) {
    sum_v += std::pow(std::stod(rows[k][3]) - std::stod(rows[k][6]), 2);
    sum_w += std::pow(std::stod(rows[k][4]) - std::stod(rows[k][7]), 2);
  }
  const double n = static_cast<double>(rows.size() - 1);
  EXPECT_NEAR(std::sqrt(sum_v / n), 0.05, 0.005);  // 1486 draws: within 10%
  EXPECT_NEAR(std::sqrt(sum_w / n), 0.02, 0.002);
}

TEST(ModelSimulation, AModeTheBankLacksIsAnError) {
  const auto dir = test_directory();
  const Bank bank = Bank::load(write_file(dir / "known.yaml", kBank), {SKIDIMM_PLUGIN_DIR});
  try {
    simulate_models(bank, parse_log_spec("ice=" + kExample), bank.config.sampling, 1, dir / "out.csv");
    FAIL();
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("step at t = 0: 'ice' is neither a mode nor a class of bank 'known'; its modes: "
                                    "crushed_concrete, grass, asphalt"));
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "out.csv"));
}

}  // namespace
}  // namespace simulation
}  // namespace skidimm
