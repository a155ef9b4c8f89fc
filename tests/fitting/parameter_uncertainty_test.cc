// Parameter uncertainty: the window fit's covariance of a mode's parameters
// against the textbook s^2 (X'X)^-1 of the same regression computed here
// with Eigen alone; the process noise a covariance adds against
// phi' Sigma phi written out by hand; the bank keys' errors; tune and fit
// carry the covariance to the bank.
#include "skidimm/engine/parameter_uncertainty.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "core/temp_files.h"
#include "fitting/kept_covariance_models.h"
#include "fitting/parameter_covariance.h"
#include "skidimm/config/bank.h"
#include "skidimm/engine/imm.h"
#include "skidimm/errors.h"
#include "skidimm/fitting/bank_fit.h"
#include "skidimm/fitting/model_fitter.h"
#include "skidimm/fitting/tuning.h"

namespace skidimm {
namespace fitting {
namespace {

using ::testing::HasSubstr;

// Two features relaxing at fixed rates towards B u + c (the BorealTC bank's
// form), two inputs; B and c are the 6 fitted parameters, in the order
// B[0,0], B[0,1], B[1,0], B[1,1], c[0], c[1].
constexpr double kFeatureRate[2] = {-2.0, -3.0};
constexpr double kFeatureDt = 0.1;

std::string bank_text(const std::string& extra = "") {
  return R"(name: two_features
states: [a, b]
inputs: [u1, u2]
measurement: {observe: [a, b], R: {std: [0.1, 0.2]}}
transition: {stay: 0.99}
initial: {covariance: {std: [1, 1]}}
modes:
  - name: only
    model: linear_features
    params: {A: [-2, -3], B: [[0.5, 0], [0, 0.5]], c: [0, 0], fixed: [A]}
    Q: {diagonal: [0.01, 0.02]}
)" + extra;
}

Bank load_two_features(const std::string& text, const std::string& name = "two.yaml") {
  return Bank::load(skidimm_test::write_file(skidimm_test::test_directory() / name, text), {SKIDIMM_PLUGIN_DIR});
}

// Gamma of one feature: int_0^dt e^{a s} ds.
double feature_gamma(int state) { return std::expm1(kFeatureRate[state] * kFeatureDt) / kFeatureRate[state]; }

// A log of the two features with errors of unequal size (0.05, 0.4 per step),
// each feature's target moved by `offset` for the whole log.
Trajectory regression_log(int rows, unsigned seed, const Eigen::Vector2d& offset = Eigen::Vector2d::Zero()) {
  std::mt19937 random(seed);
  std::normal_distribution<double> normal;
  const Eigen::Matrix<double, 2, 2> b = (Eigen::Matrix<double, 2, 2>() << 1.5, -0.7, 0.4, 2.0).finished();
  const Eigen::Vector2d c = Eigen::Vector2d(0.3, -1.0) + offset, error(0.05, 0.4);
  Trajectory t;
  t.source = "regression";
  t.u.resize(2, rows);
  t.z.resize(2, rows);
  Eigen::Vector2d x(0.0, 0.0);
  for (int k = 0; k < rows; ++k) {
    t.t.push_back(kFeatureDt * k);
    t.u.col(k) << 1.0 + std::sin(0.05 * k) + 0.3 * normal(random), 0.5 * std::cos(0.11 * k) + 0.2 * normal(random);
    t.z.col(k) = x;
    for (int i = 0; i < 2; ++i) {
      x[i] = std::exp(kFeatureRate[i] * kFeatureDt) * x[i] + feature_gamma(i) * (b.row(i).dot(t.u.col(k)) + c[i]) +
             error[i] * normal(random);
    }
  }
  return t;
}

// Three logs of 150 rows, each feature's target moved by an offset of the
// log's own, far larger than a step's error: run_0, run_1, run_2.
std::vector<Trajectory> logs_each_off_its_line() {
  const std::vector<Eigen::Vector2d> offsets = {{0.2, -1.5}, {-0.3, 2.0}, {0.05, 0.3}};
  std::vector<Trajectory> logs;
  for (std::size_t g = 0; g < offsets.size(); ++g) {
    logs.push_back(regression_log(150, 40 + static_cast<unsigned>(g), offsets[g]));
    logs.back().log = "run_" + std::to_string(g);
  }
  return logs;
}

TEST(ParameterCovariance, IsEachFeaturesRegressionCovarianceSSquaredTimesTheInverseOfXtX) {
  Bank bank = load_two_features(bank_text());
  const Trajectory log = regression_log(400, 17);
  FitOptions options;
  options.window = 0.0;  // one step: each feature's regression on [u1, u2, 1]
  options.loss = "none";
  options.parameter_covariance = true;
  const FitReport report = fit(&bank, std::vector<ModeLogs>{{0, {log}}}, options).front();
  ASSERT_EQ(report.parameter_covariance.rows(), 6);
  ASSERT_EQ(report.parameter_covariance.cols(), 6);

  // The same regression with Eigen alone: y = (z+ - e^{a dt} z) / gamma = [u1 u2 1] beta + e.
  const int rows = log.size() - 1;
  Eigen::MatrixXd x(rows, 3);
  for (int k = 0; k < rows; ++k) x.row(k) << log.u(0, k), log.u(1, k), 1.0;
  const Eigen::MatrixXd xtx_inverse = (x.transpose() * x).ldlt().solve(Eigen::MatrixXd::Identity(3, 3));
  const int index[2][3] = {{0, 1, 4}, {2, 3, 5}};  // B[i,0], B[i,1], c[i]
  Eigen::VectorXd fitted(6);
  bank.models[0]->get_parameters(fitted);
  for (int i = 0; i < 2; ++i) {
    Eigen::VectorXd y(rows);
    for (int k = 0; k < rows; ++k)
      y[k] = (log.z(i, k + 1) - std::exp(kFeatureRate[i] * kFeatureDt) * log.z(i, k)) / feature_gamma(i);
    const Eigen::Vector3d beta = xtx_inverse * x.transpose() * y;
    const double s2 = (y - x * beta).squaredNorm() / (rows - 3);
    const Eigen::Matrix3d expected = s2 * xtx_inverse;
    for (int p = 0; p < 3; ++p) {
      EXPECT_NEAR(fitted[index[i][p]], beta[p], 1e-6 * (1.0 + std::abs(beta[p])));
      for (int q = 0; q < 3; ++q) {
        EXPECT_NEAR(report.parameter_covariance(index[i][p], index[i][q]), expected(p, q),
                    1e-6 * std::abs(expected(p, p)))
            << "feature " << i << " (" << p << ", " << q << ")";
      }
    }
    // No covariance between the features' parameters, exactly: each depends
    // on its own errors, and the information is inverted a block at a time.
    for (int p = 0; p < 3; ++p) {
      for (int q = 0; q < 3; ++q) EXPECT_EQ(report.parameter_covariance(index[i][p], index[1 - i][q]), 0.0);
    }
  }
  // The prediction variance phi' Sigma phi is least at the inputs' mean and
  // grows away from it: five standard deviations out it is far larger.
  Eigen::Vector3d mean = x.colwise().mean().transpose();
  Eigen::Vector3d far = mean;
  far.head(2) += 5.0 * ((x.rowwise() - x.colwise().mean()).colwise().norm().transpose().head(2) / std::sqrt(rows));
  Eigen::Matrix3d first;
  for (int p = 0; p < 3; ++p) {
    for (int q = 0; q < 3; ++q) first(p, q) = report.parameter_covariance(index[0][p], index[0][q]);
  }
  EXPECT_GT(far.dot(first * far), 10.0 * mean.dot(first * mean));
  // Unequal errors, unequal variances: one s^2 for both features would blur them.
  EXPECT_GT(report.parameter_covariance(5, 5), 20.0 * report.parameter_covariance(4, 4));
}

// Logs each missed by an offset of its own: per log, the covariance is the
// regression's s^2 (X'X)^-1 times each feature's design effect over the logs,
// G / (G - 1) sum_g (sum of log g's residuals)^2 / SSE, computed here from
// the same regression with Eigen alone.
TEST(ParameterCovariance, PerLogIsTheRegressionsTimesEachFeaturesDesignEffect) {
  const std::vector<Trajectory> logs = logs_each_off_its_line();
  FitOptions options;
  options.window = 0.0;
  options.loss = "none";
  options.parameter_covariance = true;
  Bank independent_bank = load_two_features(bank_text());
  const FitReport independent = fit(&independent_bank, std::vector<ModeLogs>{{0, logs}}, options).front();
  options.parameter_covariance_per_log = true;
  Bank bank = load_two_features(bank_text());
  const FitReport per_log = fit(&bank, std::vector<ModeLogs>{{0, logs}}, options).front();
  ASSERT_EQ(per_log.parameter_covariance.rows(), 6);

  int rows = 0;
  for (const Trajectory& t : logs) rows += t.size() - 1;
  Eigen::MatrixXd x(rows, 3);
  std::vector<int> log_of(static_cast<std::size_t>(rows));
  for (int g = 0, r = 0; g < static_cast<int>(logs.size()); ++g) {
    for (int k = 0; k + 1 < logs[static_cast<std::size_t>(g)].size(); ++k, ++r) {
      x.row(r) << logs[static_cast<std::size_t>(g)].u(0, k), logs[static_cast<std::size_t>(g)].u(1, k), 1.0;
      log_of[static_cast<std::size_t>(r)] = g;
    }
  }
  const Eigen::MatrixXd xtx_inverse = (x.transpose() * x).ldlt().solve(Eigen::MatrixXd::Identity(3, 3));
  const int index[2][3] = {{0, 1, 4}, {2, 3, 5}};
  for (int i = 0; i < 2; ++i) {
    Eigen::VectorXd y(rows);
    for (int g = 0, r = 0; g < static_cast<int>(logs.size()); ++g) {
      const Trajectory& t = logs[static_cast<std::size_t>(g)];
      for (int k = 0; k + 1 < t.size(); ++k, ++r) {
        y[r] = (t.z(i, k + 1) - std::exp(kFeatureRate[i] * kFeatureDt) * t.z(i, k)) / feature_gamma(i);
      }
    }
    const Eigen::VectorXd residual = y - x * (xtx_inverse * x.transpose() * y);
    std::vector<double> sums(logs.size(), 0.0);
    for (int r = 0; r < rows; ++r) sums[static_cast<std::size_t>(log_of[static_cast<std::size_t>(r)])] += residual[r];
    double between = 0.0;
    for (double sum : sums) between += sum * sum;
    const double g = static_cast<double>(logs.size());
    const double design_effect = g / (g - 1.0) * between / residual.squaredNorm();
    // The offsets dwarf the errors of a step: far from independent rows.
    EXPECT_GT(design_effect, 10.0) << "feature " << i;
    const Eigen::Matrix3d expected = design_effect * residual.squaredNorm() / (rows - 3) * xtx_inverse;
    for (int p = 0; p < 3; ++p) {
      for (int q = 0; q < 3; ++q) {
        EXPECT_NEAR(per_log.parameter_covariance(index[i][p], index[i][q]), expected(p, q),
                    1e-6 * std::abs(expected(p, p)))
            << "feature " << i << " (" << p << ", " << q << ")";
        EXPECT_NEAR(per_log.parameter_covariance(index[i][p], index[i][q]),
                    design_effect * independent.parameter_covariance(index[i][p], index[i][q]),
                    1e-6 * std::abs(expected(p, p)));
      }
    }
  }
}

// The design effect by hand: one parameter (an intercept) seen by two
// channels. Channel 0: logs 0 and 2 (log 1 has none of its rows) each missed
// by an offset, residual sums 2 and -2 over 4 squares: 2/1 * 8/4 = 4.
// Channel 1: each log's residuals cancel, so its sums say less than
// independent rows would: floored at 1. The variances s_c^2 = SSE_c / n_c *
// N / (N - p) times the design effect give the information 4 / (4 * 8/7) +
// 4 / (8/7) = 35/8.
TEST(ParameterCovariance, DesignEffectByHandWithALogWithoutRowsAndItsFloor) {
  internal::ParameterCovarianceEstimate estimate(1, 2);
  const Eigen::RowVectorXd one = Eigen::RowVectorXd::Ones(1);
  for (const auto& [log, residual] : {std::pair{0, 1.0}, {0, 1.0}, {2, -1.0}, {2, -1.0}}) {
    estimate.add(0, one, residual, log);
  }
  for (const auto& [log, residual] : {std::pair{0, 1.0}, {0, -1.0}, {1, 1.0}, {1, -1.0}}) {
    estimate.add(1, one, residual, log);
  }
  EXPECT_DOUBLE_EQ(estimate.design_effect(0), 4.0);
  EXPECT_DOUBLE_EQ(estimate.design_effect(1), 1.0);
  EXPECT_NEAR(estimate.covariance(Eigen::MatrixXd::Identity(1, 1))(0, 0), 8.0 / 35.0, 1e-15);
  // Rows given without a log count as independent.
  internal::ParameterCovarianceEstimate independent(1, 1);
  for (double residual : {1.0, 1.0, -1.0, -1.0}) independent.add(0, one, residual);
  EXPECT_DOUBLE_EQ(independent.design_effect(0), 1.0);
}

// A log's segments (the rows a mode's fit_when gives it, split where it does
// not hold) are one log: split in two under the same log name, a log's
// offset still counts once, not as two logs that agree.
TEST(ParameterCovariance, PerLogCountsALogsSegmentsAsOneLog) {
  const std::vector<Trajectory> whole = logs_each_off_its_line();
  // Each log cut into two segments at row 75.
  auto segments = [&](bool same_name) {
    std::vector<Trajectory> out;
    for (const Trajectory& t : whole) {
      for (int part = 0; part < 2; ++part) {
        Trajectory s;
        const int from = part * 75, count = 75;
        s.t.assign(t.t.begin() + from, t.t.begin() + from + count);
        s.u = t.u.middleCols(from, count);
        s.z = t.z.middleCols(from, count);
        s.source = t.log + (part ? "[b]" : "[a]");
        s.log = same_name ? t.log : s.source;
        out.push_back(std::move(s));
      }
    }
    return out;
  };
  FitOptions options;
  options.window = 0.0;
  options.loss = "none";
  options.parameter_covariance = true;
  options.parameter_covariance_per_log = true;
  Bank as_logs = load_two_features(bank_text());
  const Eigen::MatrixXd logs =
      fit(&as_logs, std::vector<ModeLogs>{{0, segments(true)}}, options).front().parameter_covariance;
  Bank as_segments = load_two_features(bank_text());
  const Eigen::MatrixXd apart =
      fit(&as_segments, std::vector<ModeLogs>{{0, segments(false)}}, options).front().parameter_covariance;
  // Where the offsets dominate, each segment sums to about half its log's
  // S_g: as three logs 3/2 sum S_g^2 / SSE, as six segments
  // 6/5 * (sum S_g^2 / 2) / SSE, 2.5 times less.
  for (int p = 0; p < 6; ++p) EXPECT_GT(logs(p, p), 1.5 * apart(p, p)) << p;
}

// One log says nothing of how logs differ: the rows count as independent.
TEST(ParameterCovariance, PerLogWithOneLogIsTheIndependentRowsCovariance) {
  FitOptions options;
  options.window = 0.0;
  options.loss = "none";
  options.parameter_covariance = true;
  Trajectory log = regression_log(300, 5, Eigen::Vector2d(0.4, -0.4));
  log.log = "one";
  Bank independent_bank = load_two_features(bank_text());
  const FitReport independent = fit(&independent_bank, std::vector<ModeLogs>{{0, {log}}}, options).front();
  options.parameter_covariance_per_log = true;
  Bank bank = load_two_features(bank_text());
  const FitReport per_log = fit(&bank, std::vector<ModeLogs>{{0, {log}}}, options).front();
  EXPECT_EQ(per_log.parameter_covariance, independent.parameter_covariance);
  EXPECT_THAT(per_log.warnings, ::testing::Contains(HasSubstr("fitted on one log: its parameter covariance counts "
                                                              "the rows as independent")));
  EXPECT_THAT(independent.warnings, ::testing::Not(::testing::Contains(HasSubstr("fitted on one log"))));
}

TEST(ParameterCovariance, IsLeftEmptyUnlessAsked) {
  Bank bank = load_two_features(bank_text());
  FitOptions options;
  const FitReport report = fit(&bank, std::vector<ModeLogs>{{0, {regression_log(200, 3)}}}, options).front();
  EXPECT_EQ(report.parameter_covariance.size(), 0);
}

// A symmetric positive definite 6x6 matrix with couplings between every pair.
Eigen::MatrixXd some_covariance() {
  Eigen::MatrixXd l(6, 6);
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) l(r, c) = c <= r ? 0.1 * (1 + r) + 0.03 * (r - 2 * c) : 0.0;
  }
  return l * l.transpose();
}

