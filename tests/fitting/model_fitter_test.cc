#include "skidimm/fitting/model_fitter.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <cmath>
#include <limits>
#include <random>

#include "core/sanitizer.h"
#include "core/temp_files.h"
#include "fitting/simulated_logs.h"
#include "skidimm/errors.h"
#include "skidimm/fitting/bank_fit.h"
#include "skidimm/fitting/fit_output.h"
#include "skidimm/sdk/angles.h"

namespace skidimm {
namespace fitting {
namespace {

using skidimm_test::rich_wheel_speeds;
using skidimm_test::test_directory;
using skidimm_test::write_file;
using ::testing::Contains;
using ::testing::HasSubstr;
using ::testing::Not;

const std::string kLtcBank = R"(name: fit_test
states: [V, omega]
inputs: [phi_dot_L, phi_dot_R]
measurement: {observe: [V, omega], R: {std: [0.02, 0.02]}}
transition: {stay: 0.99}
initial: {covariance: {std: [1, 1]}}
modes:
  - name: a
    model: ltc_linear
    params: {A: [[-1, 0], [0, -1]], B: [[0.1, 0.1], [-0.1, 0.1]]}
    Q: {diagonal: [0.01, 0.01]}
)";

Bank load_bank(const std::string& yaml, const std::string& file = "bank.yaml") {
  return Bank::load(write_file(test_directory() / file, yaml), {SKIDIMM_PLUGIN_DIR});
}

// Simulates a model through the SDK with process noise of intensity q and
// measurement noise r (standard deviations), all states measured every row
// (or every `measure_every` rows), and returns the trajectory.
Trajectory simulate_model(const sdk::MotionModel& model, int rows, double dt,
                          const std::function<Eigen::VectorXd(double)>& input, const Eigen::VectorXd& q,
                          const Eigen::VectorXd& r, unsigned seed, int measure_every = 1) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  const int n = model.state_dim();
  Trajectory t;
  t.source = "simulated";
  t.u.resize(model.input_dim(), rows);
  t.z.resize(n, rows);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(n), next(n);
  for (int k = 0; k < rows; ++k) {
    const double time = k * dt;
    t.t.push_back(time);
    t.u.col(k) = input(time);
    for (int i = 0; i < n; ++i) {
      t.z(i, k) = k % measure_every == 0 ? x[i] + r[i] * normal(rng) : std::nan("");
      if (model.is_angle(i)) t.z(i, k) = sdk::wrap_angle(t.z(i, k));
    }
    model.predict(x, t.u.col(k), dt, next);
    for (int i = 0; i < n; ++i) next[i] += std::sqrt(q[i] * dt) * normal(rng);
    x = next;
    for (int i = 0; i < n; ++i) {
      if (model.is_angle(i)) x[i] = sdk::wrap_angle(x[i]);
    }
  }
  return t;
}

// ltc_linear's parameters the LTC tests simulate from.
Eigen::VectorXd ltc_true_parameters() {
  Eigen::VectorXd p(8);
  p << -4.0, 0.3, 0.2, -3.0, 0.35, 0.3, -0.7, 0.75;
  return p;
}

// `rows` rows of kLtcBank's model at ltc_true_parameters(), 50 Hz, with 1 cm/s and
// 0.01 rad/s sensors (noise seed `seed`).
Trajectory simulate_ltc_log(int rows, unsigned seed) {
  Bank truth = load_bank(kLtcBank, "truth.yaml");
  EXPECT_TRUE(truth.models[0]->set_parameters(ltc_true_parameters(), nullptr));
  return simulate_model(*truth.models[0], rows, 0.02, rich_wheel_speeds, Eigen::Vector2d(1e-4, 1e-4),
                        Eigen::Vector2d(0.01, 0.01), seed);
}

TEST(ModelFitter, RecoversLtcLinearParametersFromItsOwnData) {
  const Eigen::VectorXd true_parameters = ltc_true_parameters();
  const Trajectory data = simulate_ltc_log(6000, 1);  // two minutes
  Bank bank = load_bank(kLtcBank);  // starts from A = -I, B small
  FitOptions options;
  options.window = 0.2;  // s: 10 rows at 50 Hz
  const FitReport report = fit(&bank, {ModeLogs{0, {data}}}, options).front();
  Eigen::VectorXd fitted(8);
  bank.models[0]->get_parameters(fitted);
  for (int i = 0; i < 8; ++i) {
    EXPECT_NEAR(fitted[i], true_parameters[i], 0.05 * std::max(1.0, std::abs(true_parameters[i])))
        << report.parameters[static_cast<std::size_t>(i)].name;
    // The stated uncertainty covers the error.
    EXPECT_LT(std::abs(fitted[i] - true_parameters[i]),
              5.0 * report.parameters[static_cast<std::size_t>(i)].standard_deviation + 1e-3);
  }
  EXPECT_EQ(report.parameters.size(), 8u);
  EXPECT_LT(report.final_cost, report.initial_cost);
  EXPECT_NEAR(report.rmse[0], 0.01 * std::sqrt(2.0), 0.005);  // one-step error ~ noise of two measurements
}

TEST(ModelFitter, ExactAndNumericDerivativesReachTheSameFit) {
  const Trajectory data = simulate_ltc_log(3000, 5);
  FitOptions options;
  options.window = 0.2;  // s: 10 rows at 50 Hz
  Bank exact = load_bank(kLtcBank, "exact.yaml");
  const FitReport exact_report = fit(&exact, {ModeLogs{0, {data}}}, options).front();
  options.numeric_derivatives = true;
  Bank numeric = load_bank(kLtcBank, "numeric.yaml");
  const FitReport numeric_report = fit(&numeric, {ModeLogs{0, {data}}}, options).front();
  EXPECT_EQ(exact_report.derivatives, "autodiff");
  EXPECT_EQ(numeric_report.derivatives, "numeric");
  for (std::size_t i = 0; i < 8; ++i) {
    EXPECT_NEAR(exact_report.parameters[i].value, numeric_report.parameters[i].value,
                1e-4 * std::max(1.0, std::abs(numeric_report.parameters[i].value)))
        << exact_report.parameters[i].name;
  }
}

// Without standard deviations (what tune asks of its folds' fits) the fit
// is the same to the bit; only the deviations are NaN, and no parameter is
// called poorly determined on their account.
TEST(ModelFitter, StandardDeviationsCanBeLeftOutWithoutChangingTheFit) {
  const Trajectory data = simulate_ltc_log(1500, 6);
  FitOptions options;
  options.window = 0.2;
  Bank with = load_bank(kLtcBank, "with.yaml");
  const FitReport with_report = fit(&with, {ModeLogs{0, {data}}}, options).front();
  options.standard_deviations = false;
  Bank without = load_bank(kLtcBank, "without.yaml");
  const FitReport without_report = fit(&without, {ModeLogs{0, {data}}}, options).front();
  ASSERT_EQ(with_report.parameters.size(), without_report.parameters.size());
  for (std::size_t i = 0; i < with_report.parameters.size(); ++i) {
    EXPECT_EQ(without_report.parameters[i].value, with_report.parameters[i].value) << with_report.parameters[i].name;
    EXPECT_TRUE(std::isfinite(with_report.parameters[i].standard_deviation));
    EXPECT_TRUE(std::isnan(without_report.parameters[i].standard_deviation));
  }
  EXPECT_EQ(without_report.final_cost, with_report.final_cost);
  EXPECT_EQ(without_report.q_intensity, with_report.q_intensity);
  for (const std::string& w : without_report.warnings) {
    EXPECT_THAT(w, Not(HasSubstr("poorly determined")));
    EXPECT_THAT(w, Not(HasSubstr("covariance")));
  }
}

TEST(ModelFitter, RecoversStcSlipConstantsFromGpsEveryFifthRow) {
  const std::string bank_yaml = R"(name: stc
states: [X, Y, theta]
angles: [theta]
inputs: [phi_dot_L, phi_dot_R]
measurement: {observe: [X, Y, theta], R: {std: [0.02, 0.02, 0.02]}}
transition: {stay: 0.99}
initial: {covariance: {std: [1, 1, 1]}}
shared: {r: 0.165, b: 0.555}
modes:
  - {name: slip, model: stc_kinematic, params: {k: 1.0, m: 1.0}, Q: {diagonal: [0.001, 0.001, 0.001]}}
)";
  Bank truth = load_bank(bank_yaml, "truth.yaml");
  ASSERT_TRUE(truth.models[0]->set_parameters(Eigen::Vector4d(0.82, 0.57, 0.165, 0.555), nullptr));
  auto turns = [](double t) { return Eigen::Vector2d(5.0 + 2.5 * std::sin(0.4 * t), 5.0 - 2.5 * std::sin(0.4 * t)); };
  const Trajectory data = simulate_model(*truth.models[0], 3000, 0.02, turns, Eigen::Vector3d(1e-5, 1e-5, 1e-5),
                                         Eigen::Vector3d(0.02, 0.02, 0.02), 2, 5);
  Bank bank = load_bank(bank_yaml);
  FitOptions options;
  options.window = 0.5;  // s: 5 GPS fixes at 10 Hz
  const FitReport report = fit(&bank, {ModeLogs{0, {data}}}, options).front();
  ASSERT_EQ(report.parameters.size(), 2u);  // r and b are bank-level: not fitted per mode
  EXPECT_NEAR(report.parameters[0].value, 0.82, 0.01);
  EXPECT_NEAR(report.parameters[1].value, 0.57, 0.01);
}

