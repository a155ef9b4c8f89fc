// fit_bank: the objectives as `skidimm fit` runs them, on real logs.
#include "skidimm/fitting/bank_fit.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <map>

#include "core/sanitizer.h"
#include "core/temp_files.h"
#include "skidimm/fitting/fit_logs.h"
#include "skidimm/fitting/likelihood_fitter.h"
#include "skidimm/fitting/trajectory.h"

namespace skidimm {
namespace fitting {
namespace {

const std::string kHuskyDir = std::string(SKIDIMM_SHARED_DATA_DIR) + "/husky_ice";

std::vector<Trajectory> husky_runs(const BankConfig& config, const std::vector<std::string>& runs) {
  std::vector<Trajectory> out;
  for (const std::string& run : runs) {
    out.push_back(load_trajectory(config, {LogFile{kHuskyDir + "/TSyn_" + run + ".csv"},
                                           LogFile{kHuskyDir + "/joint_states_" + run + ".csv"}}));
  }
  return out;
}

// The likelihood is not convex. From the physical guess of
// configs/husky/ice_ltc_start.yaml, LBFGS alone settled on these real runs in
// a minimum whose innovation RMSE of V was 0.32 m/s (ten times the no-change
// baseline); started from the one-step fit, it reaches the minimum that the
// window-fitted bank also leads to, and predicts held-out runs better than
// the window fit.
TEST(BankFit, LikelihoodFromAPhysicalGuessOnRealHuskyIceRuns) {
  SKIDIMM_SKIP_UNDER_SANITIZERS_STATISTICAL();
  if (!std::filesystem::exists(kHuskyDir)) GTEST_SKIP() << "no shared data at " << kHuskyDir;
  const std::string start = std::string(SKIDIMM_SOURCE_DIR) + "/configs/husky/ice_ltc_start.yaml";
  const std::vector<std::string> fit_runs{"01", "02", "03", "04", "05", "06", "07", "08", "09"};

  Bank likelihood_bank = Bank::load(start, {SKIDIMM_PLUGIN_DIR});
  const int ice = likelihood_bank.config.mode_index("ice");
  ASSERT_GE(ice, 0);
  const ModeLogs fit_logs{ice, husky_runs(likelihood_bank.config, fit_runs)};
  BankFitOptions likelihood;  // the default objective
  const FitReport report = fit_bank(&likelihood_bank, {fit_logs}, likelihood).at(ice);
  EXPECT_LT(report.negative_log_likelihood_per_row, -3.8);
  EXPECT_LT(report.rmse[0], 0.02) << "innovation RMSE of V, m/s";
  EXPECT_NEAR(report.mean_nis[0], 1.0, 0.2) << "the fitted Q makes the filter consistent";

  Bank window_bank = Bank::load(start, {SKIDIMM_PLUGIN_DIR});
  BankFitOptions window;
  window.objective = Objective::kWindow;
  fit_bank(&window_bank, {fit_logs}, window);
  // Where each input ranged over the fitted runs, recorded on the mode.
  const std::map<std::string, InputRange>& ranges =
      window_bank.config.modes[static_cast<std::size_t>(ice)].fitted_inputs;
  ASSERT_EQ(ranges.size(), window_bank.config.input_names.size());
  for (int i = 0; i < window_bank.config.input_dim(); ++i) {
    double lowest = fit_logs.logs[0].u.row(i).minCoeff(), highest = fit_logs.logs[0].u.row(i).maxCoeff();
    for (const Trajectory& t : fit_logs.logs) {
      lowest = std::min(lowest, t.u.row(i).minCoeff());
      highest = std::max(highest, t.u.row(i).maxCoeff());
    }
    const InputRange& range = ranges.at(window_bank.config.input_names[static_cast<std::size_t>(i)]);
    EXPECT_EQ(range.lowest, lowest) << window_bank.config.input_names[static_cast<std::size_t>(i)];
    EXPECT_EQ(range.highest, highest) << window_bank.config.input_names[static_cast<std::size_t>(i)];
    EXPECT_LT(range.lowest, range.highest);
  }
  // A mode given in several entries (a fit pools them) ranges over all of them, not the last one's.
  std::vector<ModeLogs> split{{ice, {fit_logs.logs.begin(), fit_logs.logs.begin() + 4}},
                              {ice, {fit_logs.logs.begin() + 4, fit_logs.logs.end()}}};
  EXPECT_EQ(fitted_input_ranges(window_bank.config, split, ice).at("phi_dot_L").lowest, ranges.at("phi_dot_L").lowest);
  EXPECT_EQ(fitted_input_ranges(window_bank.config, split, ice).at("phi_dot_L").highest,
            ranges.at("phi_dot_L").highest);
  EXPECT_EQ(fitted_input_ranges(window_bank.config, split, ice + 1).count("phi_dot_L"), 0u) << "no steps of that mode";

  // Runs 10 and 11 (driven faster) are held out.
  const ModeLogs held_out{ice, husky_runs(likelihood_bank.config, {"10", "11"})};
  const LikelihoodEvaluation by_likelihood = evaluate_likelihood(likelihood_bank, held_out);
  const LikelihoodEvaluation by_window = evaluate_likelihood(window_bank, held_out);
  ASSERT_TRUE(by_likelihood.failure.empty()) << by_likelihood.failure;
  ASSERT_TRUE(by_window.failure.empty()) << by_window.failure;
  EXPECT_LT(by_likelihood.negative_log_likelihood, by_window.negative_log_likelihood);
  const FitReport window_held = evaluate(window_bank, held_out);
  const FitReport likelihood_held = evaluate(likelihood_bank, held_out);
  EXPECT_LT(likelihood_held.rmse[0], window_held.rmse[0]) << "held-out one-step RMSE of V";
}

// A segment's span names its times so that segments of one log differ, on a
// log stamped in seconds since 1970 as on one from 0 (six significant
// digits printed 1.71803e+09 for every segment of an hour).
TEST(BankFit, SegmentSpansTellSegmentsOfAnEpochStampedLogApart) {
  Trajectory log;
  log.source = "drive.csv";
  log.t = {1718031234.5, 1718031235.0, 1718031299.25, 1718031299.75};
  log.u = Eigen::MatrixXd::Zero(1, 4);
  log.z = Eigen::MatrixXd::Zero(1, 4);
  log.truth = {"ice", "ice", "snow", "snow"};
  const auto parts = split_by_truth(log);
  ASSERT_EQ(parts.size(), 2u);
  EXPECT_EQ(parts[0].second.source, "drive.csv[1718031234.5-1718031235 s]");
  EXPECT_EQ(parts[1].second.source, "drive.csv[1718031299.25-1718031299.75 s]");
  log.t = {0.0, 6.0655, 9.9905, 43.5};
  EXPECT_EQ(split_by_truth(log)[0].second.source, "drive.csv[0-6.0655 s]");
}

TEST(BankFit, SharedParametersNeedTheWindowObjective) {
  Bank bank = Bank::load(std::string(SKIDIMM_SOURCE_DIR) + "/configs/ltc_shared.yaml", {SKIDIMM_PLUGIN_DIR});
  BankFitOptions options;
  options.shared = true;
  Trajectory t;
  try {
    fit_bank(&bank, {ModeLogs{0, {t}}}, options);
    FAIL() << "the likelihood objective fits no bank-level parameters";
  } catch (const FitError& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("fitted by the window objective only (--objective window)"));
  }
}

// With pooled_process_noise every fitted mode gets the mean of the Q the
// modes would each have had, each mode counted once (here, one fitted on
// four real runs and one on five); the parameters are each mode's own fit.
TEST(BankFit, PooledProcessNoiseIsTheMeanOfTheModesOwn) {
  SKIDIMM_SKIP_UNDER_SANITIZERS_STATISTICAL();
  if (!std::filesystem::exists(kHuskyDir)) GTEST_SKIP() << "no shared data at " << kHuskyDir;
  std::string text = skidimm_test::read_file(std::string(SKIDIMM_SOURCE_DIR) + "/configs/husky/ice_ltc_start.yaml");
  text +=
      "  - name: ice_later\n    model: ltc_linear\n"
      "    params: {A: [[-5, 0], [0, -4]], B: [[0.39, 0.39], [-0.83, 0.83]]}\n    Q: {diagonal: [0.01, 0.01]}\n";
  const std::filesystem::path start = skidimm_test::write_file(skidimm_test::test_directory() / "two.yaml", text);
  const auto fit_two = [&](bool pooled) {
    Bank bank = Bank::load(start, {SKIDIMM_PLUGIN_DIR});
    BankFitOptions options;
    options.objective = Objective::kWindow;
    options.full_process_noise = true;
    options.pooled_process_noise = pooled;
    fit_bank(&bank,
             {ModeLogs{0, husky_runs(bank.config, {"01", "02", "03", "04"})},
              ModeLogs{1, husky_runs(bank.config, {"05", "06", "07", "08", "09"})}},
             options);
    std::vector<Eigen::VectorXd> parameters;
    for (const auto& model : bank.models) {
      parameters.emplace_back(model->parameter_info().size());
      model->get_parameters(parameters.back());
    }
    return std::make_pair(bank.config, parameters);
  };
  const auto [own, own_parameters] = fit_two(false);
  const auto [pooled, pooled_parameters] = fit_two(true);
  const Eigen::MatrixXd& q0 = own.modes[0].q_intensity;
  const Eigen::MatrixXd& q1 = own.modes[1].q_intensity;
  ASSERT_EQ(q0.rows(), 2);
  EXPECT_GT((q0 - q1).norm(), 0.1 * q0.norm()) << "the two sets of runs call for different noise";
  for (const ModeConfig& mode : pooled.modes) {
    for (Eigen::Index i = 0; i < 2; ++i) {
      for (Eigen::Index j = 0; j < 2; ++j) {
        EXPECT_NEAR(mode.q_intensity(i, j), (q0(i, j) + q1(i, j)) / 2.0, 1e-12 * q0.norm()) << mode.name;
      }
    }
  }
  for (std::size_t m = 0; m < 2; ++m) EXPECT_EQ(pooled_parameters[m], own_parameters[m]) << "each mode's own fit";
  EXPECT_THROW(pooled_process_noise({}), FitError);
  EXPECT_THROW(pooled_process_noise({q0, Eigen::MatrixXd::Zero(3, 3)}), FitError);

  Bank bank = Bank::load(start, {SKIDIMM_PLUGIN_DIR});
  BankFitOptions likelihood;
  likelihood.pooled_process_noise = true;
  try {
    fit_bank(&bank, {ModeLogs{0, husky_runs(bank.config, {"01"})}}, likelihood);
    FAIL() << "the likelihood objective fits each mode's Q with its parameters";
  } catch (const FitError& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("pooled from the window objective's estimates"));
  }
}

// What fit and tune state before they start: ltc_linear's 8 parameters of
// its own per mode (A and B, 2 x 2 each), and 2 entries of a diagonal Q or 3
// of a full one.
TEST(BankFit, StatesTheWorkItFaces) {
  const Bank bank = Bank::load(std::string(SKIDIMM_SOURCE_DIR) + "/configs/ltc_terrains.yaml", {SKIDIMM_PLUGIN_DIR});
  const auto rows = [](int n, const std::string& log) {
    Trajectory t;
    t.t.resize(static_cast<std::size_t>(n));
    t.log = log;
    return t;
  };
  // Mode 0 twice (its logs pooled), mode 2 once; three logs, one of them in
  // two segments (its truth changes): logs are counted once.
  const std::vector<ModeLogs> data{
      {0, {rows(100, "a.csv"), rows(50, "b.csv")}}, {2, {rows(7, "c.csv")}}, {0, {rows(3, "c.csv")}}};
  BankFitOptions options;
  FitWork work = fit_work(bank, data, options);
  EXPECT_EQ(work.modes, 2);
  EXPECT_EQ(work.logs, 3);
  EXPECT_EQ(work.segments, 4);
  EXPECT_EQ(work.rows, 160);
  EXPECT_EQ(work.parameters, 2 * (8 + 2));
  EXPECT_EQ(work.describe(), "2 modes, 3 logs (4 segments), 160 rows, 20 parameters (likelihood objective)");
  options.full_process_noise = true;
  options.fit_measurement_noise = true;
  options.objective = Objective::kWindow;
  work = fit_work(bank, data, options);
  EXPECT_EQ(work.parameters, 2 * (8 + 3) + 2);
  EXPECT_EQ(work.describe(), "2 modes, 3 logs (4 segments), 160 rows, 24 parameters (window objective)");
}

}  // namespace
}  // namespace fitting
}  // namespace skidimm
