#include "skidimm/fitting/likelihood_fitter.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <cmath>
#include <filesystem>
#include <functional>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "core/sanitizer.h"
#include "core/temp_files.h"
#include "core/test_banks.h"
#include "fitting/simulated_logs.h"
#include "skidimm/engine/ekf.h"
#include "skidimm/engine/imm.h"
#include "skidimm/engine/measurement_model.h"
#include "skidimm/fitting/model_fitter.h"
#include "skidimm/sdk/angles.h"
#include "skidimm/sdk/failure.h"
#include "stc_kinematic/stc_kinematic_model.h"

namespace skidimm {
namespace fitting {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
using Options = LikelihoodFitOptions;
using skidimm_test::rich_wheel_speeds;
using skidimm_test::simulate;

// x+ = x + (A x + B u) dt (the forward-Euler step of eq. 1), whose free
// entries of A and B (row-major, A first) are the model's parameters and the
// others fixed, so that a test can write down an identifiable structure (a
// latent state needs one entry fixed: scaling it would otherwise change
// nothing one can measure). With `exact`, parameter_jacobian() gives
// d x+ / d A_ij = dt x_j e_i and d x+ / d B_ij = dt u_j e_i; without, it
// returns false and the fitter differentiates predict().
class MaskedLinearModel : public sdk::MotionModel {
 public:
  MaskedLinearModel(Eigen::MatrixXd a, Eigen::MatrixXd b, Eigen::MatrixXi a_free, Eigen::MatrixXi b_free, bool exact)
      : a_(std::move(a)), b_(std::move(b)), a_free_(std::move(a_free)), b_free_(std::move(b_free)), exact_(exact) {
    for (int i = 0; i < a_.rows(); ++i) states_.push_back("x" + std::to_string(i));
    for (int j = 0; j < b_.cols(); ++j) inputs_.push_back("u" + std::to_string(j));
    for (int i = 0; i < a_.rows(); ++i) {
      for (int j = 0; j < a_.cols(); ++j) {
        if (a_free_(i, j)) add("A", i, j);
      }
    }
    for (int i = 0; i < b_.rows(); ++i) {
      for (int j = 0; j < b_.cols(); ++j) {
        if (b_free_(i, j)) add("B", i, j);
      }
    }
  }
  int state_dim() const noexcept override { return static_cast<int>(a_.rows()); }
  int input_dim() const noexcept override { return static_cast<int>(b_.cols()); }
  const std::vector<std::string>& state_names() const noexcept override { return states_; }
  const std::vector<std::string>& input_names() const noexcept override { return inputs_; }
  const std::vector<sdk::ParameterInfo>& parameter_info() const noexcept override { return info_; }
  void get_parameters(Eigen::Ref<Eigen::VectorXd> values) const noexcept override {
    int at = 0;
    for_each_free([&](bool is_a, int i, int j) { values[at++] = is_a ? a_(i, j) : b_(i, j); });
  }
  bool set_parameters(const Eigen::Ref<const Eigen::VectorXd>& values, std::string* error) noexcept override {
    if (!sdk::check_parameter_values(info_, values, error)) return false;
    int at = 0;
    for_each_free([&](bool is_a, int i, int j) { (is_a ? a_(i, j) : b_(i, j)) = values[at++]; });
    return true;
  }
  bool predict(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
               Eigen::Ref<Eigen::VectorXd> x_next) const noexcept override {
    x_next = x + (a_ * x + b_ * u) * dt;
    return x_next.allFinite();
  }
  bool jacobian(const Eigen::Ref<const Eigen::VectorXd>&, const Eigen::Ref<const Eigen::VectorXd>&, double dt,
                Eigen::Ref<Eigen::MatrixXd> jacobian) const noexcept override {
    jacobian = Eigen::MatrixXd::Identity(a_.rows(), a_.rows()) + a_ * dt;
    return true;
  }
  bool has_analytic_jacobian() const noexcept override { return true; }
  bool parameter_jacobian(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u,
                          double dt, Eigen::Ref<Eigen::MatrixXd> jacobian) const noexcept override {
    if (!exact_) return false;
    jacobian.setZero();
    int at = 0;
    for_each_free([&](bool is_a, int i, int j) { jacobian(i, at++) = dt * (is_a ? x[j] : u[j]); });
    return true;
  }