// A bank of one stc_traction mode that measures the gyro and the motor
// currents (measurement.outputs) as well as the pose.
const std::string kTractionBank = R"(name: traction
states: [X, Y, theta]
angles: [theta]
inputs: [phi_dot_L, phi_dot_R]
measurement: {observe: [X, Y, theta], outputs: [omega, i_L, i_R], R: {std: [0.02, 0.02, 0.02, 0.02, 0.3, 0.3]}}
transition: {stay: 0.99}
initial: {covariance: {std: [1, 1, 1]}}
shared: {r: 0.165, b: 0.555}
modes:
  - name: slip
    model: stc_traction
    params: {eta_l: 1, eta_r: 1, alpha_l_outer: 1, alpha_l_inner: 1, alpha_r_outer: 1, alpha_r_inner: 1, x_icr: 0,
             k_skid_l: 10, k_skid_r: 10, i_straight: 2, i_l_outer: 5, i_l_inner: 5, i_r_outer: 5, i_r_inner: 5, s_peak: 0.1}
    Q: {diagonal: [0.001, 0.001, 0.001]}
)";

// The stc_traction mode the tests simulate: its 17 parameters in plugin order.
Eigen::VectorXd traction_truth() {
  Eigen::VectorXd p(17);
  p << 0.95, 0.9, 1.6, 1.3, 1.9, 1.4, 0.0, 0.165, 0.555, 10.0, 40.0, 2.0, 9.0, 7.0, 5.0, 4.0, 0.12;
  return p;
}

