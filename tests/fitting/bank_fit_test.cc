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

// Partial pooling by hand. Three ltc_linear modes of one regime, entry 0 of
// each fitted with variance 1 at 0, 1 and 5: their mean is 2, the spread of
// the estimates 7, the modes' own variance 1, so the spread between the
// modes' true values is 6 and each estimate moves 1/(1 + 6) of the way to the
// mean; its variance becomes (6/7)^2 + (1/7)^2 (6 + 7/3) = 133/147, the
// prior's share with the mean's own uncertainty (7/3). Entry 1, fitted by
// the first mode alone (held in the third), is not pooled but moves with
// entry 0 by their covariance, 0.5: by 0.5/7 of entry 0's distance to the
// mean, to variance 1 - 0.25/7 + (0.5/7)^2 7/3 = 41/42.
TEST(PartialPooling, MovesEachEstimateByHowLittleItsLogsDeterminedIt) {
  const Bank bank = Bank::load(std::string(SKIDIMM_SOURCE_DIR) + "/configs/ltc_terrains.yaml", {SKIDIMM_PLUGIN_DIR});
  ASSERT_EQ(bank.config.num_modes(), 3);
  const Eigen::Index n = static_cast<Eigen::Index>(bank.models[0]->parameter_info().size());
  std::vector<Eigen::VectorXd> parameters(3, Eigen::VectorXd::Constant(n, 0.25));
  std::vector<Eigen::MatrixXd> covariances(3, Eigen::MatrixXd::Zero(n, n));
  const double own[3] = {0.0, 1.0, 5.0};
  for (int j = 0; j < 3; ++j) {
    parameters[static_cast<std::size_t>(j)][0] = own[j];
    covariances[static_cast<std::size_t>(j)](0, 0) = 1.0;
  }
  covariances[0](1, 1) = 1.0;
  covariances[0](0, 1) = covariances[0](1, 0) = 0.5;
  covariances[1](1, 1) = 2.0;  // fitted, but the third mode held it: not pooled
  const std::vector<Eigen::VectorXd> before = parameters;
  const PartialPooling outcome = pool_parameters_partially(bank, {0, 1, 2}, &parameters, &covariances);
  EXPECT_EQ(outcome.regimes, 1);
  EXPECT_TRUE(outcome.kept_own.empty());
  for (int j = 0; j < 3; ++j) {
    EXPECT_NEAR(parameters[static_cast<std::size_t>(j)][0], own[j] + (2.0 - own[j]) / 7.0, 1e-14) << j;
    EXPECT_NEAR(covariances[static_cast<std::size_t>(j)](0, 0), 133.0 / 147.0, 1e-14) << j;
  }
  EXPECT_NEAR(parameters[0][1], 0.25 + 0.5 / 7.0 * 2.0, 1e-14);
  EXPECT_NEAR(covariances[0](1, 1), 41.0 / 42.0, 1e-14);
  EXPECT_NEAR(parameters[1][1], 0.25, 1e-14) << "uncorrelated with entry 0: not moved";
  for (Eigen::Index e = 2; e < n; ++e) EXPECT_EQ(parameters[2][e], 0.25) << "held entries keep their values";
  // Estimates closer than their own uncertainty explains (0, 0.1, 0.2, each
  // with variance 1): no spread between the modes is left (tau2 clamped at
  // 0), so each takes the mean, 0.1, as sure as a mean of three estimates of
  // variance 1 is, 1/3 (not the spread / 3 of the estimates, 0.01 / 3).
  {
    std::vector<Eigen::VectorXd> close(3, Eigen::VectorXd::Zero(n));
    std::vector<Eigen::MatrixXd> close_covariances(3, Eigen::MatrixXd::Zero(n, n));
    for (int j = 0; j < 3; ++j) {
      close[static_cast<std::size_t>(j)][0] = 0.1 * j;
      close_covariances[static_cast<std::size_t>(j)](0, 0) = 1.0;
    }
    EXPECT_EQ(pool_parameters_partially(bank, {0, 1, 2}, &close, &close_covariances).regimes, 1);
    for (int j = 0; j < 3; ++j) {
      EXPECT_NEAR(close[static_cast<std::size_t>(j)][0], 0.1, 1e-12) << j;
      EXPECT_NEAR(close_covariances[static_cast<std::size_t>(j)](0, 0), 1.0 / 3.0, 1e-12) << j;
    }
  }
  // Two modes are no regime to pool over; modes of another fit_when are another regime.
  std::vector<Eigen::VectorXd> two = before;
  std::vector<Eigen::MatrixXd> two_covariances(3, Eigen::MatrixXd::Identity(n, n));
  EXPECT_EQ(pool_parameters_partially(bank, {0, 2}, &two, &two_covariances).regimes, 0);
  EXPECT_EQ(two[0], before[0]);
  Bank regimes = bank;
  regimes.config.modes[1].fit_when = "phi_dot_L > 1";
  two = before;
  EXPECT_EQ(pool_parameters_partially(regimes, {0, 1, 2}, &two, &two_covariances).regimes, 0);
  EXPECT_EQ(two[2], before[2]);
}

// A mode whose pooling would move a bounded parameter past its bound (an
// unpooled m pulled by its correlation with the pooled k) keeps its own
// estimates, and is named.
TEST(PartialPooling, AModeItWouldMovePastABoundKeepsItsOwn) {
  const Bank bank = Bank::load(std::string(SKIDIMM_SOURCE_DIR) + "/configs/stc_slip4.yaml", {SKIDIMM_PLUGIN_DIR});
  const auto& info = bank.models[0]->parameter_info();
  const auto index = [&info](const std::string& name) {
    for (std::size_t e = 0; e < info.size(); ++e) {
      if (info[e].name == name) return static_cast<Eigen::Index>(e);
    }
    return Eigen::Index{-1};
  };
  const Eigen::Index k = index("k"), m = index("m"), n = static_cast<Eigen::Index>(info.size());
  ASSERT_GE(k, 0);
  ASSERT_GE(m, 0);
  ASSERT_EQ(info[static_cast<std::size_t>(m)].upper_bound, 2.0);
  std::vector<Eigen::VectorXd> parameters(4, Eigen::VectorXd::Zero(n));
  std::vector<Eigen::MatrixXd> covariances(4, Eigen::MatrixXd::Zero(n, n));
  for (int j = 0; j < 4; ++j) {
    bank.models[static_cast<std::size_t>(j)]->get_parameters(parameters[static_cast<std::size_t>(j)]);
    parameters[static_cast<std::size_t>(j)][k] = j < 3 ? 0.1 : 1.9;
    covariances[static_cast<std::size_t>(j)](k, k) = 0.01;
  }
  parameters[3][m] = 1.99;
  covariances[3](m, m) = 0.01;
  covariances[3](k, m) = covariances[3](m, k) = -0.009;
  const std::vector<Eigen::VectorXd> before = parameters;
  const PartialPooling outcome = pool_parameters_partially(bank, {0, 1, 2, 3}, &parameters, &covariances);
  ASSERT_EQ(outcome.kept_own.size(), 1u);
  EXPECT_EQ(outcome.kept_own[0].first, "slip_FL_FR_RL_RR");
  EXPECT_THAT(outcome.kept_own[0].second, ::testing::HasSubstr("outside its bounds"));
  EXPECT_EQ(parameters[3], before[3]);
  EXPECT_LT(parameters[3][k] - parameters[0][k], before[3][k] - before[0][k]) << "the others moved";
  EXPECT_GT(parameters[0][k], 0.1);
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