 private:
  void add(const std::string& key, int i, int j) {
    sdk::ParameterInfo p;
    p.name = key + "[" + std::to_string(i) + "," + std::to_string(j) + "]";
    p.key = key;
    info_.push_back(p);
  }
  template <typename F>
  void for_each_free(F&& f) const {
    for (int i = 0; i < a_.rows(); ++i) {
      for (int j = 0; j < a_.cols(); ++j) {
        if (a_free_(i, j)) f(true, i, j);
      }
    }
    for (int i = 0; i < b_.rows(); ++i) {
      for (int j = 0; j < b_.cols(); ++j) {
        if (b_free_(i, j)) f(false, i, j);
      }
    }
  }
  Eigen::MatrixXd a_, b_;
  Eigen::MatrixXi a_free_, b_free_;
  bool exact_;
  std::vector<std::string> states_, inputs_;
  std::vector<sdk::ParameterInfo> info_;
};

// A bank of one or more modes around in-process models, with diagonal Q and R.
Bank make_bank(std::vector<std::shared_ptr<sdk::MotionModel>> models, const std::vector<Eigen::MatrixXd>& q,
               const Eigen::MatrixXd& h, const Eigen::MatrixXd& r, std::vector<bool> angles = {}) {
  skidimm_test::BankBuilder builder;
  const int n = models.front()->state_dim();
  builder.states = models.front()->state_names();
  builder.inputs = models.front()->input_names();
  builder.angles = angles.empty() ? std::vector<bool>(static_cast<std::size_t>(n), false) : angles;
  builder.models = std::move(models);
  builder.q = q;
  builder.h = h;
  builder.r = r;
  Bank bank = builder.build();
  // BankBuilder marks angle rows only for H = I; do it for any H that picks an angle state alone.
  for (Eigen::Index c = 0; c < h.rows(); ++c) {
    for (int i = 0; i < n; ++i) {
      if (h(c, i) == 1.0 && h.row(c).cwiseAbs().sum() == 1.0 && builder.angles[static_cast<std::size_t>(i)]) {
        bank.config.measurement.is_angle[static_cast<std::size_t>(c)] = true;
      }
    }
  }
  return bank;
}

std::shared_ptr<sdk::MotionModel> make_stc(double k, double m) {
  sdk::ParameterSet params;
  params.set_scalar("k", k);
  params.set_scalar("m", m);
  params.set_scalar("r", 0.165);
  params.set_scalar("b", 0.555);
  std::string error;
  return std::shared_ptr<sdk::MotionModel>(plugins::StcKinematicModel::Create(params, &error).release());
}

Eigen::MatrixXd diagonal(std::initializer_list<double> values) {
  Eigen::VectorXd v(static_cast<Eigen::Index>(values.size()));
  int i = 0;
  for (double value : values) v[i++] = value;
  return v.asDiagonal();
}

// An STC log that circles through +-pi several times, GPS (X, Y) every fifth
// row, heading every row but a few, and some rows with nothing at all.
struct StcCase {
  Bank bank;
  Trajectory log;
};

StcCase stc_case(int rows) {
  auto model = make_stc(0.9, 0.6);
  auto turning = [](double t) { return Eigen::Vector2d(4.0 + 2.0 * std::sin(0.3 * t), 6.0 + 1.5 * std::cos(0.5 * t)); };
  const Eigen::MatrixXd q = diagonal({1e-3, 2e-3, 5e-4});
  const Eigen::MatrixXd r = diagonal({0.02 * 0.02, 0.03 * 0.03, 0.01 * 0.01});
  Trajectory log = simulate(*model, q, Eigen::MatrixXd::Identity(3, 3), r, rows, 0.05, turning, 7,
                            [](int k, int c) { return k % 13 != 5 && (c == 2 ? k % 7 != 3 : k % 5 == 0); });
  Bank bank = make_bank({make_stc(0.8, 0.7)}, {diagonal({2e-3, 1e-3, 1e-3})}, Eigen::MatrixXd::Identity(3, 3),
                        diagonal({0.03 * 0.03, 0.02 * 0.02, 0.015 * 0.015}), {false, false, true});
  bank.config.initial_state = Eigen::Vector3d(0.05, -0.05, 0.1);
  bank.config.initial_covariance = diagonal({0.1, 0.1, 0.05});
  return {std::move(bank), std::move(log)};
}

TEST(LikelihoodFitter, NllIsTheSumOfTheEnginesLogLikelihoodsWithMissingRowsAndAnAngle) {
  StcCase c = stc_case(1500);
  const Trajectory& log = c.log;
  // The heading wraps several times, and some rows are predict-only.
  int wraps = 0, empty_rows = 0;
  double last_heading = std::nan("");
  for (int k = 0; k < log.size(); ++k) {
    if (std::isfinite(log.z(2, k))) {
      if (std::abs(log.z(2, k) - last_heading) > 3.0) ++wraps;
      last_heading = log.z(2, k);
    }
    empty_rows += log.z.col(k).array().isFinite().any() ? 0 : 1;
  }
  ASSERT_GE(wraps, 3);
  ASSERT_GT(empty_rows, 50);

  const LikelihoodEvaluation e = evaluate_likelihood(c.bank, ModeLogs{0, {log}});
  ASSERT_TRUE(e.failure.empty()) << e.failure;

  // The engine's own filter, step by step.
  const BankConfig& config = c.bank.config;
  ExtendedKalmanFilter ekf(*c.bank.models[0], config.modes[0].q_intensity, 3);
  const MeasurementModel measurement(config.measurement.h, config.measurement.r, config.measurement.is_angle);
  SelectedMeasurement selected = measurement.make_selection();
  ekf.state() = config.initial_state;
  ekf.covariance() = config.initial_covariance;
  double ekf_sum = 0.0;
  int measured_rows = 0;
  for (int k = 0; k < log.size(); ++k) {
    if (k > 0) {
      ASSERT_TRUE(ekf.predict(log.u.col(k - 1), log.t[k] - log.t[k - 1]));
    }
    measurement.select(log.z.col(k), &selected);
    if (selected.size == 0) {
      EXPECT_TRUE(std::isnan(e.row_terms[0][k])) << "row " << k;
      continue;
    }
    const UpdateResult result = ekf.update(selected);
    ASSERT_TRUE(result.ok);
    ekf_sum += result.log_likelihood;
    ++measured_rows;
    EXPECT_NEAR(e.row_terms[0][k], -result.log_likelihood, 1e-9) << "row " << k;
  }
  EXPECT_NEAR(e.negative_log_likelihood, -ekf_sum, 1e-9 * std::max(1.0, std::abs(ekf_sum)));
  EXPECT_EQ(e.measured_rows, measured_rows);

  // And a one-mode IMM.
  Imm imm(c.bank);
  double imm_sum = 0.0;
  for (int k = 0; k < log.size(); ++k) {
    const ImmEstimate& estimate = imm.step(log.t[k], log.u.col(k), log.z.col(k));
    if (estimate.status == StepStatus::kUpdated) imm_sum += estimate.log_likelihoods[0];
  }
  EXPECT_NEAR(e.negative_log_likelihood, -imm_sum, 1e-9 * std::max(1.0, std::abs(imm_sum)));
  std::cout << "NLL " << e.negative_log_likelihood << ", EKF " << -ekf_sum << ", IMM " << -imm_sum << " over "
            << measured_rows << " measured rows\n";
}

// d NLL / d parameter by a four-point central difference (error O(h^4)),
// with `set` writing one natural parameter into the bank.
double numeric_derivative(Bank* bank, const ModeLogs& data, double value,
                          const std::function<void(Bank*, double)>& set) {
  const double h = 1e-3 * std::max(std::abs(value), 1e-3);
  auto nll = [&](double v) {
    set(bank, v);
    return evaluate_likelihood(*bank, data).negative_log_likelihood;
  };
  const double d = (8.0 * (nll(value + h) - nll(value - h)) - (nll(value + 2 * h) - nll(value - 2 * h))) / (12.0 * h);
  set(bank, value);
  return d;
}

// Checks evaluate_likelihood_derivatives() against numeric_derivative() for
// every parameter `options` selects; returns the largest relative error.
double check_gradient(Bank* bank, const ModeLogs& data, const Options& options) {
  const LikelihoodEvaluation e = evaluate_likelihood_derivatives(bank, data, options);
  EXPECT_TRUE(e.failure.empty()) << e.failure;
  const int mode = data.mode;
  sdk::MotionModel& model = *bank->models[static_cast<std::size_t>(mode)];
  const int n = model.state_dim();
  Eigen::VectorXd parameters(static_cast<Eigen::Index>(model.parameter_info().size()));
  model.get_parameters(parameters);
  std::vector<double> numeric;
  if (options.fit_model_parameters) {
    for (Eigen::Index i = 0; i < parameters.size(); ++i) {
      if (model.parameter_info()[static_cast<std::size_t>(i)].scope != sdk::ParameterScope::kMode) continue;
      numeric.push_back(numeric_derivative(bank, data, parameters[i], [&](Bank* b, double v) {
        Eigen::VectorXd p = parameters;
        p[i] = v;
        ASSERT_TRUE(b->models[static_cast<std::size_t>(mode)]->set_parameters(p, nullptr));
      }));
    }
  }
  Eigen::MatrixXd& q = bank->config.modes[static_cast<std::size_t>(mode)].q_intensity;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j <= i; ++j) {
      if (options.process_noise == Options::ProcessNoise::kKeep) continue;
      if (options.process_noise == Options::ProcessNoise::kDiagonal && i != j) continue;
      numeric.push_back(numeric_derivative(bank, data, q(i, j), [&](Bank*, double v) { q(i, j) = q(j, i) = v; }));
    }
  }
  if (options.fit_measurement_noise) {
    Eigen::MatrixXd& r = bank->config.measurement.r;
    for (Eigen::Index c = 0; c < r.rows(); ++c) {
      numeric.push_back(numeric_derivative(bank, data, r(c, c), [&](Bank*, double v) { r(c, c) = v; }));
    }
  }
  EXPECT_EQ(static_cast<std::size_t>(e.gradient.size()), numeric.size());
  double worst = 0.0;
  std::string worst_name;
  for (std::size_t i = 0; i < numeric.size() && i < static_cast<std::size_t>(e.gradient.size()); ++i) {
    const double exact = e.gradient[static_cast<Eigen::Index>(i)];
    const double error = std::abs(exact - numeric[i]) / std::max(std::abs(numeric[i]), 1e-6);
    if (error > worst) {
      worst = error;
      worst_name = e.parameter_names[i];
    }
    EXPECT_LT(error, 1e-5) << e.parameter_names[i] << ": sensitivities " << exact << ", differences " << numeric[i];
  }
  std::cout << "  " << numeric.size() << " parameters, largest relative error " << worst << " (" << worst_name << ")\n";
  return worst;
}