std::string flow_matrix(const Eigen::MatrixXd& m) {
  std::string out = "[";
  for (Eigen::Index r = 0; r < m.rows(); ++r) {
    out += r ? ", [" : "[";
    for (Eigen::Index c = 0; c < m.cols(); ++c) {
      char number[40];
      std::snprintf(number, sizeof number, "%.17g", m(r, c));
      out += (c ? ", " : "") + std::string(number);
    }
    out += "]";
  }
  return out + "]";
}

// The process noise a covariance adds to the two-feature model at (u, dt),
// by hand: x+_i depends on B[i,:] and c[i] through Gamma_i (B[i,:] u + c_i),
// so the added covariance of states i and k is
//   Gamma_i Gamma_k sum_{p in i, q in k} phi_p Sigma_pq phi_q,  phi = (u1, u2, 1).
Eigen::Matrix2d added_by_hand(const Eigen::MatrixXd& sigma, const Eigen::Vector2d& u, double dt) {
  const int index[2][3] = {{0, 1, 4}, {2, 3, 5}};
  const double phi[3] = {u[0], u[1], 1.0};
  const double g[2] = {std::expm1(-2.0 * dt) / -2.0, std::expm1(-3.0 * dt) / -3.0};
  Eigen::Matrix2d added = Eigen::Matrix2d::Zero();
  for (int i = 0; i < 2; ++i) {
    for (int k = 0; k < 2; ++k) {
      for (int p = 0; p < 3; ++p) {
        for (int r = 0; r < 3; ++r) added(i, k) += phi[p] * sigma(index[i][p], index[k][r]) * phi[r];
      }
      added(i, k) *= g[i] * g[k];
    }
  }
  return added;
}

