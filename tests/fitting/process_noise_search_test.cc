// The consistent process noise of the window fit (evaluate()'s Q) against the
// search it replaced, run here as it was: two rounds over the states, each
// root found by TOMS 748 on the full filter (ExtendedKalmanFilter). Decoupled
// modes now search every state in one pass per evaluation; the result must be
// the same to the bit, and must fall back to the two rounds whenever the
// states are not decoupled, however that shows.
#include <gtest/gtest.h>

#include <atomic>
#include <boost/math/tools/toms748_solve.hpp>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <random>

#include "core/test_banks.h"
#include "skidimm/engine/ekf.h"
#include "skidimm/engine/measurement_model.h"
#include "skidimm/fitting/model_fitter.h"
#include "skidimm/sdk/angles.h"

namespace skidimm {
namespace fitting {
namespace {

using skidimm_test::BankBuilder;

// x_i relaxes towards b_i u at rate a_i, exactly over dt; the last state is
// an angle when `angle` is set. `leak` > 0 makes states 0 and 1 follow each
// other as well (x_0 += leak x_1 dt, x_1 += leak x_0 dt) while jacobian()
// still says diagonal: a model coupled in a way its Jacobian does not show. `coupled` says so in the
// Jacobian (a true off-diagonal entry). Counts its predictions.
class RelaxingModel : public sdk::SizedMotionModel<3, 1> {
 public:
  RelaxingModel(bool angle, double leak, bool coupled) : angle_(angle), leak_(leak), coupled_(coupled) {}
  const std::vector<std::string>& state_names() const noexcept override { return states_; }
  const std::vector<std::string>& input_names() const noexcept override { return inputs_; }
  bool is_angle(int i) const noexcept override { return angle_ && i == 2; }
  const std::vector<sdk::ParameterInfo>& parameter_info() const noexcept override { return info_; }
  void get_parameters(Eigen::Ref<Eigen::VectorXd>) const noexcept override {}
  bool set_parameters(const Eigen::Ref<const Eigen::VectorXd>&, std::string*) noexcept override { return true; }
  bool predict_fixed(const State& x, const Input& u, double dt, State* next) const override {
    ++predictions;
    for (int i = 0; i < 3; ++i) {
      const double decay = std::exp(-kRates[i] * dt);
      (*next)[i] = decay * x[i] + (1.0 - decay) * kGains[i] * u[0];
    }
    (*next)[0] += (leak_ + (coupled_ ? 0.3 : 0.0)) * x[1] * dt;
    (*next)[1] += leak_ * x[0] * dt;
    if (angle_) (*next)[2] = sdk::wrap_angle((*next)[2]);
    return true;
  }
  bool jacobian_fixed(const State&, const Input&, double dt, Jacobian* j) const override {
    j->setZero();
    for (int i = 0; i < 3; ++i) (*j)(i, i) = std::exp(-kRates[i] * dt);
    if (coupled_) (*j)(0, 1) = 0.3 * dt;
    return true;
  }
  bool has_analytic_jacobian() const noexcept override { return true; }

  mutable std::atomic<long> predictions{0};