// `rows` steps of 0.02 s of kTractionBank's mode with traction_truth(),
// turning both ways from gentle to tight: the pose measured every
// `pose_every` steps with 0.02 noise, the gyro with 0.02 rad/s and the
// currents with 0.3 A at every step (seed `output_seed`).
Trajectory simulate_traction(int rows, int pose_every, unsigned output_seed) {
  Bank truth = load_bank(kTractionBank, "truth.yaml");
  EXPECT_TRUE(truth.models[0]->set_parameters(traction_truth(), nullptr));
  auto turns = [](double t) {
    const double turn = 3.0 * std::sin(0.4 * t) * std::abs(std::sin(0.05 * t));
    return Eigen::Vector2d(5.0 - turn, 5.0 + turn);
  };
  Trajectory data = simulate_model(*truth.models[0], rows, 0.02, turns, Eigen::Vector3d(1e-5, 1e-5, 1e-5),
                                   Eigen::Vector3d(0.02, 0.02, 0.02), 3, pose_every);
  std::mt19937 rng(output_seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  data.z.conservativeResize(6, Eigen::NoChange);
  Eigen::VectorXd y(3);
  for (int k = 0; k < data.size(); ++k) {
    if (!truth.models[0]->outputs(data.u.col(k), y) || y.size() != 3) {
      ADD_FAILURE() << "stc_traction gave no three outputs at row " << k;
      return data;
    }
    data.z(3, k) = y[0] + 0.02 * normal(rng);
    data.z(4, k) = y[1] + 0.3 * normal(rng);
    data.z(5, k) = y[2] + 0.3 * normal(rng);
  }
  return data;
}

// Outputs a bank measures (measurement.outputs) are fitted too: stc_traction's
// motor-current parameters, which move no state, come from the currents
// alone, and the gyro's yaw rate sharpens the ICR parameters. (From a start
// far from the truth, gains of 1 A, the fit can find the shape of the turn
// current flattened to nothing instead: start from the order of the
// currents the robot draws.)
TEST(ModelFitter, RecoversMotorCurrentParametersFromMeasuredOutputs) {
  SKIDIMM_SKIP_UNDER_SANITIZERS_STATISTICAL();
  const std::string& bank_yaml = kTractionBank;
  const Eigen::VectorXd truth_parameters = traction_truth();
  const Trajectory data = simulate_traction(6000, 5, 4);
  Bank bank = load_bank(bank_yaml);
  FitOptions options;
  options.window = 0.5;
  const FitReport report = fit(&bank, {ModeLogs{0, {data}}}, options).front();
  EXPECT_EQ(report.derivatives, "autodiff");
  ASSERT_EQ(report.parameters.size(), 15u);  // r and b are bank-level
  const int truth_index[15] = {0, 1, 2, 3, 4, 5, 6, 9, 10, 11, 12, 13, 14, 15, 16};
  for (std::size_t i = 0; i < 15; ++i) {
    const double expected = truth_parameters[truth_index[i]];
    // Within 3%, or 4 of the fit's own standard deviations where the logs
    // say less (the inner treads' ICRs: a turn's yaw rate gives their sum
    // with the outer one's).
    EXPECT_NEAR(report.parameters[i].value, expected,
                std::max(0.03 * std::max(0.5, std::abs(expected)), 4.0 * report.parameters[i].standard_deviation))
        << report.parameters[i].name;
    // Known to 10%: each tread's ICR and its growth with the turn trade off
    // against each other over the turns' range.
    EXPECT_LT(report.parameters[i].standard_deviation, 0.1 * std::max(0.5, std::abs(expected)))
        << report.parameters[i].name;
  }
  // The currents' one-step error is their noise.
  EXPECT_NEAR(report.rmse[4], 0.3, 0.03);
  EXPECT_NEAR(report.rmse[3], 0.02, 0.005);

  // With output_noise the mode gets its own R: its outputs' residual
  // variances, the state rows the bank's.
  Bank own = load_bank(bank_yaml);
  BankFitOptions bank_options;
  bank_options.objective = Objective::kWindow;
  bank_options.window = options;
  bank_options.output_noise = true;
  fit_bank(&own, {ModeLogs{0, {data}}}, bank_options);
  const Eigen::MatrixXd& r = own.config.modes[0].r;
  ASSERT_EQ(r.rows(), 6);
  EXPECT_EQ(r.topLeftCorner(3, 3), own.config.measurement.r.topLeftCorner(3, 3));
  EXPECT_NEAR(std::sqrt(r(3, 3)), 0.02, 0.005);
  EXPECT_NEAR(std::sqrt(r(4, 4)), 0.3, 0.03);
  EXPECT_NEAR(std::sqrt(r(5, 5)), 0.3, 0.03);
  EXPECT_EQ((r - Eigen::MatrixXd(r.diagonal().asDiagonal())).cwiseAbs().maxCoeff(), 0.0);
  // The likelihood objective scores modes with the bank's R: it refuses a
  // bank with a mode's own, and estimates none.
  bank_options.objective = Objective::kLikelihood;
  EXPECT_THROW(fit_bank(&own, {ModeLogs{0, {data}}}, bank_options), FitError);
  bank_options.output_noise = false;
  try {
    fit_bank(&own, {ModeLogs{0, {data}}}, bank_options);
    ADD_FAILURE() << "the likelihood objective fitted a bank with a mode's own R";
  } catch (const FitError& e) {
    EXPECT_THAT(e.what(), HasSubstr("--objective window"));
  }
}

// A measurement row the logs never give has no one-step error: its RMSE is
// NaN (reported as "not measured"), and output_noise keeps the bank's R for
// it instead of taking the missing error for a perfect prediction (a 0 here
// became R x 1e-6, a mode sure of a sensor it had never seen).
TEST(ModelFitter, ARowNeverMeasuredHasNoErrorAndKeepsTheBanksNoise) {
  Trajectory data = simulate_traction(1500, 7, 8);
  data.z.row(3).setConstant(std::numeric_limits<double>::quiet_NaN());  // no gyro
  Bank bank = load_bank(kTractionBank);
  BankFitOptions options;
  options.objective = Objective::kWindow;
  options.window.window = 0.5;
  options.output_noise = true;
  const FitReport report = fit_bank(&bank, {ModeLogs{0, {data}}}, options).at(0);
  ASSERT_EQ(report.rmse.size(), 6);
  EXPECT_TRUE(std::isnan(report.rmse[3])) << report.rmse.transpose();
  EXPECT_NEAR(report.rmse[4], 0.3, 0.05);
  const Eigen::MatrixXd& r = bank.config.modes[0].r;
  EXPECT_EQ(r(3, 3), bank.config.measurement.r(3, 3));
  EXPECT_NEAR(std::sqrt(r(4, 4)), 0.3, 0.05);
  EXPECT_THAT(measurement_values_text(bank.config, report.rmse),
              HasSubstr(bank.config.measurement.names[3] + " not measured"));
}

// A mode with its own R (R: in its entry) has its residuals weighed by it,
// the noise its filter assumes: fitting it is fitting the same mode in a bank
// whose R is that one. Here its own R trusts the gyro and the currents far
// less than the bank's does, which moves the fit.
TEST(ModelFitter, AModesOwnMeasurementNoiseWeighsItsResiduals) {
  const Trajectory data = simulate_traction(1500, 7, 8);
  Eigen::VectorXd own_std(6);
  own_std << 0.02, 0.02, 0.02, 2.0, 30.0, 30.0;
  const Eigen::MatrixXd own_r = own_std.cwiseAbs2().asDiagonal();
  Bank with_own = load_bank(kTractionBank);
  with_own.config.modes[0].r = own_r;
  Bank bank_wide = load_bank(kTractionBank);
  bank_wide.config.measurement.r = own_r;
  Bank bank_r = load_bank(kTractionBank);
  FitOptions options;
  options.window = 0.5;
  const FitReport own = fit(&with_own, {ModeLogs{0, {data}}}, options).front();
  const FitReport wide = fit(&bank_wide, {ModeLogs{0, {data}}}, options).front();
  const FitReport plain = fit(&bank_r, {ModeLogs{0, {data}}}, options).front();
  ASSERT_EQ(own.parameters.size(), wide.parameters.size());
  double moved = 0.0;
  for (std::size_t i = 0; i < own.parameters.size(); ++i) {
    EXPECT_NEAR(own.parameters[i].value, wide.parameters[i].value,
                1e-9 * std::max(1.0, std::abs(wide.parameters[i].value)))
        << own.parameters[i].name;
    moved = std::max(moved, std::abs(own.parameters[i].value - plain.parameters[i].value));
  }
  EXPECT_GT(moved, 1e-3) << "weighed by the bank's R the fit is another one";
  EXPECT_EQ(own.q_intensity, wide.q_intensity);
}

TEST(ModelFitter, FitsSharedParametersJointlyAndAProcessNoisePerMode) {
  SKIDIMM_SKIP_UNDER_SANITIZERS_STATISTICAL();
  const std::string bank_yaml = R"(name: shared
states: [V, omega]
inputs: [phi_dot_L, phi_dot_R]
measurement: {observe: [V, omega], R: {std: [0.01, 0.01]}}
transition: {stay: 0.99}
initial: {covariance: {std: [1, 1]}}
shared: {A: [[-1, 0], [0, -1]], B: [[0.1, 0.1], [-0.1, 0.1]]}
modes:
  - {name: smooth, model: ltc_shared, Q: {diagonal: [0.01, 0.01]}}
  - {name: rough, model: ltc_shared, Q: {diagonal: [0.01, 0.01]}}
)";
  Bank truth = load_bank(bank_yaml, "truth.yaml");
  Eigen::VectorXd true_parameters(8);
  true_parameters << -5.0, 0.0, 0.0, -4.0, 0.4, 0.4, -0.8, 0.8;
  ASSERT_TRUE(truth.models[0]->set_parameters(true_parameters, nullptr));
  const Trajectory smooth = simulate_model(*truth.models[0], 6000, 0.02, rich_wheel_speeds,
                                           Eigen::Vector2d(0.002, 0.002), Eigen::Vector2d(0.01, 0.01), 3);
  const Trajectory rough = simulate_model(*truth.models[0], 6000, 0.02, rich_wheel_speeds, Eigen::Vector2d(0.05, 0.05),
                                          Eigen::Vector2d(0.01, 0.01), 4);
  Bank bank = load_bank(bank_yaml);
  FitOptions options;
  options.window = 0.2;  // s: 10 rows at 50 Hz
  options.scope = sdk::ParameterScope::kBank;
  const std::vector<FitReport> reports = fit(&bank, {ModeLogs{0, {smooth}}, ModeLogs{1, {rough}}}, options);
  Eigen::VectorXd a(8), b(8);
  bank.models[0]->get_parameters(a);
  bank.models[1]->get_parameters(b);
  EXPECT_EQ(a, b) << "one A, B for the whole bank";
  for (int i = 0; i < 8; ++i) EXPECT_NEAR(a[i], true_parameters[i], 0.1 * std::max(1.0, std::abs(true_parameters[i])));
  // Each mode's Q reflects its own logs' process noise, within a factor of 2.
  for (int s = 0; s < 2; ++s) {
    EXPECT_NEAR(std::log(reports[0].q_intensity(s, s)), std::log(0.002), std::log(2.0)) << "smooth, state " << s;
    EXPECT_NEAR(std::log(reports[1].q_intensity(s, s)), std::log(0.05), std::log(2.0)) << "rough, state " << s;
  }
}