TEST(LikelihoodFitter, GradientMatchesDifferencesOfTheNllForALinearModel) {
  Eigen::Matrix2d a, b;
  a << -4.0, 0.3, 0.2, -3.0;
  b << 0.35, 0.3, -0.7, 0.75;
  auto truth = skidimm_test::make_ltc(a, b);
  const Eigen::MatrixXd q = diagonal({2e-3, 3e-3});
  const Eigen::MatrixXd r = diagonal({1e-4, 2e-4});
  Trajectory log = simulate(*truth, q, Eigen::MatrixXd::Identity(2, 2), r, 400, 0.02, rich_wheel_speeds, 3,
                            [](int k, int c) { return c == 1 || k % 3 == 0; });
  a(0, 0) = -3.0;
  b(1, 1) = 0.6;
  Bank bank = make_bank({skidimm_test::make_ltc(a, b)}, {diagonal({1e-3, 5e-3})}, Eigen::MatrixXd::Identity(2, 2),
                        diagonal({2e-4, 1e-4}));
  const ModeLogs data{0, {log}};
  Options options;
  options.fit_measurement_noise = true;
  const double diagonal_error = check_gradient(&bank, data, options);
  options.process_noise = Options::ProcessNoise::kFull;
  bank.config.modes[0].q_intensity(0, 1) = bank.config.modes[0].q_intensity(1, 0) = 5e-4;
  const double full_error = check_gradient(&bank, data, options);
  std::cout << "largest relative gradient error: diagonal Q " << diagonal_error << ", full Q " << full_error << "\n";
}

TEST(LikelihoodFitter, GradientMatchesDifferencesOfTheNllForANonlinearModelWithAnAngle) {
  StcCase c = stc_case(600);
  Options options;
  options.fit_measurement_noise = true;
  const double exact_error = check_gradient(&c.bank, ModeLogs{0, {c.log}}, options);
  options.numeric_derivatives = true;
  const double numeric_error = check_gradient(&c.bank, ModeLogs{0, {c.log}}, options);
  std::cout << "largest relative gradient error: parameter_jacobian " << exact_error << ", differences of predict() "
            << numeric_error << "\n";
}

// linear_features with a full A: its process noise is the exact
// discretisation int expm(As) Q expm(As)' ds, so Qd depends on A too, and
// its steps do not depend on x or u (their derivatives are reused between
// rows of equal dt). One log on a fixed grid, one with irregular steps.
TEST(LikelihoodFitter, GradientMatchesDifferencesWhenQdDependsOnTheParameters) {
  const std::string yaml = R"(name: three
states: [a, b, c]
inputs: [u]
measurement: {observe: [a, c], R: {std: [0.05, 0.03]}}
transition: {stay: 0.99}
initial: {covariance: {std: [1, 1, 1]}}
modes:
  - name: full
    model: linear_features
    params: {A: [[-1.5, 0.4, 0], [0.3, -2, 0.5], [0, 0.6, -0.8]], B: [[1], [0.5], [-0.2]], c: [0.1, 0, -0.1]}
    Q: {diagonal: [0.02, 0.05, 0.01]}
)";
  Bank bank =
      Bank::load(skidimm_test::write_file(skidimm_test::test_directory() / "three.yaml", yaml), {SKIDIMM_PLUGIN_DIR});
  const Eigen::MatrixXd h = (Eigen::MatrixXd(2, 3) << 1, 0, 0, 0, 0, 1).finished();
  auto input = [](double t) { return Eigen::VectorXd::Constant(1, std::sin(0.8 * t) + 0.5 * std::cos(2.9 * t)); };
  const Trajectory grid = simulate(*bank.models[0], diagonal({0.02, 0.05, 0.01}), h,
                                   diagonal({0.05 * 0.05, 0.03 * 0.03}), 300, 0.1, input, 131);
  Trajectory irregular = simulate(*bank.models[0], diagonal({0.02, 0.05, 0.01}), h,
                                  diagonal({0.05 * 0.05, 0.03 * 0.03}), 300, 0.1, input, 132);
  for (int k = 0; k < irregular.size(); ++k) irregular.t[static_cast<std::size_t>(k)] += 0.03 * std::sin(1.7 * k);
  Eigen::VectorXd parameters(static_cast<Eigen::Index>(bank.models[0]->parameter_info().size()));
  bank.models[0]->get_parameters(parameters);
  ASSERT_TRUE(bank.models[0]->set_parameters(parameters * 0.9, nullptr));  // away from the truth
  Options options;
  options.process_noise = Options::ProcessNoise::kFull;
  options.fit_measurement_noise = true;
  check_gradient(&bank, ModeLogs{0, {grid, irregular}}, options);
}