void expect_added_as_by_hand(const Eigen::MatrixXd& sigma) {
  const Bank plain = load_two_features(bank_text(), "plain.yaml");
  const Bank uncertain =
      load_two_features(bank_text("    parameter_covariance: " + flow_matrix(sigma) + "\n"), "uncertain.yaml");
  ASSERT_EQ(uncertain.config.modes[0].parameter_covariance.rows(), 6);
  const Eigen::MatrixXd q = plain.config.modes[0].q_intensity;
  const Eigen::Vector2d x(0.3, -0.2), u(2.5, -1.5);
  const double dt = 0.5;
  Eigen::MatrixXd without(2, 2), with(2, 2);
  ASSERT_TRUE(plain.models[0]->process_noise(q, x, u, dt, without));
  ASSERT_TRUE(uncertain.models[0]->process_noise(q, x, u, dt, with));
  const Eigen::Matrix2d added = added_by_hand(sigma, u, dt);
  for (int i = 0; i < 2; ++i) {
    for (int k = 0; k < 2; ++k) {
      EXPECT_NEAR(with(i, k), without(i, k) + added(i, k), 1e-12 * (1.0 + std::abs(added(i, k)))) << i << ", " << k;
    }
  }
  // Everything else is the model's own.
  Eigen::VectorXd a(2), b(2);
  ASSERT_TRUE(plain.models[0]->predict(x, u, dt, a));
  ASSERT_TRUE(uncertain.models[0]->predict(x, u, dt, b));
  EXPECT_EQ(a, b);
  EXPECT_TRUE(parameter_covariance_of(*uncertain.models[0]).isApprox(sigma, 1e-12));
  EXPECT_EQ(parameter_covariance_of(*plain.models[0]).size(), 0);
}