TEST(ModelFitter, ANonFinitePredictionNamesItsStepInsteadOfFittingInfinity) {
  Bank truth = load_bank(kLtcBank, "truth.yaml");
  Trajectory data = simulate_model(*truth.models[0], 500, 0.02, rich_wheel_speeds, Eigen::Vector2d(1e-4, 1e-4),
                                   Eigen::Vector2d(0.01, 0.01), 1);
  data.u(0, 200) = 1e200;  // a corrupt cell
  Bank bank = load_bank(kLtcBank);
  FitOptions options;
  options.window = 0.2;
  try {
    fit(&bank, {ModeLogs{0, {data}}}, options);
    FAIL();
  } catch (const FitError& e) {
    EXPECT_THAT(e.what(), HasSubstr("simulated: the prediction from step"));
    EXPECT_THAT(e.what(), HasSubstr("is not finite (or absurd) with the starting values of mode 'a'"));
  }
}

TEST(ModelFitter, TooShortALogIsAnError) {
  Bank truth = load_bank(kLtcBank, "truth.yaml");
  const Trajectory data = simulate_model(*truth.models[0], 4, 0.02, rich_wheel_speeds, Eigen::Vector2d(0, 0),
                                         Eigen::Vector2d(0.02, 0.02), 1);
  Bank bank = load_bank(kLtcBank);
  try {
    fit(&bank, {ModeLogs{0, {data}}}, FitOptions{});
    FAIL();
  } catch (const FitError& e) {
    EXPECT_THAT(e.what(), HasSubstr("the logs are too short: 6 residuals for 8 parameters"));
  }
}

