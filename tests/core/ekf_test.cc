#include "skidimm/engine/ekf.h"

#include <gtest/gtest.h>

#include <Eigen/LU>
#include <cmath>
#include <limits>

#include "core/test_banks.h"
#include "fixed_size_ekf.h"
#include "skidimm/engine/measurement_model.h"
#include "stc_kinematic/stc_kinematic_model.h"

namespace skidimm {
namespace {

using skidimm_test::ScalarLinearModel;

TEST(ExtendedKalmanFilter, ScalarStepMatchesClosedForm) {
  ScalarLinearModel model(-1.0, 2.0);
  ExtendedKalmanFilter filter(model, Eigen::MatrixXd::Constant(1, 1, 0.5), 1);
  filter.state()[0] = 1.0;
  filter.covariance()(0, 0) = 2.0;
  ASSERT_TRUE(filter.predict(Eigen::VectorXd::Constant(1, 3.0), 0.1));
  // x- = 1 + (-1 + 6) 0.1 = 1.5; P- = 0.9^2 * 2 + 0.5 * 0.1 = 1.67
  EXPECT_NEAR(filter.state()[0], 1.5, 1e-15);
  EXPECT_NEAR(filter.covariance()(0, 0), 1.67, 1e-15);

  MeasurementModel measurement(Eigen::MatrixXd::Ones(1, 1), Eigen::MatrixXd::Constant(1, 1, 0.33), {false});
  SelectedMeasurement selected = measurement.make_selection();
  measurement.select(Eigen::VectorXd::Constant(1, 2.0), &selected);
  const UpdateResult result = filter.update(selected);
  ASSERT_TRUE(result.ok);
  // S = 2, K = 0.835, nu = 0.5: x+ = 1.9175, P+ = (1-K)^2 P- + K^2 R = 0.27555.
  EXPECT_NEAR(filter.state()[0], 1.9175, 1e-14);
  EXPECT_NEAR(filter.covariance()(0, 0), 0.165 * 0.165 * 1.67 + 0.835 * 0.835 * 0.33, 1e-14);
  EXPECT_NEAR(result.nis, 0.125, 1e-15);
  EXPECT_NEAR(result.log_likelihood, -0.5 * (0.125 + std::log(2.0 * M_PI * 2.0)), 1e-14);
}

TEST(ExtendedKalmanFilter, JosephUpdateEqualsTheStandardFormForTheOptimalGain) {
  skidimm::sdk::ParameterSet params;
  Eigen::Matrix2d a, b;
  a << -2, 0.3, 0.1, -1;
  b << 0.4, 0.4, -0.8, 0.8;
  auto model = skidimm_test::make_ltc(a, b);
  ExtendedKalmanFilter filter(*model, Eigen::Matrix2d::Identity() * 0.1, 2);
  Eigen::Matrix2d p;
  p << 0.7, 0.2, 0.2, 0.4;
  filter.covariance() = p;
  filter.state() = Eigen::Vector2d(0.3, -0.1);
  Eigen::MatrixXd h(2, 2), r(2, 2);
  h << 1.0, 0.5, 0.0, 1.0;
  r << 0.05, 0.01, 0.01, 0.08;
  MeasurementModel measurement(h, r, {false, false});
  SelectedMeasurement selected = measurement.make_selection();
  measurement.select(Eigen::Vector2d(0.4, 0.2), &selected);
  ASSERT_TRUE(filter.update(selected).ok);
  // Independent: K = P H' S^-1 with an explicit inverse, P+ = (I - K H) P.
  const Eigen::Matrix2d s = h * p * h.transpose() + r;
  const Eigen::Matrix2d k = p * h.transpose() * s.inverse();
  const Eigen::Matrix2d expected = (Eigen::Matrix2d::Identity() - k * h) * p;
  EXPECT_TRUE(filter.covariance().isApprox(expected, 1e-12));
  EXPECT_TRUE(filter.state().isApprox(
      Eigen::Vector2d(0.3, -0.1) + k * (Eigen::Vector2d(0.4, 0.2) - h * Eigen::Vector2d(0.3, -0.1)), 1e-12));
}

TEST(ExtendedKalmanFilter, SingularInnovationCovarianceIsReportedNotCrashed) {
  ScalarLinearModel model(0.0, 0.0);
  ExtendedKalmanFilter filter(model, Eigen::MatrixXd::Zero(1, 1), 1);
  filter.covariance()(0, 0) = 0.0;
  MeasurementModel measurement(Eigen::MatrixXd::Ones(1, 1), Eigen::MatrixXd::Zero(1, 1), {false});
  SelectedMeasurement selected = measurement.make_selection();
  measurement.select(Eigen::VectorXd::Constant(1, 1.0), &selected);
  EXPECT_FALSE(filter.update(selected).ok);
}

// The fixed-size filter the IMM's kernels run agrees with
// ExtendedKalmanFilter: a heading across the seam, every subset of rows.
TEST(FixedSizeFilter, AgreesWithTheDynamicFilterOnEverySubsetOfRows) {
  sdk::ParameterSet params;
  params.set_scalar("k", 0.9);
  params.set_scalar("m", 0.6);
  params.set_scalar("r", 0.165);
  params.set_scalar("b", 0.555);
  std::string error;
  const auto model = plugins::StcKinematicModel::Create(params, &error);
  ASSERT_TRUE(model) << error;
  const Eigen::Matrix3d q = Eigen::Vector3d(1e-3, 2e-3, 3e-3).asDiagonal();
  Eigen::Matrix3d r;
  r << 9e-4, 1e-4, 0, 1e-4, 9e-4, 0, 0, 0, 4e-4;
  const MeasurementModel measurement(Eigen::Matrix3d::Identity(), r, {false, false, true});
  SelectedMeasurement selected = measurement.make_selection();
  const Eigen::Vector2d u(2.0, 12.0);
  for (int rows = 1; rows < 8; ++rows) {  // every non-empty subset of {X, Y, theta}
    ExtendedKalmanFilter dynamic(*model, q, 3);
    Eigen::Vector3d x(1.0, -2.0, 3.1);
    Eigen::Matrix3d p;
    p << 0.02, 0.005, 0.001, 0.005, 0.03, -0.002, 0.001, -0.002, 0.01;
    dynamic.state() = x;
    dynamic.covariance() = p;
    for (int k = 0; k < 30; ++k) {
      ASSERT_TRUE(dynamic.predict(u, 0.02));
      ASSERT_TRUE(predict_fixed<3>(*model, q, 0b100, u, 0.02, &x, &p));
      ASSERT_LT((dynamic.state() - x).cwiseAbs().maxCoeff(), 1e-13) << "step " << k;
      ASSERT_LT((dynamic.covariance() - p).cwiseAbs().maxCoeff(), 1e-14) << "step " << k;
      Eigen::Vector3d z(1.0 + 0.1 * k, -2.0 + 0.05 * k, sdk::wrap_angle(3.1 + 0.3 * k));
      for (int a = 0; a < 3; ++a) {
        if (!(rows >> a & 1)) z[a] = std::numeric_limits<double>::quiet_NaN();
      }
      measurement.select(z, &selected);
      const UpdateResult expected = dynamic.update(selected);
      UpdateResult actual;
      const int n = selected.size;
      AngleMask z_angles = 0;
      for (int a = 0; a < n; ++a) z_angles |= selected.is_angle[a] ? 1u << a : 0u;
      if (n == 1) {
        actual = update_fixed<3, 1>(selected.z.head<1>(), selected.h.topRows<1>(), selected.r.topLeftCorner<1, 1>(),
                                    z_angles, 0b100, &x, &p);
      } else if (n == 2) {
        actual = update_fixed<3, 2>(selected.z.head<2>(), selected.h.topRows<2>(), selected.r.topLeftCorner<2, 2>(),
                                    z_angles, 0b100, &x, &p);
      } else {
        actual = update_fixed<3, 3>(selected.z.head<3>(), selected.h.topRows<3>(), selected.r.topLeftCorner<3, 3>(),
                                    z_angles, 0b100, &x, &p);
      }
      ASSERT_EQ(actual.ok, expected.ok);
      ASSERT_NEAR(actual.log_likelihood, expected.log_likelihood, 1e-12 * std::max(1.0, std::abs(expected.log_likelihood)));
      ASSERT_NEAR(actual.nis, expected.nis, 1e-12 * std::max(1.0, expected.nis));
      ASSERT_LT((dynamic.state() - x).cwiseAbs().maxCoeff(), 1e-13) << "rows " << rows << " step " << k;
      ASSERT_LT((dynamic.covariance() - p).cwiseAbs().maxCoeff(), 1e-14) << "rows " << rows << " step " << k;
    }
  }
}

TEST(FixedSizeFilter, ANonPositiveDefiniteInnovationIsReportedLikeTheDynamicFilter) {
  Eigen::Matrix<double, 1, 1> z, r;
  z << 1.0;
  r << 0.0;
  Eigen::Matrix<double, 1, 2> h(1.0, 0.0);
  Eigen::Vector2d x(0.0, 0.0);
  Eigen::Matrix2d p = Eigen::Matrix2d::Zero();
  EXPECT_FALSE((update_fixed<2, 1>(z, h, r, 0, 0, &x, &p).ok));
  p(0, 0) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE((update_fixed<2, 1>(z, h, r, 0, 0, &x, &p).ok));
}

// H = I skips the products with H (copies and I - K, update_fixed()); the
// products give the same numbers, so the two paths agree to the bit.
TEST(FixedSizeFilter, AnIdentityHIsTheProductsToTheBit) {
  const Eigen::Matrix3d h = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d r;
  r << 0.04, 0.001, 0.0, 0.001, 0.09, -0.002, 0.0, -0.002, 0.0009;
  Eigen::Vector3d x_product(1.0, -2.0, 3.1), x_identity = x_product;
  Eigen::Matrix3d p_product;
  p_product << 0.02, 0.005, 0.001, 0.005, 0.03, -0.002, 0.001, -0.002, 0.01;
  Eigen::Matrix3d p_identity = p_product;
  for (int k = 0; k < 20; ++k) {
    const Eigen::Vector3d z(1.0 + 0.1 * k, -2.0 + 0.07 * k, sdk::wrap_angle(3.1 + 0.3 * k));
    const double gate = std::numeric_limits<double>::infinity();
    Eigen::Vector3d whitened_product, whitened_identity;
    const UpdateResult product =
        update_fixed<3, 3>(z, h, r, 0b100, 0b100, &x_product, &p_product, gate, &whitened_product, false);
    const UpdateResult identity =
        update_fixed<3, 3>(z, h, r, 0b100, 0b100, &x_identity, &p_identity, gate, &whitened_identity, true);
    ASSERT_TRUE(product.ok && identity.ok);
    ASSERT_EQ(identity.log_likelihood, product.log_likelihood) << "step " << k;
    ASSERT_EQ(identity.nis, product.nis) << "step " << k;
    ASSERT_EQ(whitened_identity, whitened_product) << "step " << k;
    ASSERT_EQ(x_identity, x_product) << "step " << k;
    ASSERT_EQ(p_identity, p_product) << "step " << k;
    // Let the covariance grow again, as a prediction would.
    p_product += 0.01 * Eigen::Matrix3d::Identity();
    p_identity += 0.01 * Eigen::Matrix3d::Identity();
  }
}

// H rows that pick states are applied by gathering rows and columns of P
// (ekf.cc); the general product path must give the same numbers, to the bit
// when no state is picked twice, with rows missing, reordered and repeated.
TEST(ExtendedKalmanFilter, UpdateThatGathersPickedStatesEqualsTheProductPathExactly) {
  Eigen::Matrix2d a, b;
  a << -2, 0.3, 0.1, -1;
  b << 0.4, 0.4, -0.8, 0.8;
  auto model = skidimm_test::make_ltc(a, b);
  Eigen::MatrixXd h(3, 2), r(3, 3);
  h << 0.0, 1.0, 1.0, 0.0, 0.0, 1.0;  // omega, V, omega again
  r << 0.05, 0.01, 0.0, 0.01, 0.08, 0.002, 0.0, 0.002, 0.03;
  const MeasurementModel measurement(h, r, {false, false, false});
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (const Eigen::Vector3d& z : {Eigen::Vector3d(0.4, 0.2, 0.41), Eigen::Vector3d(nan, 0.2, 0.39),
                                   Eigen::Vector3d(0.4, nan, nan)}) {
    SelectedMeasurement gathered = measurement.make_selection();
    measurement.select(z, &gathered);
    ASSERT_TRUE(gathered.picks_states);
    SelectedMeasurement multiplied = gathered;
    multiplied.picks_states = false;
    ExtendedKalmanFilter first(*model, Eigen::Matrix2d::Identity() * 0.1, 3);
    ExtendedKalmanFilter second(*model, Eigen::Matrix2d::Identity() * 0.1, 3);
    for (ExtendedKalmanFilter* f : {&first, &second}) {
      f->state() = Eigen::Vector2d(0.3, -0.1);
      f->covariance() << 0.7, 0.2, 0.2, 0.4;
    }
    const UpdateResult x = first.update(gathered);
    const UpdateResult y = second.update(multiplied);
    ASSERT_TRUE(x.ok && y.ok);
    if (gathered.size < 3) {
      EXPECT_EQ(x.nis, y.nis);
      EXPECT_EQ(x.log_likelihood, y.log_likelihood);
      EXPECT_EQ(first.state(), second.state());
      EXPECT_EQ(first.covariance(), second.covariance());
    } else {  // omega twice: I - K H sums two gains in an order of its own
      EXPECT_NEAR(x.nis, y.nis, 1e-14 * std::abs(y.nis));
      EXPECT_NEAR((first.state() - second.state()).cwiseAbs().maxCoeff(), 0.0, 1e-15);
      EXPECT_NEAR((first.covariance() - second.covariance()).cwiseAbs().maxCoeff(), 0.0, 1e-15);
    }
  }
}

TEST(MeasurementModel, PicksStatesOnlyWhenEverySelectedRowIsOneUnitEntry) {
  Eigen::MatrixXd h(3, 2);
  h << 1.0, 0.0, 0.0, 2.0, 0.5, 0.5;  // picks V; 2 omega; a blend
  const MeasurementModel measurement(h, Eigen::Matrix3d::Identity(), {false, false, false});
  SelectedMeasurement s = measurement.make_selection();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  measurement.select(Eigen::Vector3d(1.0, nan, nan), &s);
  EXPECT_TRUE(s.picks_states);
  EXPECT_EQ(s.picked_state[0], 0);
  measurement.select(Eigen::Vector3d(1.0, 1.0, nan), &s);
  EXPECT_FALSE(s.picks_states);  // a gain of 2 is no pick
  measurement.select(Eigen::Vector3d(nan, nan, 1.0), &s);
  EXPECT_FALSE(s.picks_states);
}

// A diagonal F scales P's rows and columns (ekf.cc): P- = F P F' + Qd by hand.
TEST(ExtendedKalmanFilter, PredictWithADiagonalJacobianIsFPFPlusQ) {
  Eigen::Matrix2d a, b;
  a << -2, 0.0, 0.0, -1;  // decoupled: F = diag(e^{-2 dt}, e^{-dt}) to first order
  b << 0.4, 0.4, -0.8, 0.8;
  auto model = skidimm_test::make_ltc(a, b);
  const Eigen::Matrix2d q = Eigen::Matrix2d::Identity() * 0.1;
  ExtendedKalmanFilter filter(*model, q, 2);
  Eigen::Matrix2d p;
  p << 0.7, 0.2, 0.2, 0.4;
  filter.covariance() = p;
  filter.state() = Eigen::Vector2d(0.3, -0.1);
  const Eigen::Vector2d u(1.0, 2.0);
  Eigen::MatrixXd f(2, 2), qd(2, 2);
  ASSERT_TRUE(model->jacobian(filter.state(), u, 0.05, f));
  ASSERT_TRUE(model->process_noise(q, filter.state(), u, 0.05, qd));
  ASSERT_EQ(f(0, 1), 0.0);
  ASSERT_EQ(f(1, 0), 0.0);
  ASSERT_TRUE(filter.predict(u, 0.05));
  const Eigen::Matrix2d expected = f * p * f.transpose() + qd;
  EXPECT_NEAR((filter.covariance() - expected).cwiseAbs().maxCoeff(), 0.0, 1e-16);
}

TEST(MeasurementModel, SelectsTheFiniteRowsWithTheirBlockOfR) {
  Eigen::MatrixXd h = Eigen::MatrixXd::Identity(3, 3);
  Eigen::MatrixXd r(3, 3);
  r << 1, 0.1, 0.2, 0.1, 2, 0.3, 0.2, 0.3, 3;
  MeasurementModel measurement(h, r, {false, false, true});
  SelectedMeasurement s = measurement.make_selection();
  measurement.select(Eigen::Vector3d(5.0, std::numeric_limits<double>::quiet_NaN(), 7.0), &s);
  ASSERT_EQ(s.size, 2);
  EXPECT_EQ(s.rows[0], 0);
  EXPECT_EQ(s.rows[1], 2);
  EXPECT_EQ(s.z[1], 7.0);
  EXPECT_EQ(s.r(0, 1), 0.2);
  EXPECT_EQ(s.r(1, 1), 3.0);
  EXPECT_TRUE(s.is_angle[1]);
  EXPECT_EQ(s.h(1, 2), 1.0);
}

// x' = A x + B u over dt (forward Euler), any n states: a diagonal A or a
// coupled one; the last state is a heading.
class LinearStates : public sdk::MotionModel {
 public:
  LinearStates(int n, bool coupled) : a_(Eigen::MatrixXd::Zero(n, n)), names_(static_cast<std::size_t>(n), "x") {
    for (int i = 0; i < n; ++i) a_(i, i) = -1.0 - 0.3 * i;
    for (int i = 0; coupled && i + 1 < n; ++i) a_(i, i + 1) = 0.2;
  }
  int state_dim() const noexcept override { return static_cast<int>(a_.rows()); }
  int input_dim() const noexcept override { return 1; }
  const std::vector<std::string>& state_names() const noexcept override { return names_; }
  const std::vector<std::string>& input_names() const noexcept override { return inputs_; }
  bool is_angle(int i) const noexcept override { return i == a_.rows() - 1; }
  const std::vector<sdk::ParameterInfo>& parameter_info() const noexcept override { return info_; }
  void get_parameters(Eigen::Ref<Eigen::VectorXd>) const noexcept override {}
  bool set_parameters(const Eigen::Ref<const Eigen::VectorXd>&, std::string*) noexcept override { return true; }
  bool predict(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
               Eigen::Ref<Eigen::VectorXd> next) const noexcept override {
    next = x + (a_ * x + Eigen::VectorXd::LinSpaced(x.size(), 0.5, 1.5) * u[0]) * dt;
    next[next.size() - 1] = sdk::wrap_angle(next[next.size() - 1]);
    return true;
  }
  bool jacobian(const Eigen::Ref<const Eigen::VectorXd>&, const Eigen::Ref<const Eigen::VectorXd>&, double dt,
                Eigen::Ref<Eigen::MatrixXd> f) const noexcept override {
    f = Eigen::MatrixXd::Identity(a_.rows(), a_.rows()) + a_ * dt;
    return true;
  }
  bool has_analytic_jacobian() const noexcept override { return true; }