 private:
  static constexpr double kRates[3] = {2.0, 5.0, 1.0};
  static constexpr double kGains[3] = {1.5, -0.7, 3.0};
  bool angle_;
  double leak_;
  bool coupled_;
  const std::vector<std::string> states_{"a", "b", "heading"};
  const std::vector<std::string> inputs_{"u"};
  const std::vector<sdk::ParameterInfo> info_{};
};

Bank bank_of(std::shared_ptr<RelaxingModel> model, const Eigen::Vector3d& r_std) {
  BankBuilder b;
  b.states = {"a", "b", "heading"};
  b.angles = {false, false, model->is_angle(2)};
  b.models = {model};
  b.q = {Eigen::Matrix3d::Identity()};
  b.r = r_std.array().square().matrix().asDiagonal();
  return b.build();
}

// Two logs of the true model with noise of intensity q_true, each state
// measured on most rows (some rows miss one state, some miss every state).
ModeLogs simulate(const RelaxingModel& model, const Eigen::Vector3d& q_true, const Eigen::Vector3d& r_std,
                  unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  ModeLogs data;
  for (int log = 0; log < 2; ++log) {
    Trajectory t;
    t.source = "log" + std::to_string(log);
    const int rows = 300;
    t.u.resize(1, rows);
    t.z.resize(3, rows);
    Eigen::VectorXd x = Eigen::VectorXd::Zero(3), next(3);
    double time = 0.0;
    for (int k = 0; k < rows; ++k) {
      const double dt = 0.05 + 0.02 * (k % 3);
      t.t.push_back(time);
      t.u(0, k) = std::sin(0.3 * time + log) + 0.5 * std::cos(1.7 * time);
      for (int i = 0; i < 3; ++i) {
        const bool missing = k % 7 == i + 1 || k % 23 == 5;
        double z = x[i] + r_std[i] * normal(rng);
        if (model.is_angle(i)) z = sdk::wrap_angle(z);
        t.z(i, k) = missing ? std::nan("") : z;
      }
      model.predict(x, t.u.col(k), dt, next);
      for (int i = 0; i < 3; ++i) next[i] += std::sqrt(q_true[i] * dt) * normal(rng);
      x = next;
      if (model.is_angle(2)) x[2] = sdk::wrap_angle(x[2]);
      time += dt;
    }
    data.logs.push_back(t);
  }
  return data;
}

// The search as it was: for each state s in turn, twice over, the root of
// log mean NIS_s(log q_ss) by TOMS 748, each evaluation a pass of the full
// filter.
double mean_state_nis(const Bank& bank, const ModeLogs& data, const Eigen::MatrixXd& q, int s) {
  const sdk::MotionModel& model = *bank.models[0];
  const Eigen::MatrixXd& r = bank.config.measurement.r;
  const MeasurementModel measurement(bank.config.measurement.h, r, bank.config.measurement.is_angle);
  SelectedMeasurement selected = measurement.make_selection();
  double sum = 0.0, count = 0.0;
  for (const Trajectory& t : data.logs) {
    ExtendedKalmanFilter filter(model, q, 3);
    int k = 0;
    while (k < t.size() && !t.z.col(k).allFinite()) ++k;
    if (k >= t.size()) continue;
    filter.state() = t.z.col(k);
    filter.covariance() = r;
    for (++k; k < t.size(); ++k) {
      if (!filter.predict(t.u.col(k - 1), t.t[k] - t.t[k - 1])) break;
      measurement.select(t.z.col(k), &selected);
      if (selected.size == 0) continue;
      if (std::isfinite(t.z(s, k))) {
        double e = t.z(s, k) - filter.state()[s];
        if (bank.config.measurement.is_angle[static_cast<std::size_t>(s)]) e = sdk::wrap_angle(e);
        sum += e * e / (filter.covariance()(s, s) + r(s, s));
        count += 1.0;
      }
      if (!filter.update(selected).ok) break;
    }
  }
  return sum / std::max(count, 1.0);
}

Eigen::VectorXd two_rounds(const Bank& bank, const ModeLogs& data) {
  Eigen::MatrixXd q = Eigen::MatrixXd::Identity(3, 3) * 1e-3;
  for (int round = 0; round < 2; ++round) {
    for (int s = 0; s < 3; ++s) {
      const auto log_nis = [&](double log_q) {
        q(s, s) = std::exp(log_q);
        const double nis = mean_state_nis(bank, data, q, s);
        return std::log(std::isfinite(nis) ? std::max(nis, 1e-300) : 1e-300);
      };
      const double low = std::log(1e-10), high = std::log(1e3);
      const double at_low = log_nis(low);
      if (at_low <= 0.0) {
        q(s, s) = 1e-10;
        continue;
      }
      const double at_high = log_nis(high);
      if (at_high >= 0.0) {
        q(s, s) = 1e3;
        continue;
      }
      std::uintmax_t iterations = 60;
      const auto root = boost::math::tools::toms748_solve(
          log_nis, low, high, at_low, at_high, [](double a, double b) { return std::abs(a - b) <= 2e-8; }, iterations);
      q(s, s) = std::exp(0.5 * (root.first + root.second));
    }
  }
  return q.diagonal();
}

struct Searched {
  Eigen::VectorXd q;
  long predictions = 0;
};

Searched search(const Bank& bank, const ModeLogs& data, RelaxingModel* model) {
  model->predictions = 0;
  Searched out;
  out.q = evaluate(bank, data).q_intensity.diagonal();
  out.predictions = model->predictions;
  return out;
}

void expect_same_bits(const Eigen::VectorXd& actual, const Eigen::VectorXd& expected) {
  ASSERT_EQ(actual.size(), expected.size());
  for (Eigen::Index i = 0; i < actual.size(); ++i) EXPECT_EQ(actual[i], expected[i]) << "Q[" << i << "," << i << "]";
}

TEST(ProcessNoiseSearch, DecoupledStatesAreSearchedTogetherWithTheTwoRoundsResultToTheBit) {
  const Eigen::Vector3d r_std(0.05, 0.02, 0.03);
  for (const bool angle : {false, true}) {
    auto model = std::make_shared<RelaxingModel>(angle, 0.0, false);
    const Bank bank = bank_of(model, r_std);
    const ModeLogs data = simulate(*model, Eigen::Vector3d(0.02, 0.5, 0.003), r_std, 7);
    model->predictions = 0;
    const Eigen::VectorXd expected = two_rounds(bank, data);
    const long two_rounds_predictions = model->predictions;
    const Searched searched = search(bank, data, model.get());
    expect_same_bits(searched.q, expected);
    // Taken together: far fewer passes of the filter (the fit's own one-step
    // RMSE adds one pass's worth).
    EXPECT_LT(searched.predictions * 2, two_rounds_predictions) << "angle " << angle;
  }
}

TEST(ProcessNoiseSearch, AStateAtTheFloorOrCeilingIsFoundAsByTheTwoRounds) {
  // R far above the noise (floor) on one state, far below on another.
  const Eigen::Vector3d r_std(2.0, 1e-4, 0.03);
  auto model = std::make_shared<RelaxingModel>(false, 0.0, false);
  const Bank bank = bank_of(model, r_std);
  const ModeLogs data = simulate(*model, Eigen::Vector3d(1e-6, 2e4, 0.01), Eigen::Vector3d(0.01, 1e-4, 0.03), 11);
  const Eigen::VectorXd expected = two_rounds(bank, data);
  EXPECT_EQ(expected[0], 1e-10);  // the case this test is for
  expect_same_bits(search(bank, data, model.get()).q, expected);
}

TEST(ProcessNoiseSearch, CouplingTheJacobianShowsRunsTheTwoRounds) {
  const Eigen::Vector3d r_std(0.05, 0.02, 0.03);
  auto model = std::make_shared<RelaxingModel>(false, 0.0, true);
  const Bank bank = bank_of(model, r_std);
  const ModeLogs data = simulate(*model, Eigen::Vector3d(0.02, 0.5, 0.003), r_std, 3);
  expect_same_bits(search(bank, data, model.get()).q, two_rounds(bank, data));
}

TEST(ProcessNoiseSearch, CouplingOnlyThePredictionShowsIsFoundAndRunsTheTwoRounds) {
  // States 0 and 1 follow each other while the Jacobian is diagonal: each
  // state's filter is a scalar one, but its NIS moves with the other's Q.
  // Only the final check of independence can see it.
  const Eigen::Vector3d r_std(0.05, 0.02, 0.03);
  auto model = std::make_shared<RelaxingModel>(false, 0.8, false);
  const Bank bank = bank_of(model, r_std);
  const ModeLogs data = simulate(*model, Eigen::Vector3d(0.02, 0.5, 0.003), r_std, 5);
  expect_same_bits(search(bank, data, model.get()).q, two_rounds(bank, data));
}

TEST(ProcessNoiseSearch, CorrelatedMeasurementNoiseRunsTheTwoRounds) {
  const Eigen::Vector3d r_std(0.05, 0.02, 0.03);
  auto model = std::make_shared<RelaxingModel>(false, 0.0, false);
  Bank bank = bank_of(model, r_std);
  bank.config.measurement.r(0, 1) = bank.config.measurement.r(1, 0) = 0.5 * 0.05 * 0.02;
  const ModeLogs data = simulate(*model, Eigen::Vector3d(0.02, 0.5, 0.003), r_std, 9);
  expect_same_bits(search(bank, data, model.get()).q, two_rounds(bank, data));
}

}  // namespace
}  // namespace fitting
}  // namespace skidimm