TEST(ModelFitter, DrivingStraightDoesNotExciteTheYawParameters) {
  Bank truth = load_bank(kLtcBank, "truth.yaml");
  auto straight = [](double t) { return Eigen::Vector2d(4.0 + std::sin(t), 4.0 + std::sin(t)); };
  const Trajectory data =
      simulate_model(*truth.models[0], 1000, 0.02, straight, Eigen::Vector2d(0, 0), Eigen::Vector2d(0.02, 0.02), 1);
  Bank bank = load_bank(kLtcBank);
  try {
    fit(&bank, {ModeLogs{0, {data}}}, FitOptions{});
    FAIL() << "a straight run cannot determine how the robot turns";
  } catch (const FitError& e) {
    EXPECT_THAT(e.what(), HasSubstr("the logs do not excite every parameter"));
    // Equal wheel speeds cannot separate the left and right input gains of
    // either row: both combinations are named.
    EXPECT_THAT(e.what(), HasSubstr("[B[1,0], B[1,1]]"));
    EXPECT_THAT(e.what(), HasSubstr("[B[0,0], B[0,1]]"));
    // What they are, from the model's own description of B, said once for its four entries.
    EXPECT_THAT(e.what(), HasSubstr(". What they are: B[1,0], B[1,1], B[0,0], B[0,1]: input matrix: row V in m/rad/s, "
                                    "row omega in 1/s"));
  }
}