TEST(ParameterUncertainty, AddsPhiSigmaPhiToTheProcessNoise) { expect_added_as_by_hand(some_covariance()); }

// A covariance with exact zeros between the features' parameters (as a fit
// of separate regressions leaves it), which the filter skips, and one with
// a parameter of no variance (a held one).
TEST(ParameterUncertainty, AddsPhiSigmaPhiWhereTheCovarianceHasExactZeros) {
  Eigen::MatrixXd blocks = some_covariance();
  const int first[3] = {0, 1, 4}, second[3] = {2, 3, 5};
  for (int p : first) {
    for (int r : second) blocks(p, r) = blocks(r, p) = 0.0;
  }
  expect_added_as_by_hand(blocks);
  Eigen::MatrixXd held = blocks;
  held.row(1).setZero();
  held.col(1).setZero();
  expect_added_as_by_hand(held);
}

// The fixed-size filters keep a mode's F and Qd while dt repeats (its model
// says they depend on dt alone) and add G Sigma G' at each step, with that
// step's inputs; the dynamic kernel asks the model for all of it at every
// step. The two agree, and differ from the same bank without the covariance.
TEST(ParameterUncertainty, TheFiltersAddItAtEveryStepWithTheStepsInputs) {
  const std::string covariance = "    parameter_covariance: " + flow_matrix(some_covariance()) + "\n";
  Imm fixed(load_two_features(bank_text(covariance), "fixed.yaml"));
  Imm dynamic(load_two_features(bank_text(covariance), "dynamic.yaml"), ImmKernelChoice::kDynamic);
  Imm plain(load_two_features(bank_text(), "plain.yaml"));
  const Trajectory log = regression_log(60, 23);
  double largest_difference = 0.0;
  for (int k = 0; k < log.size(); ++k) {
    Eigen::Vector2d z = log.z.col(k);
    if (k % 3 == 1) z.setConstant(std::nan(""));  // predictions alone, some steps
    const ImmEstimate& a = fixed.step(log.t[static_cast<std::size_t>(k)], log.u.col(k), z);
    const ImmEstimate& b = dynamic.step(log.t[static_cast<std::size_t>(k)], log.u.col(k), z);
    const ImmEstimate& c = plain.step(log.t[static_cast<std::size_t>(k)], log.u.col(k), z);
    ASSERT_TRUE(a.covariance.isApprox(b.covariance, 1e-12)) << "step " << k << "\n" << a.covariance << "\n" << b.covariance;
    ASSERT_TRUE(a.state.isApprox(b.state, 1e-12)) << "step " << k;
    largest_difference = std::max(largest_difference, (a.covariance - c.covariance).cwiseAbs().maxCoeff());
  }
  EXPECT_GT(largest_difference, 1e-3);
}