// The recovered values next to the true ones, for the test's output.
void print_recovery(const std::string& title, const std::vector<ParameterEstimate>& estimates,
                    const std::vector<double>& truth) {
  std::cout << title << ":\n";
  for (std::size_t i = 0; i < estimates.size(); ++i) {
    std::cout << "  " << estimates[i].name << " = " << estimates[i].value << " +- " << estimates[i].standard_deviation
              << " (true " << truth[i] << ", " << (estimates[i].value - truth[i]) / estimates[i].standard_deviation
              << " sd)\n";
  }
}

// Every estimate within `sigmas` of its standard deviation from the truth.
void expect_recovered(const std::vector<ParameterEstimate>& estimates, const std::vector<double>& truth,
                      double sigmas = 4.0) {
  ASSERT_EQ(estimates.size(), truth.size());
  for (std::size_t i = 0; i < truth.size(); ++i) {
    EXPECT_TRUE(std::isfinite(estimates[i].standard_deviation) && estimates[i].standard_deviation > 0.0)
        << estimates[i].name;
    EXPECT_LT(std::abs(estimates[i].value - truth[i]), sigmas * estimates[i].standard_deviation)
        << estimates[i].name << " = " << estimates[i].value << " +- " << estimates[i].standard_deviation << ", true "
        << truth[i];
  }
}

struct LtcTruth {
  Eigen::Matrix2d a, b;
  Eigen::MatrixXd q;
  std::vector<double> parameters() const {
    return {a(0, 0), a(0, 1), a(1, 0), a(1, 1), b(0, 0), b(0, 1), b(1, 0), b(1, 1)};
  }
};

LtcTruth ltc_truth() {
  LtcTruth t;
  t.a << -4.0, 0.3, 0.2, -3.0;
  t.b << 0.35, 0.3, -0.7, 0.75;
  t.q = diagonal({2e-3, 3e-3});
  return t;
}

// A start far from the truth: A = -I, B small, Q 5 times too large.
Bank ltc_start_bank(const Eigen::MatrixXd& r, int modes = 1) {
  Eigen::Matrix2d a = -Eigen::Matrix2d::Identity(), b;
  b << 0.1, 0.1, -0.1, 0.1;
  std::vector<std::shared_ptr<sdk::MotionModel>> models;
  for (int j = 0; j < modes; ++j) models.push_back(skidimm_test::make_ltc(a, b));
  return make_bank(models, {diagonal({0.01, 0.01})}, Eigen::MatrixXd::Identity(2, 2), r);
}

TEST(LikelihoodFitter, RecoversParametersAndQWhenEveryStateIsMeasured) {
  SKIDIMM_SKIP_UNDER_SANITIZERS_STATISTICAL();
  const LtcTruth truth = ltc_truth();
  const Eigen::MatrixXd r = diagonal({1e-4, 1e-4});  // 1 cm/s, 0.01 rad/s
  const Trajectory log = simulate(*skidimm_test::make_ltc(truth.a, truth.b), truth.q, Eigen::MatrixXd::Identity(2, 2),
                                  r, 6000, 0.02, rich_wheel_speeds, 11);
  Bank bank = ltc_start_bank(r);
  const FitReport report = fit_likelihood(&bank, {ModeLogs{0, {log}}}).front();
  print_recovery("all states measured", report.parameters, truth.parameters());
  print_recovery("  Q", report.noise_parameters, {truth.q(0, 0), truth.q(1, 1)});
  expect_recovered(report.parameters, truth.parameters());
  expect_recovered(report.noise_parameters, {truth.q(0, 0), truth.q(1, 1)});
  EXPECT_EQ(report.derivatives, "autodiff");
  EXPECT_LT(report.final_cost, report.initial_cost);
  EXPECT_EQ(report.measured_rows, 6000);
  EXPECT_EQ(report.residuals, 12000);
  EXPECT_DOUBLE_EQ(report.negative_log_likelihood_per_row, report.negative_log_likelihood / 6000);
  // The model's parameters are left at the fit, and the filter is consistent.
  Eigen::VectorXd fitted(8);
  bank.models[0]->get_parameters(fitted);
  for (int i = 0; i < 8; ++i) EXPECT_EQ(fitted[i], report.parameters[static_cast<std::size_t>(i)].value);
  for (int c = 0; c < 2; ++c) EXPECT_NEAR(report.mean_nis[c], 1.0, 0.1) << "component " << c;
  EXPECT_TRUE(report.measurement_noise.size() == 0) << "R was not fitted";
  std::cout << "  " << report.iterations << " iterations, NLL " << report.initial_cost << " -> " << report.final_cost
            << ", mean NIS " << report.mean_nis.transpose() << ", innovation RMSE " << report.rmse.transpose() << "\n";
}