// A long log's windows condensed into one residual block (memory that does
// not grow with the log) give the solver the same cost, gradient and
// Gauss-Newton matrix as one block per window: the same fit, to round-off,
// with each loss (the robust ones active: a few outliers), one-step and
// multi-step, and the same parameters held when the logs do not excite them.
TEST(ModelFitter, CondensedWindowsReachTheWindowsOwnFit) {
  Bank truth = load_bank(kLtcBank, "truth.yaml");
  Eigen::VectorXd true_parameters(8);
  true_parameters << -4.0, 0.3, 0.2, -3.0, 0.35, 0.3, -0.7, 0.75;
  ASSERT_TRUE(truth.models[0]->set_parameters(true_parameters, nullptr));
  Trajectory data = simulate_model(*truth.models[0], 2000, 0.02, rich_wheel_speeds, Eigen::Vector2d(1e-4, 1e-4),
                                   Eigen::Vector2d(0.01, 0.01), 7);
  for (int k = 100; k < 2000; k += 150) data.z(k % 2, k) += 0.3;  // 30 sigma
  auto straight = [](double t) { return Eigen::Vector2d(4.0 + std::sin(t), 4.0 + std::sin(t)); };
  const Trajectory straight_data =
      simulate_model(*truth.models[0], 1000, 0.02, straight, Eigen::Vector2d(0, 0), Eigen::Vector2d(0.02, 0.02), 1);
  struct Case {
    std::string loss;
    double window;
    const Trajectory* data;
  };
  std::vector<Case> cases = {Case{"huber", 0.0, &data}, Case{"cauchy", 0.0, &data}, Case{"none", 0.0, &data},
                             Case{"huber", 0.2, &data}, Case{"huber", 0.0, &straight_data}};
  // Under the sanitizers the first case runs the condensed block's code; the
  // other losses and windows are arithmetic the Release suite checks.
  if (SKIDIMM_SANITIZED) cases.resize(1);
  for (const Case& c : cases) {
    SCOPED_TRACE(c.loss + ", window " + std::to_string(c.window) + (c.data == &data ? "" : ", driving straight"));
    FitOptions options;
    options.loss = c.loss;
    options.loss_scale = 1.0;
    options.window = c.window;
    options.hold_unexcited = true;
    Bank windows_bank = load_bank(kLtcBank);
    options.condense_above = std::numeric_limits<long>::max();
    const FitReport windows = fit(&windows_bank, {ModeLogs{0, {*c.data}}}, options).front();
    Bank condensed_bank = load_bank(kLtcBank);
    options.condense_above = 0;
    const FitReport condensed = fit(&condensed_bank, {ModeLogs{0, {*c.data}}}, options).front();
    ASSERT_EQ(condensed.parameters.size(), windows.parameters.size());
    for (std::size_t i = 0; i < windows.parameters.size(); ++i) {
      const ParameterEstimate& a = windows.parameters[i];
      const ParameterEstimate& b = condensed.parameters[i];
      EXPECT_NEAR(b.value, a.value, 1e-6 * std::max(1.0, std::abs(a.value))) << a.name;
      EXPECT_EQ(std::isnan(b.standard_deviation), std::isnan(a.standard_deviation)) << a.name << " held in one only";
      if (!std::isnan(a.standard_deviation)) {
        EXPECT_NEAR(b.standard_deviation, a.standard_deviation, 1e-5 * a.standard_deviation) << a.name;
      }
    }
    EXPECT_EQ(condensed.residuals, windows.residuals);
    EXPECT_NEAR(condensed.initial_cost, windows.initial_cost, 1e-9 * windows.initial_cost);
    EXPECT_NEAR(condensed.final_cost, windows.final_cost, 1e-8 * windows.final_cost);
    EXPECT_NEAR(condensed.condition_number, windows.condition_number, 1e-5 * windows.condition_number);
    EXPECT_EQ(condensed.warnings, windows.warnings);
  }
}