 private:
  Eigen::MatrixXd a_;
  std::vector<std::string> names_, inputs_{"u"};
  std::vector<sdk::ParameterInfo> info_;
};

// The filter for N states and any measurement rows (the IMM's kernels from 5
// states, or past 4 rows) agrees with ExtendedKalmanFilter to round-off:
// rows that pick states and rows that measure sums, correlated R, a heading
// across the seam, rows missing.
template <int N>
void expect_fixed_states_agree_with_the_dynamic_filter(bool coupled, bool sums) {
  SCOPED_TRACE("states " + std::to_string(N) + (coupled ? ", coupled" : ", diagonal") + (sums ? ", sums" : ""));
  const LinearStates model(N, coupled);
  const int m = sums ? N + 2 : N;
  Eigen::MatrixXd h = Eigen::MatrixXd::Zero(m, N);
  for (int a = 0; a < m; ++a) h(a, a % N) = 1.0;
  for (int a = N; a < m; ++a) h(a, (a + 1) % N) += 0.5;
  Eigen::MatrixXd r = Eigen::MatrixXd::Identity(m, m) * 0.01;
  r(0, 1) = r(1, 0) = 0.002;
  std::vector<bool> row_is_angle(static_cast<std::size_t>(m), false);
  row_is_angle[N - 1] = true;
  const MeasurementModel measurement(h, r, row_is_angle);
  SelectedMeasurement selected = measurement.make_selection();
  SelectedUpdateWorkspace<N> workspace(m);
  const Eigen::Matrix<double, N, N> q = Eigen::Matrix<double, N, 1>::LinSpaced(1e-3, 4e-3).asDiagonal();
  ExtendedKalmanFilter dynamic(model, q, m);
  Eigen::Matrix<double, N, 1> x = Eigen::Matrix<double, N, 1>::Constant(3.0);
  Eigen::Matrix<double, N, N> p = Eigen::Matrix<double, N, N>::Identity() * 0.5;
  p(0, N - 1) = p(N - 1, 0) = 0.1;
  dynamic.state() = x;
  dynamic.covariance() = p;
  const AngleMask state_angles = 1u << (N - 1);
  for (int k = 0; k < 60; ++k) {
    const Eigen::VectorXd u = Eigen::VectorXd::Constant(1, std::sin(0.2 * k));
    ASSERT_TRUE(dynamic.predict(u, 0.05));
    ASSERT_TRUE(predict_fixed<N>(model, q, state_angles, u, 0.05, &x, &p));
    ASSERT_LT((dynamic.state() - x).cwiseAbs().maxCoeff(), 1e-13) << "step " << k;
    ASSERT_LT((dynamic.covariance() - p).cwiseAbs().maxCoeff(), 1e-14) << "step " << k;
    Eigen::VectorXd z(m);
    for (int a = 0; a < m; ++a) z[a] = 3.0 + 0.5 * std::sin(0.1 * k + a);
    z[N - 1] = sdk::wrap_angle(3.0 + 0.4 * k);
    for (int a = 0; a < m; ++a) {
      if ((k + a) % 5 == 0) z[a] = std::numeric_limits<double>::quiet_NaN();  // rows missing, different ones each step
    }
    measurement.select(z, &selected);
    const UpdateResult expected = dynamic.update(selected);
    const UpdateResult actual = update_selected<N>(selected, state_angles, &x, &p, &workspace);
    ASSERT_EQ(actual.ok, expected.ok) << "step " << k;
    ASSERT_NEAR(actual.log_likelihood, expected.log_likelihood,
                1e-11 * std::max(1.0, std::abs(expected.log_likelihood)))
        << "step " << k;
    ASSERT_NEAR(actual.nis, expected.nis, 1e-11 * std::max(1.0, expected.nis)) << "step " << k;
    ASSERT_LT((dynamic.state() - x).cwiseAbs().maxCoeff(), 1e-13) << "step " << k;
    ASSERT_LT((dynamic.covariance() - p).cwiseAbs().maxCoeff(), 1e-14) << "step " << k;
    for (int i = 0; i < N; ++i) {
      for (int j = 0; j < i; ++j) ASSERT_EQ(p(i, j), p(j, i)) << "P symmetric, step " << k;
    }
  }
}

TEST(FixedStateFilter, AgreesWithTheDynamicFilterForAnyMeasurementRows) {
  for (const bool coupled : {false, true}) {
    for (const bool sums : {false, true}) {
      expect_fixed_states_agree_with_the_dynamic_filter<3>(coupled, sums);
      expect_fixed_states_agree_with_the_dynamic_filter<5>(coupled, sums);
      expect_fixed_states_agree_with_the_dynamic_filter<9>(coupled, sums);
      expect_fixed_states_agree_with_the_dynamic_filter<12>(coupled, sums);
    }
  }
}

// Every row measured (k = N) runs loops of fixed length; they must do what
// the loops of runtime length do, in the same order, so give the same bits:
// for a direct and a summed measurement, a correlated R, an angle row, and a
// measurement precise enough for the Joseph form.
template <int N>
void expect_fixed_row_count_is_the_same_update_to_the_bit(bool sums, double r_scale) {
  SCOPED_TRACE("states " + std::to_string(N) + (sums ? ", sums" : ", direct") + ", R x " + std::to_string(r_scale));
  Eigen::MatrixXd h = Eigen::MatrixXd::Identity(N, N);
  if (sums) {
    for (int a = 0; a + 1 < N; ++a) h(a, a + 1) = 0.5;
  }
  Eigen::MatrixXd r = Eigen::MatrixXd::Identity(N, N) * 0.01 * r_scale;
  r(0, 1) = r(1, 0) = 0.002 * r_scale;
  std::vector<bool> row_is_angle(static_cast<std::size_t>(N), false);
  row_is_angle[N - 1] = !sums;
  const MeasurementModel measurement(h, r, row_is_angle);
  Eigen::Matrix<double, N, N> a = Eigen::Matrix<double, N, N>::Random();
  const Eigen::Matrix<double, N, N> p0 = a * a.transpose() + Eigen::Matrix<double, N, N>::Identity();
  const Eigen::Matrix<double, N, 1> x0 = Eigen::Matrix<double, N, 1>::Random();
  for (int k = 0; k < 5; ++k) {
    SelectedMeasurement selected = measurement.make_selection();
    measurement.select(Eigen::VectorXd::LinSpaced(N, -1.0 + k, 1.0 + 2 * k), &selected);
    ASSERT_EQ(selected.size, N);
    Eigen::Matrix<double, N, 1> x_fixed = x0, x_runtime = x0;
    Eigen::Matrix<double, N, N> p_fixed = p0, p_runtime = p0;
    SelectedUpdateWorkspace<N> w_fixed(N), w_runtime(N);
    const double gate = k == 4 ? 1.0 : std::numeric_limits<double>::infinity();  // the last one gated
    const UpdateResult fixed = update_selected_rows<N, N>(selected, 1u << (N - 1), &x_fixed, &p_fixed, &w_fixed, gate);
    const UpdateResult runtime =
        update_selected_rows<N, 0>(selected, 1u << (N - 1), &x_runtime, &p_runtime, &w_runtime, gate);
    ASSERT_TRUE(fixed.ok);
    EXPECT_EQ(fixed.ok, runtime.ok);
    EXPECT_EQ(fixed.gated, runtime.gated);
    EXPECT_EQ(fixed.log_likelihood, runtime.log_likelihood);
    EXPECT_EQ(fixed.nis, runtime.nis);
    EXPECT_TRUE(x_fixed == x_runtime);
    EXPECT_TRUE(p_fixed == p_runtime);
    EXPECT_TRUE(w_fixed.whitened == w_runtime.whitened);
  }
}

TEST(FixedStateFilter, EveryRowMeasuredIsTheSameUpdateToTheBitAsAnyRows) {
  for (const bool sums : {false, true}) {
    for (const double r_scale : {1.0, 1e-14}) {
      expect_fixed_row_count_is_the_same_update_to_the_bit<5>(sums, r_scale);
      expect_fixed_row_count_is_the_same_update_to_the_bit<9>(sums, r_scale);
      expect_fixed_row_count_is_the_same_update_to_the_bit<12>(sums, r_scale);
    }
  }
}

// A measurement far more precise than the prediction: P- - W W' would cancel
// nearly all of each variance's digits (what is left, about R, is round-off
// of P-), so the update takes the Joseph form and agrees with
// ExtendedKalmanFilter's to the last digits that matter.
TEST(FixedStateFilter, AMeasurementFarMorePreciseThanThePredictionTakesTheJosephForm) {
  constexpr int N = 9;
  const LinearStates model(N, true);
  Eigen::Matrix<double, N, N> a = Eigen::Matrix<double, N, N>::Random();
  Eigen::Matrix<double, N, N> p = 1e6 * (a * a.transpose() + Eigen::Matrix<double, N, N>::Identity());
  const Eigen::Matrix<double, N, 1> x0 = Eigen::Matrix<double, N, 1>::Random();
  Eigen::Matrix<double, N, 1> x = x0;
  const MeasurementModel measurement(Eigen::MatrixXd::Identity(N, N), 1e-8 * Eigen::MatrixXd::Identity(N, N),
                                     std::vector<bool>(N, false));
  SelectedMeasurement selected = measurement.make_selection();
  measurement.select(Eigen::VectorXd::LinSpaced(N, -1.0, 1.0), &selected);
  ExtendedKalmanFilter dynamic(model, Eigen::MatrixXd::Identity(N, N), N);
  dynamic.state() = x;
  dynamic.covariance() = p;
  ASSERT_TRUE(dynamic.update(selected).ok);
  // What the difference would give: P- - P- (P- + R)^-1 P-, by the same
  // factors as update_selected().
  const Eigen::MatrixXd s = p + 1e-8 * Eigen::MatrixXd::Identity(N, N);
  const Eigen::MatrixXd l = s.llt().matrixL();
  const Eigen::MatrixXd w = l.triangularView<Eigen::Lower>().solve(Eigen::MatrixXd(p)).transpose();
  const Eigen::MatrixXd difference = Eigen::MatrixXd(p) - w * w.transpose();
  SelectedUpdateWorkspace<N> workspace(N);
  ASSERT_TRUE(update_selected<N>(selected, 0, &x, &p, &workspace).ok);
  double worst_difference = 0.0;
  for (int i = 0; i < N; ++i) {
    const double joseph = dynamic.covariance()(i, i);
    ASSERT_GT(joseph, 0.0);
    EXPECT_NEAR(p(i, i), joseph, 1e-6 * joseph) << "variance " << i;
    worst_difference = std::max(worst_difference, std::abs(difference(i, i) - joseph) / joseph);
  }
  EXPECT_GT(worst_difference, 1e-3) << "the difference form would have been accurate here: the test no longer "
                                        "exercises the fallback";
  EXPECT_LT((dynamic.state() - x).cwiseAbs().maxCoeff(), 1e-12);
  for (int i = 0; i < N; ++i) {
    for (int j = 0; j < i; ++j) ASSERT_EQ(p(i, j), p(j, i));
  }
}

// A diagonal F scales P's rows and columns; the products give the same
// numbers to the bit (what predict_fixed() relies on from 5 states).
TEST(FixedStateFilter, ADiagonalJacobianPredictsAsTheProductsToTheBit) {
  constexpr int N = 9;
  const LinearStates model(N, false);
  const Eigen::Matrix<double, N, N> q = Eigen::Matrix<double, N, 1>::LinSpaced(1e-3, 4e-3).asDiagonal();
  Eigen::Matrix<double, N, N> a = Eigen::Matrix<double, N, N>::Random();
  Eigen::Matrix<double, N, N> p = a * a.transpose();
  Eigen::Matrix<double, N, 1> x = Eigen::Matrix<double, N, 1>::Random();
  ExtendedKalmanFilter dynamic(model, q, N);  // its own diagonal path
  dynamic.state() = x;
  dynamic.covariance() = p;
  Eigen::Matrix<double, N, N> f;
  ASSERT_TRUE(model.jacobian(x, Eigen::VectorXd::Ones(1), 0.05, f));
  Eigen::Matrix<double, N, N> by_products = f.lazyProduct(p);
  by_products = by_products.lazyProduct(f.transpose()).eval() + q * 0.05;
  symmetrize_fixed<N>(&by_products);
  ASSERT_TRUE(predict_fixed<N>(model, q, 1u << (N - 1), Eigen::VectorXd::Ones(1), 0.05, &x, &p));
  ASSERT_TRUE(dynamic.predict(Eigen::VectorXd::Ones(1), 0.05));
  for (int j = 0; j < N; ++j) {
    for (int i = 0; i < N; ++i) {
      EXPECT_EQ(p(i, j), by_products(i, j));
      EXPECT_EQ(p(i, j), dynamic.covariance()(i, j));
    }
  }
}

}  // namespace
}  // namespace skidimm