TEST(LikelihoodFitter, RecoversALatentStateThatIsNeverMeasured) {
  SKIDIMM_SKIP_UNDER_SANITIZERS_STATISTICAL();
  // x0' = -a x0 + b u (latent, e.g. a motor's torque), x1' = x0 - d x1
  // (measured). The gain from x0 to x1 is fixed at 1: scaling the latent state
  // would otherwise change nothing measurable.
  auto latent_model = [](double a, double d, double b) {
    Eigen::Matrix2d am;
    am << -a, 0.0, 1.0, -d;
    Eigen::Matrix2i a_free;
    a_free << 1, 0, 0, 1;
    return std::make_shared<MaskedLinearModel>(am, Eigen::Vector2d(b, 0.0), a_free, Eigen::Vector2i(1, 0), true);
  };
  const Eigen::MatrixXd q = diagonal({0.05, 0.01});
  const Eigen::MatrixXd h = (Eigen::MatrixXd(1, 2) << 0.0, 1.0).finished();
  const Eigen::MatrixXd r = diagonal({1e-4});
  auto input = [](double t) {
    return Eigen::VectorXd::Constant(1,
                                     std::sin(0.7 * t) + 0.5 * std::sin(2.3 * t) + (std::sin(0.25 * t) > 0 ? 1 : -1));
  };
  const Trajectory log = simulate(*latent_model(2.0, 0.5, 1.5), q, h, r, 8000, 0.05, input, 5);
  Bank bank = make_bank({latent_model(3.0, 0.3, 1.0)}, {diagonal({0.01, 0.01})}, h, r);
  const FitReport report = fit_likelihood(&bank, {ModeLogs{0, {log}}}).front();
  const std::vector<double> truth = {-2.0, -0.5, 1.5};
  print_recovery("latent state", report.parameters, truth);
  print_recovery("  Q", report.noise_parameters, {0.05, 0.01});
  expect_recovered(report.parameters, truth);
  expect_recovered(report.noise_parameters, {0.05, 0.01});
  EXPECT_EQ(report.rmse.size(), 1);
  EXPECT_NEAR(report.mean_nis[0], 1.0, 0.1);
}

TEST(LikelihoodFitter, FitsOneMeasurementNoiseJointlyOverTwoModes) {
  SKIDIMM_SKIP_UNDER_SANITIZERS_STATISTICAL();
  LtcTruth smooth = ltc_truth(), rough = ltc_truth();
  rough.a << -6.0, 0.0, 0.5, -2.0;
  rough.b << 0.3, 0.25, -0.5, 0.55;
  rough.q = diagonal({0.02, 0.01});
  const Eigen::MatrixXd r = diagonal({0.02 * 0.02, 0.01 * 0.01});
  const Eigen::MatrixXd h = Eigen::MatrixXd::Identity(2, 2);
  const Trajectory smooth_log =
      simulate(*skidimm_test::make_ltc(smooth.a, smooth.b), smooth.q, h, r, 5000, 0.02, rich_wheel_speeds, 21);
  const Trajectory rough_log =
      simulate(*skidimm_test::make_ltc(rough.a, rough.b), rough.q, h, r, 5000, 0.02, rich_wheel_speeds, 22);
  Bank bank = ltc_start_bank(diagonal({0.05 * 0.05, 0.03 * 0.03}), 2);  // R far too large
  Options options;
  options.fit_measurement_noise = true;
  const std::vector<FitReport> reports =
      fit_likelihood(&bank, {ModeLogs{0, {smooth_log}}, ModeLogs{1, {rough_log}}}, options);
  ASSERT_EQ(reports.size(), 2u);
  // Q then R, for each mode.
  const std::vector<double> smooth_noise = {smooth.q(0, 0), smooth.q(1, 1), r(0, 0), r(1, 1)};
  const std::vector<double> rough_noise = {rough.q(0, 0), rough.q(1, 1), r(0, 0), r(1, 1)};
  print_recovery("joint R, smooth mode", reports[0].parameters, smooth.parameters());
  print_recovery("  Q and R", reports[0].noise_parameters, smooth_noise);
  print_recovery("joint R, rough mode", reports[1].parameters, rough.parameters());
  print_recovery("  Q and R", reports[1].noise_parameters, rough_noise);
  expect_recovered(reports[0].parameters, smooth.parameters());
  expect_recovered(reports[1].parameters, rough.parameters());
  expect_recovered(reports[0].noise_parameters, smooth_noise);
  expect_recovered(reports[1].noise_parameters, rough_noise);
  // One R, written into the bank and reported by both modes.
  EXPECT_EQ(bank.config.measurement.r, reports[0].measurement_noise);
  EXPECT_EQ(reports[0].measurement_noise, reports[1].measurement_noise);
  EXPECT_EQ(bank.config.measurement.r(0, 1), 0.0);
  EXPECT_EQ(reports[0].final_cost, reports[1].final_cost) << "the joint objective";
  std::cout << "  " << reports[0].iterations << " iterations, NLL " << reports[0].initial_cost << " -> "
            << reports[0].final_cost << ", mean NIS " << reports[0].mean_nis.transpose() << " and "
            << reports[1].mean_nis.transpose() << "\n";
  EXPECT_NEAR(reports[0].negative_log_likelihood + reports[1].negative_log_likelihood, reports[0].final_cost,
              1e-9 * std::abs(reports[0].final_cost));
}

TEST(LikelihoodFitter, RecoversParametersFromMultiRateMeasurements) {
  SKIDIMM_SKIP_UNDER_SANITIZERS_STATISTICAL();
  const LtcTruth truth = ltc_truth();
  const Eigen::MatrixXd r = diagonal({1e-4, 1e-4});
  // Speed at 10 Hz (every fifth row), yaw rate at 50 Hz.
  const Trajectory log =
      simulate(*skidimm_test::make_ltc(truth.a, truth.b), truth.q, Eigen::MatrixXd::Identity(2, 2), r, 6000, 0.02,
               rich_wheel_speeds, 31, [](int k, int c) { return c == 1 || k % 5 == 0; });
  Bank bank = ltc_start_bank(r);
  const FitReport report = fit_likelihood(&bank, {ModeLogs{0, {log}}}).front();
  print_recovery("speed every fifth row", report.parameters, truth.parameters());
  print_recovery("  Q", report.noise_parameters, {truth.q(0, 0), truth.q(1, 1)});
  expect_recovered(report.parameters, truth.parameters());
  expect_recovered(report.noise_parameters, {truth.q(0, 0), truth.q(1, 1)});
  EXPECT_EQ(report.measured_rows, 6000);
  EXPECT_EQ(report.residuals, 6000 + 1200);
}