// The wrapped model as it is, but for the rows of its parameter Jacobian it
// declares: none (the filter then scans the dense Jacobian), or `rows`.
class DeclaringOtherRows final : public sdk::MotionModel {
 public:
  DeclaringOtherRows(ModelHandle model, std::vector<std::vector<int>> rows)
      : model_(std::move(model)), rows_(std::move(rows)) {}
  int state_dim() const noexcept override { return model_->state_dim(); }
  int input_dim() const noexcept override { return model_->input_dim(); }
  const std::vector<std::string>& state_names() const noexcept override { return model_->state_names(); }
  const std::vector<std::string>& input_names() const noexcept override { return model_->input_names(); }
  const std::vector<sdk::ParameterInfo>& parameter_info() const noexcept override { return model_->parameter_info(); }
  void get_parameters(Eigen::Ref<Eigen::VectorXd> values) const noexcept override { model_->get_parameters(values); }
  bool set_parameters(const Eigen::Ref<const Eigen::VectorXd>& values, std::string* error) noexcept override {
    return model_->set_parameters(values, error);
  }
  bool predict(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
               Eigen::Ref<Eigen::VectorXd> x_next) const noexcept override {
    return model_->predict(x, u, dt, x_next);
  }
  bool parameter_jacobian(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u,
                          double dt, Eigen::Ref<Eigen::MatrixXd> jacobian) const noexcept override {
    return model_->parameter_jacobian(x, u, dt, jacobian);
  }
  const std::vector<std::vector<int>>& parameter_jacobian_rows() const noexcept override { return rows_; }
  bool process_noise(const Eigen::Ref<const Eigen::MatrixXd>& intensity, const Eigen::Ref<const Eigen::VectorXd>& x,
                     const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
                     Eigen::Ref<Eigen::MatrixXd> noise) const noexcept override {
    return model_->process_noise(intensity, x, u, dt, noise);
  }

 private:
  ModelHandle model_;
  std::vector<std::vector<int>> rows_;
};