// The LTC bank fitted to `data` from its starting values, holding what the
// data do not excite: the parameters before and after, and the report.
struct HeldFit {
  Eigen::VectorXd start, fitted;
  FitReport report;
};
HeldFit fit_holding_unexcited(const Trajectory& data) {
  Bank bank = load_bank(kLtcBank);
  HeldFit out{Eigen::VectorXd(8), Eigen::VectorXd(8), {}};
  bank.models[0]->get_parameters(out.start);
  FitOptions options;
  options.hold_unexcited = true;
  out.report = fit(&bank, {ModeLogs{0, {data}}}, options).front();
  bank.models[0]->get_parameters(out.fitted);
  return out;
}

TEST(ModelFitter, HoldingUnexcitedParametersFitsTheRest) {
  Bank truth = load_bank(kLtcBank, "truth.yaml");
  auto straight = [](double t) { return Eigen::Vector2d(4.0 + std::sin(t), 4.0 + std::sin(t)); };
  const Trajectory data =
      simulate_model(*truth.models[0], 1000, 0.02, straight, Eigen::Vector2d(0, 0), Eigen::Vector2d(0.02, 0.02), 1);
  const auto [start, fitted, report] = fit_holding_unexcited(data);
  // Equal wheel speeds see only each row's sum B[r,0] + B[r,1]: their
  // difference is held where it started, so both gains move by the same
  // amount (the least move from the start that fits), and their sum is fitted.
  Eigen::VectorXd true_parameters(8);
  truth.models[0]->get_parameters(true_parameters);
  for (int row : {4, 6}) {
    const std::string& name = report.parameters[static_cast<std::size_t>(row)].name;
    const double move = fitted[row] - start[row];
    EXPECT_GT(std::abs(move), 1e-3) << name << " carries half the fitted sum";
    EXPECT_NEAR(fitted[row + 1] - start[row + 1], move, 1e-9 * std::abs(move)) << name << " and its twin move alike";
    const int a = row == 4 ? 0 : 3;  // A[0,0] or A[1,1]
    EXPECT_NEAR((fitted[row] + fitted[row + 1]) / -fitted[a],
                (true_parameters[row] + true_parameters[row + 1]) / -true_parameters[a], 0.02)
        << "the sum's steady-state gain is what the logs determine";
    // Each gain is half in the held direction, half in the fitted sum: its
    // deviation is the sum's, halved in variance, and equal for the two.
    const double sd = report.parameters[static_cast<std::size_t>(row)].standard_deviation;
    EXPECT_TRUE(std::isfinite(sd)) << name;
    EXPECT_NEAR(report.parameters[static_cast<std::size_t>(row + 1)].standard_deviation, sd, 1e-6 * sd) << name;
  }
  EXPECT_NE(fitted[0], start[0]) << "A[0,0] is still fitted";
  // Two unexcited directions with the same (zero) singular value: the SVD
  // may return any basis of them, so the warnings name what it returned;
  // the fit above does not depend on it.
  int combinations = 0;
  for (const std::string& w : report.warnings) {
    combinations += w.find("the logs do not excite a combination of B[") != std::string::npos &&
                    w.find("it is held where it started") != std::string::npos;
    EXPECT_THAT(w, Not(HasSubstr("is held at its starting value"))) << "no gain is held whole";
  }
  EXPECT_EQ(combinations, 2);
}

// A parameter the logs do not move at all is held whole at its start: no
// deviation, and a warning names it alone. Standing still (both wheel
// speeds zero), no input gain acts, and only the process noise moves the
// state through A.
TEST(ModelFitter, ParametersTheLogsNeverMoveAreHeldWholeAtTheirStart) {
  Bank truth = load_bank(kLtcBank, "truth.yaml");
  auto still = [](double) { return Eigen::Vector2d(0.0, 0.0); };
  const Trajectory data = simulate_model(*truth.models[0], 1500, 0.02, still, Eigen::Vector2d(1e-2, 1e-2),
                                         Eigen::Vector2d(0.005, 0.005), 3);
  const auto [start, fitted, report] = fit_holding_unexcited(data);
  int held = 0;
  for (const std::string& w : report.warnings) {
    held += w.find("is held at its starting value") != std::string::npos;
    EXPECT_THAT(w, Not(HasSubstr("a combination of")));
  }
  EXPECT_EQ(held, 4);
  for (int i = 4; i < 8; ++i) {
    const ParameterEstimate& b = report.parameters[static_cast<std::size_t>(i)];
    EXPECT_EQ(fitted[i], start[i]) << b.name;
    EXPECT_TRUE(std::isnan(b.standard_deviation)) << b.name;
    EXPECT_THAT(report.warnings, Contains(HasSubstr("parameter '" + b.name + "' is held at its starting value")));
  }
  for (int i : {0, 3}) {
    EXPECT_NE(fitted[i], start[i]) << "A's diagonal is fitted";
    EXPECT_TRUE(std::isfinite(report.parameters[static_cast<std::size_t>(i)].standard_deviation));
  }
}