TEST(LikelihoodFitter, FullProcessNoiseIsRecoveredWithItsCorrelation) {
  SKIDIMM_SKIP_UNDER_SANITIZERS_STATISTICAL();
  const LtcTruth truth = ltc_truth();
  Eigen::MatrixXd q(2, 2);
  q << 4e-3, 2e-3, 2e-3, 3e-3;  // correlation 0.58
  const Eigen::MatrixXd r = diagonal({1e-4, 1e-4});
  const Trajectory log = simulate(*skidimm_test::make_ltc(truth.a, truth.b), q, Eigen::MatrixXd::Identity(2, 2), r,
                                  6000, 0.02, rich_wheel_speeds, 41);
  Bank bank = ltc_start_bank(r);
  Options options;
  options.process_noise = Options::ProcessNoise::kFull;
  const FitReport report = fit_likelihood(&bank, {ModeLogs{0, {log}}}, options).front();
  // The lower triangle, row by row.
  const std::vector<double> q_truth = {q(0, 0), q(1, 0), q(1, 1)};
  print_recovery("full Q", report.noise_parameters, q_truth);
  ASSERT_EQ(report.noise_parameters[1].name, "Q[1,0]");
  expect_recovered(report.noise_parameters, q_truth);
  expect_recovered(report.parameters, truth.parameters());
  EXPECT_EQ(report.q_intensity(0, 1), report.q_intensity(1, 0));
  EXPECT_GT(Eigen::LLT<Eigen::MatrixXd>(report.q_intensity).info() == Eigen::Success, 0);
}

TEST(LikelihoodFitter, APluginWithoutParameterJacobianGetsDifferencesAndTheSameOptimum) {
  // skidimm_test::ScalarLinearModel (x + (a x + b u) dt) has no
  // parameter_jacobian(); MaskedLinearModel is the same model with one.
  const double a = -1.5, b = 0.8;
  const Eigen::MatrixXd q = diagonal({0.02});
  const Eigen::MatrixXd r = diagonal({0.05 * 0.05});
  auto input = [](double t) { return Eigen::VectorXd::Constant(1, std::sin(0.5 * t) + std::sin(1.7 * t)); };
  const Trajectory log =
      simulate(skidimm_test::ScalarLinearModel(a, b), q, Eigen::MatrixXd::Identity(1, 1), r, 3000, 0.05, input, 51);
  Bank numeric = make_bank({std::make_shared<skidimm_test::ScalarLinearModel>(-0.5, 0.3)}, {diagonal({0.1})},
                           Eigen::MatrixXd::Identity(1, 1), r);
  Bank exact = make_bank(
      {std::make_shared<MaskedLinearModel>(Eigen::MatrixXd::Constant(1, 1, -0.5), Eigen::MatrixXd::Constant(1, 1, 0.3),
                                           Eigen::MatrixXi::Ones(1, 1), Eigen::MatrixXi::Ones(1, 1), true)},
      {diagonal({0.1})}, Eigen::MatrixXd::Identity(1, 1), r);
  const FitReport numeric_report = fit_likelihood(&numeric, {ModeLogs{0, {log}}}).front();
  const FitReport exact_report = fit_likelihood(&exact, {ModeLogs{0, {log}}}).front();
  EXPECT_EQ(numeric_report.derivatives, "numeric");
  EXPECT_EQ(exact_report.derivatives, "autodiff");
  for (std::size_t i = 0; i < 2; ++i) {
    const ParameterEstimate& n = numeric_report.parameters[i];
    const ParameterEstimate& e = exact_report.parameters[i];
    EXPECT_NEAR(n.value, e.value, 1e-4 * e.standard_deviation) << e.name;
    EXPECT_NEAR(n.standard_deviation, e.standard_deviation, 1e-4 * e.standard_deviation) << e.name;
    std::cout << e.name << ": exact " << e.value << " +- " << e.standard_deviation << ", numeric " << n.value << " +- "
              << n.standard_deviation << "\n";
  }
  EXPECT_NEAR(numeric_report.noise_parameters[0].value, exact_report.noise_parameters[0].value,
              1e-4 * exact_report.noise_parameters[0].standard_deviation);
  EXPECT_NEAR(numeric_report.final_cost, exact_report.final_cost, 1e-8 * std::abs(exact_report.final_cost));
  expect_recovered(exact_report.parameters, {a, b});
}

// A model that fails where the log drives it past what it covers: the window
// fit's check of the starting values gives the model's own words, not a
// suspicion of the log's numbers.
TEST(LikelihoodFitter, AWindowFitNamesWhyTheModelFailedAtTheStartingValues) {
  class FailingAbove final : public MaskedLinearModel {
   public:
    using MaskedLinearModel::MaskedLinearModel;
    bool predict(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
                 Eigen::Ref<Eigen::VectorXd> x_next) const noexcept override {
      if (u[0] > 1.5) {
        sdk::report_failure("the input is past what this model covers");
        return false;
      }
      return MaskedLinearModel::predict(x, u, dt, x_next);
    }
  };
  const Eigen::MatrixXd r = diagonal({0.05 * 0.05});
  auto input = [](double t) { return Eigen::VectorXd::Constant(1, std::sin(0.5 * t) + std::sin(1.7 * t)); };
  const Trajectory log = simulate(skidimm_test::ScalarLinearModel(-1.5, 0.8), diagonal({0.02}),
                                  Eigen::MatrixXd::Identity(1, 1), r, 400, 0.05, input, 51);
  Bank bank = make_bank(
      {std::make_shared<FailingAbove>(Eigen::MatrixXd::Constant(1, 1, -0.5), Eigen::MatrixXd::Constant(1, 1, 0.3),
                                      Eigen::MatrixXi::Ones(1, 1), Eigen::MatrixXi::Ones(1, 1), true)},
      {diagonal({0.1})}, Eigen::MatrixXd::Identity(1, 1), r);
  FitOptions options;
  options.window = 0.2;
  try {
    fit(&bank, {ModeLogs{0, {log}}}, options);
    FAIL() << "the model fails on the log";
  } catch (const FitError& e) {
    EXPECT_THAT(e.what(), HasSubstr("failed with the starting values of mode '"));
    EXPECT_THAT(e.what(), HasSubstr(": the model failed: the input is past what this model covers"));
    EXPECT_THAT(e.what(), Not(HasSubstr("check the log's inputs")));
  }
}