// linear_features declares that each feature's B[i,:] and c[i] move state i
// alone, and the filter asks for those entries only. That adds the same
// numbers, bit for bit, as the scan of the dense parameter Jacobian it
// replaces, with blocks of one feature and with blocks that couple both.
TEST(ParameterUncertainty, DeclaredJacobianRowsAddWhatTheDenseJacobianAddsBitForBit) {
  const Bank plain = load_two_features(bank_text(), "declared.yaml");
  const ModelHandle model = plain.models[0];
  ASSERT_EQ(model->parameter_jacobian_rows(), (std::vector<std::vector<int>>{{0}, {0}, {1}, {1}, {0}, {1}}));
  Eigen::MatrixXd per_feature = some_covariance();
  for (int p : {0, 1, 4}) {
    for (int r : {2, 3, 5}) per_feature(p, r) = per_feature(r, p) = 0.0;
  }
  const Eigen::MatrixXd q = plain.config.modes[0].q_intensity;
  std::mt19937 rng(31);
  std::normal_distribution<double> normal(0.0, 2.0);
  for (const Eigen::MatrixXd& sigma : {some_covariance(), per_feature}) {
    const ModelHandle declared = with_parameter_uncertainty(model, sigma, kFeatureDt);
    const ModelHandle dense = with_parameter_uncertainty(
        ModelHandle(std::make_shared<DeclaringOtherRows>(model, std::vector<std::vector<int>>{})), sigma, kFeatureDt);
    for (int k = 0; k < 200; ++k) {
      const Eigen::Vector2d x(normal(rng), normal(rng));
      const Eigen::Vector2d u =
          k % 10 == 0 ? Eigen::Vector2d(0.0, normal(rng)) : Eigen::Vector2d(normal(rng), normal(rng));
      const double dt = k % 7 == 0 ? 0.0 : 0.05 * (1 + k % 5);
      Eigen::MatrixXd a(2, 2), b(2, 2);
      ASSERT_TRUE(declared->process_noise(q, x, u, dt, a));
      ASSERT_TRUE(dense->process_noise(q, x, u, dt, b));
      for (int i = 0; i < 4; ++i) {
        ASSERT_EQ(std::memcmp(a.data() + i, b.data() + i, sizeof(double)), 0) << "step " << k << "\n" << a << "\n" << b;
      }
      if (sigma(0, 2) == 0.0) continue;
      // One block coupling both rows, where the filter leaves out the terms
      // of G's zeros: the same bits as the sums over every term, in index
      // order, done here by hand.
      const Eigen::MatrixXd& used = parameter_covariance_of(*declared);  // as the model holds it
      Eigen::MatrixXd g(2, 6), every_term(2, 2);
      ASSERT_TRUE(model->parameter_jacobian(x, u, dt, g));
      ASSERT_TRUE(model->process_noise(q, x, u, dt, every_term));
      for (int r = 0; r < 2; ++r) {
        double column[6] = {0, 0, 0, 0, 0, 0};
        for (int c = 0; c < 6; ++c) {
          for (int l = 0; l < 6; ++l) column[l] += g(r, c) * used(l, c);
        }
        for (int s = 0; s <= r; ++s) {
          double added = 0.0;
          for (int l = 0; l < 6; ++l) added += column[l] * g(s, l);
          every_term(r, s) += added;
          if (s != r) every_term(s, r) += added;
        }
      }
      for (int i = 0; i < 4; ++i) {
        ASSERT_EQ(std::memcmp(a.data() + i, every_term.data() + i, sizeof(double)), 0) << "step " << k << "\n"
                                                                                       << a << "\n"
                                                                                       << every_term;
      }
    }
  }
}

TEST(ParameterUncertainty, DeclaredJacobianRowsThatDoNotFitTheModelAreABankError) {
  const Bank plain = load_two_features(bank_text(), "misdeclared.yaml");
  const auto declaring = [&](std::vector<std::vector<int>> rows) {
    return ModelHandle(std::make_shared<DeclaringOtherRows>(plain.models[0], std::move(rows)));
  };
  const Eigen::MatrixXd sigma = some_covariance();
  try {
    with_parameter_uncertainty(declaring({{0}, {1}}), sigma, kFeatureDt);
    FAIL() << "two lists for six parameters";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("parameter_jacobian_rows() lists 2 parameters; the model has 6"));
  }
  try {
    with_parameter_uncertainty(declaring({{0}, {0}, {1}, {1}, {0}, {2}}), sigma, kFeatureDt);
    FAIL() << "a row past the states";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("parameter 5 are not increasing rows of its 2 states"));
  }
  try {
    with_parameter_uncertainty(declaring({{0}, {0}, {1}, {1}, {1, 0}, {1}}), sigma, kFeatureDt);
    FAIL() << "rows out of order";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("parameter 4 are not increasing"));
  }
}