TEST(ModelFitter, CorrelatedProcessNoiseTakesTheOneStepErrorsCorrelation) {
  Bank truth = load_bank(kLtcBank, "truth.yaml");
  const sdk::MotionModel& model = *truth.models[0];
  // V and omega driven by process noise correlated at 0.8; R small against it.
  const double dt = 0.02, q_v = 0.04, q_omega = 0.09, rho = 0.8;
  Eigen::Matrix2d q;
  q << q_v, rho * std::sqrt(q_v * q_omega), rho * std::sqrt(q_v * q_omega), q_omega;
  const Eigen::Matrix2d l = Eigen::LLT<Eigen::Matrix2d>(q * dt).matrixL();
  std::mt19937 rng(5);
  std::normal_distribution<double> normal(0.0, 1.0);
  Trajectory t;
  t.source = "simulated";
  const int rows = 20000;
  t.u.resize(2, rows);
  t.z.resize(2, rows);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(2), next(2);
  for (int k = 0; k < rows; ++k) {
    t.t.push_back(k * dt);
    t.u.col(k) = Eigen::Vector2d(3.0 + std::sin(0.3 * k * dt), 3.0 + std::cos(0.2 * k * dt));
    for (int i = 0; i < 2; ++i) t.z(i, k) = x[i] + 1e-3 * normal(rng);
    model.predict(x, t.u.col(k), dt, next);
    const double w0 = normal(rng), w1 = normal(rng);  // in this order, whatever the compiler
    x = next + l * Eigen::Vector2d(w0, w1);
  }
  std::string yaml = kLtcBank;
  yaml.replace(yaml.find("R: {std: [0.02, 0.02]}"), 22, "R: {std: [0.001, 0.001]}");
  Bank bank = load_bank(yaml);
  const FitReport diagonal = evaluate(bank, ModeLogs{0, {t}});
  const FitReport correlated = evaluate(bank, ModeLogs{0, {t}}, /*correlated=*/true);
  EXPECT_EQ(diagonal.q_intensity(0, 1), 0.0);
  EXPECT_NEAR(correlated.q_intensity(0, 0), diagonal.q_intensity(0, 0), 1e-12) << "the diagonal is unchanged";
  EXPECT_NEAR(correlated.q_intensity(1, 1), diagonal.q_intensity(1, 1), 1e-12);
  EXPECT_NEAR(correlated.q_intensity(0, 0), q_v, 0.1 * q_v);
  EXPECT_NEAR(correlated.q_intensity(1, 1), q_omega, 0.1 * q_omega);
  const double fitted_rho =
      correlated.q_intensity(0, 1) / std::sqrt(correlated.q_intensity(0, 0) * correlated.q_intensity(1, 1));
  EXPECT_NEAR(fitted_rho, rho, 0.03);
  EXPECT_EQ(correlated.q_intensity(0, 1), correlated.q_intensity(1, 0));
}

TEST(ModelFitter, EveryStateMustBeMeasured) {
  std::string yaml = kLtcBank;
  yaml.replace(yaml.find("observe: [V, omega], R: {std: [0.02, 0.02]}"), 43, "observe: [V], R: {std: [0.02]}");
  Bank bank = load_bank(yaml);
  Trajectory data;
  EXPECT_THROW(
      {
        try {
          fit(&bank, {ModeLogs{0, {data}}}, FitOptions{});
        } catch (const FitError& e) {
          EXPECT_THAT(e.what(), HasSubstr("does not measure [omega] directly"));
          throw;
        }
      },
      FitError);
}

TEST(ModelFitter, LogsWithMissingColumnsOrNonFiniteValuesAreRejected) {
  const auto dir = test_directory();
  const BankConfig config = load_bank_config(write_file(dir / "bank.yaml", kLtcBank));
  EXPECT_THROW(load_trajectory(config, {write_file(dir / "a.csv", "t,phi_dot_L,phi_dot_R,V\n0,1,1,0\n")}), LogError);
  try {
    load_trajectory(config, {write_file(dir / "b.csv", "t,phi_dot_L,phi_dot_R,V,omega\n0,1,1,0,0\n0.1,1,1,inf,0\n")});
    FAIL();
  } catch (const LogError& e) {
    EXPECT_THAT(e.what(), HasSubstr("b.csv:3: column 4 ('V'): expected a finite number"));
  }
}

}  // namespace
}  // namespace fitting
}  // namespace skidimm