TEST(LikelihoodFitter, FitsOnlyTheNoiseOfAModelWithoutParameters) {
  auto heading = std::make_shared<skidimm_test::HeadingModel>(0.5);
  const Eigen::MatrixXd q = diagonal({4e-3});
  const Eigen::MatrixXd r = diagonal({0.02 * 0.02});
  auto input = [](double t) { return Eigen::VectorXd::Constant(1, 3.0 + std::sin(t)); };
  const Trajectory log = simulate(*heading, q, Eigen::MatrixXd::Identity(1, 1), r, 4000, 0.05, input, 61);
  Bank bank = make_bank({heading}, {diagonal({0.1})}, Eigen::MatrixXd::Identity(1, 1), r, {true});
  Options keep;
  keep.process_noise = Options::ProcessNoise::kKeep;
  try {
    fit_likelihood(&bank, {ModeLogs{0, {log}}}, keep);
    FAIL() << "no parameters, Q kept, R not fitted";
  } catch (const FitError& e) {
    EXPECT_THAT(e.what(), HasSubstr("mode 'mode0': nothing to fit"));
  }
  // Asked for its parameters, a model with none fits its noise alone, as when asked for none.
  const FitReport report = fit_likelihood(&bank, {ModeLogs{0, {log}}}).front();
  Options options;
  options.fit_model_parameters = false;
  const FitReport noise_only = fit_likelihood(&bank, {ModeLogs{0, {log}}}, options).front();
  EXPECT_NEAR(report.noise_parameters[0].value, noise_only.noise_parameters[0].value,
              1e-3 * noise_only.noise_parameters[0].standard_deviation);
  EXPECT_TRUE(report.parameters.empty());
  EXPECT_EQ(report.derivatives, "none");
  print_recovery("heading's Q alone", report.noise_parameters, {4e-3});
  expect_recovered(report.noise_parameters, {4e-3});
}

TEST(LikelihoodFitter, NoMeasuredRowIsAnError) {
  const LtcTruth truth = ltc_truth();
  Trajectory log = simulate(*skidimm_test::make_ltc(truth.a, truth.b), truth.q, Eigen::MatrixXd::Identity(2, 2),
                            diagonal({1e-4, 1e-4}), 100, 0.02, rich_wheel_speeds, 71);
  log.z.setConstant(std::nan(""));
  Bank bank = ltc_start_bank(diagonal({1e-4, 1e-4}));
  try {
    fit_likelihood(&bank, {ModeLogs{0, {log}}});
    FAIL();
  } catch (const FitError& e) {
    EXPECT_THAT(e.what(), HasSubstr("mode 'mode0': no measured row in its logs (simulated)"));
  }
}

TEST(LikelihoodFitter, ANonFiniteStartNamesTheLogAndTheRow) {
  const LtcTruth truth = ltc_truth();
  Trajectory log = simulate(*skidimm_test::make_ltc(truth.a, truth.b), truth.q, Eigen::MatrixXd::Identity(2, 2),
                            diagonal({1e-4, 1e-4}), 500, 0.02, rich_wheel_speeds, 81);
  log.u(0, 200) = 1e200;  // a corrupt cell: row 201 drives the prediction to row 202
  Bank bank = ltc_start_bank(diagonal({1e-4, 1e-4}));
  Eigen::VectorXd start(8), after(8);
  bank.models[0]->get_parameters(start);
  try {
    fit_likelihood(&bank, {ModeLogs{0, {log}}});
    FAIL();
  } catch (const FitError& e) {
    EXPECT_THAT(e.what(), HasSubstr("mode 'mode0': simulated: row 202 (t = 4.02 s): "));
    EXPECT_THAT(e.what(), HasSubstr("the negative log-likelihood is not finite at the starting values"));
  }
  bank.models[0]->get_parameters(after);
  EXPECT_EQ(after, start) << "the model is left at its starting values";
  // The held-out evaluation says the same without throwing.
  const LikelihoodEvaluation e = evaluate_likelihood(bank, ModeLogs{0, {log}});
  EXPECT_EQ(e.negative_log_likelihood, std::numeric_limits<double>::infinity());
  EXPECT_THAT(e.failure, HasSubstr("simulated: row 202"));
}

TEST(LikelihoodFitter, DrivingStraightDoesNotIdentifyTheTurnGains) {
  const LtcTruth truth = ltc_truth();
  auto straight = [](double t) { return Eigen::Vector2d(4.0 + std::sin(t), 4.0 + std::sin(t)); };
  const Trajectory log = simulate(*skidimm_test::make_ltc(truth.a, truth.b), truth.q, Eigen::MatrixXd::Identity(2, 2),
                                  diagonal({1e-4, 1e-4}), 2000, 0.02, straight, 91);
  Bank bank = ltc_start_bank(diagonal({1e-4, 1e-4}));
  Eigen::VectorXd start(8), after(8);
  bank.models[0]->get_parameters(start);
  try {
    fit_likelihood(&bank, {ModeLogs{0, {log}}});
    FAIL() << "equal wheel speeds cannot separate the left and right gains";
  } catch (const FitError& e) {
    EXPECT_THAT(e.what(), HasSubstr("mode 'mode0' (logs: simulated): the logs do not identify every parameter"));
    EXPECT_THAT(e.what(), HasSubstr("[B[0,0], B[0,1]]"));
    EXPECT_THAT(e.what(), HasSubstr("[B[1,0], B[1,1]]"));
    EXPECT_THAT(e.what(), HasSubstr(". What they are: B[0,0], B[0,1], B[1,0], B[1,1]: input matrix"));
  }
  bank.models[0]->get_parameters(after);
  EXPECT_EQ(after, start);
}