// The tune's path: a fit's covariance is taken as it is, unchecked but for
// its size, and gives the process noise a checked one gives.
TEST(ParameterUncertainty, AFittedCovarianceIsTakenAsItIsButItsSizeIsChecked) {
  const Eigen::MatrixXd sigma = some_covariance();
  Bank checked = load_two_features(bank_text(), "checked.yaml");
  Bank fitted = load_two_features(bank_text(), "fitted.yaml");
  set_parameter_covariance(&checked, 0, sigma);
  set_fitted_parameter_covariance(&fitted, 0, sigma);
  EXPECT_EQ(parameter_covariance_of(*fitted.models[0]), sigma);
  EXPECT_EQ(fitted.config.modes[0].parameter_covariance, sigma);
  const Eigen::MatrixXd q = fitted.config.modes[0].q_intensity;
  const Eigen::Vector2d x(0.1, 0.4), u(-0.5, 3.0);
  Eigen::MatrixXd a(2, 2), b(2, 2);
  ASSERT_TRUE(checked.models[0]->process_noise(q, x, u, 0.5, a));
  ASSERT_TRUE(fitted.models[0]->process_noise(q, x, u, 0.5, b));
  EXPECT_TRUE(b.isApprox(a, 1e-12));
  // Swapped for another, not stacked on it; an empty one removes it.
  set_fitted_parameter_covariance(&fitted, 0, 2.0 * sigma);
  EXPECT_EQ(parameter_covariance_of(*fitted.models[0]), 2.0 * sigma);
  set_fitted_parameter_covariance(&fitted, 0, Eigen::MatrixXd());
  EXPECT_EQ(parameter_covariance_of(*fitted.models[0]).size(), 0);
  EXPECT_EQ(fitted.config.modes[0].parameter_covariance.size(), 0);
  try {
    set_fitted_parameter_covariance(&fitted, 0, Eigen::MatrixXd::Identity(5, 5));
    ADD_FAILURE() << "took a 5x5 covariance for 6 parameters";
  } catch (const Error& e) {
    EXPECT_THAT(std::string(e.what()), HasSubstr("must be 6x6 (one row and column per parameter of the model), got 5x5"));
  }
}

// A tuner applies each fold's fit once per candidate setting: the model a
// mode had with a covariance is taken again for the same matrix, only while
// it wraps the bank's own model and the matrix holds the same values.
TEST(ParameterUncertainty, AKeptModelIsReusedOnlyForTheSameValuesOnTheSameModel) {
  Eigen::MatrixXd sigma = some_covariance();
  Bank bank = load_two_features(bank_text(), "kept.yaml");
  internal::KeptCovarianceModels kept;
  kept.set(&bank, 0, sigma);
  const ModelHandle first = bank.models[0];
  EXPECT_EQ(parameter_covariance_of(*first), sigma);
  EXPECT_EQ(bank.config.modes[0].parameter_covariance, sigma);
  // Between scorings the tuner puts the starting values back: no covariance.
  set_fitted_parameter_covariance(&bank, 0, Eigen::MatrixXd());
  kept.set(&bank, 0, sigma);
  EXPECT_EQ(bank.models[0].get(), first.get());
  EXPECT_EQ(bank.config.modes[0].parameter_covariance, sigma);
  // The same matrix with other values: wrapped again, with those.
  set_fitted_parameter_covariance(&bank, 0, Eigen::MatrixXd());
  sigma *= 3.0;
  kept.set(&bank, 0, sigma);
  EXPECT_NE(bank.models[0].get(), first.get());
  EXPECT_EQ(parameter_covariance_of(*bank.models[0]), sigma);
  EXPECT_EQ(bank.config.modes[0].parameter_covariance, sigma);
  // The bank's model replaced by another: the one kept wraps the old one.
  const ModelHandle tripled = bank.models[0];
  Bank other = load_two_features(bank_text(), "other.yaml");
  bank.models[0] = other.models[0];
  kept.set(&bank, 0, sigma);
  EXPECT_NE(bank.models[0].get(), tripled.get());
  EXPECT_EQ(parameter_covariance_of(*bank.models[0]), sigma);
  // And what it adds to the process noise is the covariance's, as set directly.
  Bank direct = load_two_features(bank_text(), "direct.yaml");
  set_fitted_parameter_covariance(&direct, 0, sigma);
  const Eigen::MatrixXd q = direct.config.modes[0].q_intensity;
  const Eigen::Vector2d x(0.1, 0.4), u(-0.5, 3.0);
  Eigen::MatrixXd a(2, 2), b(2, 2);
  ASSERT_TRUE(direct.models[0]->process_noise(q, x, u, 0.5, a));
  ASSERT_TRUE(bank.models[0]->process_noise(q, x, u, 0.5, b));
  EXPECT_EQ(a, b);
  // An empty covariance removes it.
  kept.set(&bank, 0, Eigen::MatrixXd());
  EXPECT_EQ(parameter_covariance_of(*bank.models[0]).size(), 0);
  EXPECT_EQ(bank.config.modes[0].parameter_covariance.size(), 0);
}

void expect_bank_error(const std::string& covariance, const std::string& what) {
  try {
    load_two_features(bank_text("    parameter_covariance: " + covariance + "\n"), "bad.yaml");
    ADD_FAILURE() << "loaded a bank with parameter_covariance " << covariance;
  } catch (const ConfigError& e) {
    EXPECT_THAT(std::string(e.what()), HasSubstr("bad.yaml"));
    EXPECT_THAT(std::string(e.what()), HasSubstr("modes[0].parameter_covariance"));
    EXPECT_THAT(std::string(e.what()), HasSubstr(what));
  }
}

TEST(ParameterUncertainty, BankErrorsNameTheFileTheFieldAndWhatWasExpected) {
  Eigen::MatrixXd five = Eigen::MatrixXd::Identity(5, 5);
  expect_bank_error(flow_matrix(five), "must be 6x6 (one row and column per parameter of the model), got 5x5");
  Eigen::MatrixXd asymmetric = Eigen::MatrixXd::Identity(6, 6);
  asymmetric(0, 1) = 0.5;
  expect_bank_error(flow_matrix(asymmetric), "not symmetric");
  Eigen::MatrixXd indefinite = Eigen::MatrixXd::Identity(6, 6);
  indefinite(0, 0) = -1.0;
  expect_bank_error(flow_matrix(indefinite), "not positive semidefinite");
  expect_bank_error("[[1, 0], [0, 1, 2]]", "this row has 3 numbers and row 0 has 2");
  expect_bank_error("[1, 2, 3]", "expected a 3x3 matrix, got 3x1");
  expect_bank_error("{diagonal: [1, 1, 1, 1, 1, nan]}", "");
}

TEST(ParameterUncertainty, ADiagonalCovarianceIsAccepted) {
  const Bank bank = load_two_features(bank_text("    parameter_covariance: {diagonal: [1, 2, 3, 4, 5, 6]}\n"));
  EXPECT_EQ(bank.config.modes[0].parameter_covariance.diagonal(), (Eigen::VectorXd(6) << 1, 2, 3, 4, 5, 6).finished());
}

TEST(ParameterUncertainty, FitBankAndTuningSetTheCovarianceAndARefitWithoutItRemovesIt) {
  Bank bank = load_two_features(bank_text());
  BankFitOptions options;
  options.objective = Objective::kWindow;
  options.window.loss = "none";
  options.parameter_uncertainty = true;
  const std::vector<ModeLogs> data{{0, {regression_log(300, 5)}}};
  const FitReport report = fit_bank(&bank, data, options).at(0);
  ASSERT_EQ(report.parameter_covariance.rows(), 6);
  EXPECT_EQ(bank.config.modes[0].parameter_covariance, report.parameter_covariance);
  EXPECT_EQ(parameter_covariance_of(*bank.models[0]), report.parameter_covariance);
  // Tuning carries it from a fold's fit to the bank it scores.
  const FittedValues values = values_of(bank);
  Bank other = load_two_features(bank_text(), "other.yaml");
  apply(values, TunedSettings{}, &other);
  EXPECT_EQ(other.config.modes[0].parameter_covariance, report.parameter_covariance);
  EXPECT_EQ(parameter_covariance_of(*other.models[0]), report.parameter_covariance);
  // Refitted without the option, the old covariance (of other parameters) goes.
  options.parameter_uncertainty = false;
  fit_bank(&bank, data, options);
  EXPECT_EQ(bank.config.modes[0].parameter_covariance.size(), 0);
  EXPECT_EQ(parameter_covariance_of(*bank.models[0]).size(), 0);
}

// fit_bank (which fit and tune call) counts each log's rows as correlated
// when asked: the same covariance as the fit's own option gives.
TEST(ParameterUncertainty, FitBankCountsEachLogsRowsAsCorrelatedWhenAsked) {
  const std::vector<Trajectory> logs = logs_each_off_its_line();
  BankFitOptions options;
  options.objective = Objective::kWindow;
  options.window.loss = "none";
  options.parameter_uncertainty = true;
  Bank independent = load_two_features(bank_text());
  fit_bank(&independent, std::vector<ModeLogs>{{0, logs}}, options);
  options.uncertainty_per_log = true;
  Bank per_log = load_two_features(bank_text(), "per_log.yaml");
  fit_bank(&per_log, std::vector<ModeLogs>{{0, logs}}, options);
  FitOptions direct;
  direct.loss = "none";
  direct.parameter_covariance = true;
  direct.parameter_covariance_per_log = true;
  Bank reference = load_two_features(bank_text(), "reference.yaml");
  const FitReport report = fit(&reference, std::vector<ModeLogs>{{0, logs}}, direct).front();
  EXPECT_EQ(per_log.config.modes[0].parameter_covariance, report.parameter_covariance);
  EXPECT_GT(per_log.config.modes[0].parameter_covariance(4, 4),
            10.0 * independent.config.modes[0].parameter_covariance(4, 4));
}

TEST(ParameterUncertainty, TheLikelihoodObjectiveRefusesIt) {
  Bank bank = load_two_features(bank_text());
  BankFitOptions options;
  options.objective = Objective::kLikelihood;
  options.parameter_uncertainty = true;
  EXPECT_THROW(fit_bank(&bank, std::vector<ModeLogs>{{0, {regression_log(100, 9)}}}, options), FitError);
}

}  // namespace
}  // namespace fitting
}  // namespace skidimm