// x + (a x + b u) dt, except that for b above `cliff` it claims success and
// returns NaN, as a careless plugin might: the fitter must treat such a
// point as a failed evaluation, and never hand NaN to the line search.
class CliffModel : public skidimm_test::ScalarLinearModel {
 public:
  CliffModel(double a, double b, double cliff) : ScalarLinearModel(a, b), cliff_(cliff) {}
  bool predict_fixed(const State& x, const Input& u, double dt, State* next) const noexcept override {
    Eigen::VectorXd p(2);
    get_parameters(p);
    if (p[1] > cliff_) {
      ++nan_predictions;
      (*next)[0] = std::nan("");
      return true;
    }
    return ScalarLinearModel::predict_fixed(x, u, dt, next);
  }
  mutable int nan_predictions = 0;

 private:
  double cliff_;
};

TEST(LikelihoodFitter, NonFiniteValuesDuringTheSearchAreFailedEvaluations) {
  const Eigen::MatrixXd q = diagonal({0.02});
  const Eigen::MatrixXd r = diagonal({0.05 * 0.05});
  auto input = [](double t) { return Eigen::VectorXd::Constant(1, std::sin(0.5 * t) + std::sin(1.7 * t)); };
  const Trajectory log = simulate(skidimm_test::ScalarLinearModel(-1.5, 0.8), q, Eigen::MatrixXd::Identity(1, 1), r,
                                  3000, 0.05, input, 111);
  auto model = std::make_shared<CliffModel>(-0.2, 0.05, 1.0);
  Bank bank = make_bank({model}, {diagonal({1.0})}, Eigen::MatrixXd::Identity(1, 1), r);
  const FitReport report = fit_likelihood(&bank, {ModeLogs{0, {log}}}).front();
  EXPECT_GT(model->nan_predictions, 0) << "the search never crossed the cliff: the test does not test";
  print_recovery("past a cliff of NaN", report.parameters, {-1.5, 0.8});
  expect_recovered(report.parameters, {-1.5, 0.8});
  EXPECT_TRUE(std::isfinite(report.final_cost));
  std::cout << "  " << model->nan_predictions << " predictions returned NaN during the search\n";
}

// Q dt plus a floor: affine, not linear, in the intensity.
class NoiseFloorModel : public skidimm_test::ScalarLinearModel {
 public:
  using ScalarLinearModel::ScalarLinearModel;
  bool process_noise(const Eigen::Ref<const Eigen::MatrixXd>& intensity, const Eigen::Ref<const Eigen::VectorXd>&,
                     const Eigen::Ref<const Eigen::VectorXd>&, double dt,
                     Eigen::Ref<Eigen::MatrixXd> noise) const noexcept override {
    noise = intensity * dt;
    noise(0, 0) += 1e-4;
    return true;
  }
};

TEST(LikelihoodFitter, ProcessNoiseNotLinearInQIsAnErrorUnlessQIsKept) {
  const Eigen::MatrixXd r = diagonal({0.05 * 0.05});
  auto input = [](double t) { return Eigen::VectorXd::Constant(1, std::sin(0.5 * t) + std::sin(1.7 * t)); };
  const Trajectory log = simulate(skidimm_test::ScalarLinearModel(-1.5, 0.8), diagonal({0.02}),
                                  Eigen::MatrixXd::Identity(1, 1), r, 2000, 0.05, input, 121);
  Bank bank =
      make_bank({std::make_shared<NoiseFloorModel>(-1.0, 0.5)}, {diagonal({0.02})}, Eigen::MatrixXd::Identity(1, 1), r);
  try {
    fit_likelihood(&bank, {ModeLogs{0, {log}}});
    FAIL();
  } catch (const FitError& e) {
    EXPECT_THAT(e.what(), HasSubstr("mode 'mode0': the model's process_noise() is not linear in the intensity Q"));
  }
  EXPECT_THAT(evaluate_likelihood_derivatives(&bank, ModeLogs{0, {log}}).failure,
              HasSubstr("is not linear in the intensity Q"));
  Options options;
  options.process_noise = Options::ProcessNoise::kKeep;
  const FitReport report = fit_likelihood(&bank, {ModeLogs{0, {log}}}, options).front();
  EXPECT_TRUE(report.noise_parameters.empty());
  EXPECT_EQ(report.q_intensity, diagonal({0.02})) << "kept";
  EXPECT_NEAR(report.parameters[0].value, -1.5, 4.0 * report.parameters[0].standard_deviation);
}

// The NLL with the gradient (evaluate_likelihood_derivatives) is the NLL
// alone (evaluate_likelihood), for a 2-state model with a parameter Jacobian
// and 6-state ones with 42 parameters. What these evaluations cost is
// measured in tests/benchmarks/likelihood_benchmark.cc.
void expect_same_negative_log_likelihood(Bank* bank, const Trajectory& log) {
  const ModeLogs data{0, {log}};
  const LikelihoodEvaluation value = evaluate_likelihood(*bank, data);
  const LikelihoodEvaluation derivatives = evaluate_likelihood_derivatives(bank, data);
  ASSERT_TRUE(value.failure.empty()) << value.failure;
  ASSERT_TRUE(derivatives.failure.empty()) << derivatives.failure;
  EXPECT_NEAR(value.negative_log_likelihood, derivatives.negative_log_likelihood,
              1e-12 * std::abs(value.negative_log_likelihood));
}

TEST(LikelihoodFitter, TheNllWithTheGradientIsTheNllAlone) {
  const LtcTruth truth = ltc_truth();
  const Eigen::MatrixXd r = diagonal({1e-4, 1e-4});
  Bank ltc = ltc_start_bank(r);
  expect_same_negative_log_likelihood(
      &ltc, simulate(*skidimm_test::make_ltc(truth.a, truth.b), truth.q, Eigen::MatrixXd::Identity(2, 2), r, 500, 0.02,
                     rich_wheel_speeds, 101));
  const std::filesystem::path directory = skidimm_test::test_directory();
  Bank diagonal_a = skidimm_test::six_states_diagonal_a(directory);
  expect_same_negative_log_likelihood(&diagonal_a, skidimm_test::six_state_log(*diagonal_a.models[0], 102, 500));
  Bank full_a = skidimm_test::six_states_full_a(directory);
  expect_same_negative_log_likelihood(&full_a, skidimm_test::six_state_log(*full_a.models[0], 103, 500));
}

}  // namespace
}  // namespace fitting
}  // namespace skidimm
