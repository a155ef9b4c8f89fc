// The fixed-size kernels keep F and Qd of a model whose Jacobian and process
// noise depend on dt only, while dt repeats: the same results to the bit as
// asking at every step, with the model asked once per new dt, and asked
// afresh after reset() (its parameters may have changed in between).
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <atomic>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "core/test_banks.h"
#include "skidimm/engine/imm.h"
#include "skidimm/sdk/motion_model.h"

namespace {

using skidimm::Bank;
using skidimm::Imm;
using skidimm::ImmEstimate;
using skidimm_test::BankBuilder;
using skidimm_test::vec;

// dx/dt = A x + u over n states, one Euler step: F = I + A dt, and
// Qd = Q dt (1 + dt), which no scaling of one step's Qd gives for another dt.
// Counts its calls of jacobian() and process_noise(); says that they depend
// on dt only when told to. The parameters are A's entries, column-major.
class CountingLinearModel final : public skidimm::sdk::MotionModel {
 public:
  CountingLinearModel(Eigen::MatrixXd a, bool says_dt_only) : a_(std::move(a)), says_dt_only_(says_dt_only) {
    for (int i = 0; i < a_.rows(); ++i) states_.push_back("x" + std::to_string(i));
    for (Eigen::Index k = 0; k < a_.size(); ++k) info_.push_back({"a" + std::to_string(k), "A entry", "1/s"});
  }

  int state_dim() const noexcept override { return static_cast<int>(a_.rows()); }
  int input_dim() const noexcept override { return 1; }
  const std::vector<std::string>& state_names() const noexcept override { return states_; }
  const std::vector<std::string>& input_names() const noexcept override { return inputs_; }
  const std::vector<skidimm::sdk::ParameterInfo>& parameter_info() const noexcept override { return info_; }
  void get_parameters(Eigen::Ref<Eigen::VectorXd> values) const noexcept override {
    values = Eigen::Map<const Eigen::VectorXd>(a_.data(), a_.size());
  }
  bool set_parameters(const Eigen::Ref<const Eigen::VectorXd>& values, std::string* /*error*/) noexcept override {
    if (values.size() != a_.size()) return false;
    Eigen::Map<Eigen::VectorXd>(a_.data(), a_.size()) = values;
    return true;
  }

  bool predict(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
               Eigen::Ref<Eigen::VectorXd> next) const noexcept override {
    next = x + (a_ * x + Eigen::VectorXd::Constant(x.size(), u[0])) * dt;
    return true;
  }
  bool jacobian(const Eigen::Ref<const Eigen::VectorXd>& /*x*/, const Eigen::Ref<const Eigen::VectorXd>& /*u*/,
                double dt, Eigen::Ref<Eigen::MatrixXd> f) const noexcept override {
    ++jacobian_calls_;
    f = Eigen::MatrixXd::Identity(a_.rows(), a_.cols()) + a_ * dt;
    return true;
  }
  bool has_analytic_jacobian() const noexcept override { return true; }
  bool process_noise(const Eigen::Ref<const Eigen::MatrixXd>& intensity, const Eigen::Ref<const Eigen::VectorXd>& /*x*/,
                     const Eigen::Ref<const Eigen::VectorXd>& /*u*/, double dt,
                     Eigen::Ref<Eigen::MatrixXd> noise) const noexcept override {
    ++noise_calls_;
    noise = intensity * (dt * (1.0 + dt));
    return true;
  }
  bool jacobian_and_noise_depend_only_on_dt() const noexcept override { return says_dt_only_; }

  int jacobian_calls() const { return jacobian_calls_; }
  int noise_calls() const { return noise_calls_; }

 private:
  Eigen::MatrixXd a_;
  bool says_dt_only_;
  std::vector<std::string> states_;
  const std::vector<std::string> inputs_{"u"};
  std::vector<skidimm::sdk::ParameterInfo> info_;
  mutable std::atomic<int> jacobian_calls_{0};
  mutable std::atomic<int> noise_calls_{0};
};

// Three modes of n states: a diagonal A (the kernels' diagonal path from 5
// states on), a full one, and a diagonal one again.
std::vector<Eigen::MatrixXd> state_matrices(int n) {
  std::vector<Eigen::MatrixXd> a;
  for (int j = 0; j < 3; ++j) {
    Eigen::MatrixXd m = Eigen::MatrixXd::Zero(n, n);
    for (int i = 0; i < n; ++i) m(i, i) = -0.5 * (1.0 + j) - 0.1 * i;
    if (j == 1) {
      for (int i = 0; i + 1 < n; ++i) {
        m(i, i + 1) = 0.2;
        m(i + 1, i) = -0.15;
      }
    }
    a.push_back(m);
  }
  return a;
}

struct CountedBank {
  Bank bank;
  std::vector<std::shared_ptr<CountingLinearModel>> models;
};

CountedBank counted_bank(int n, bool says_dt_only) {
  CountedBank counted;
  BankBuilder b;
  b.states.clear();
  for (int i = 0; i < n; ++i) b.states.push_back("x" + std::to_string(i));
  b.angles.assign(static_cast<std::size_t>(n), false);
  for (const Eigen::MatrixXd& a : state_matrices(n)) {
    counted.models.push_back(std::make_shared<CountingLinearModel>(a, says_dt_only));
    b.models.push_back(counted.models.back());
  }
  Eigen::MatrixXd q = Eigen::MatrixXd::Identity(n, n) * 0.02;
  q(0, n - 1) = q(n - 1, 0) = n > 1 ? 0.005 : 0.02;
  b.q = {q};
  b.r = Eigen::MatrixXd::Identity(n, n) * 0.05;
  b.x0 = Eigen::VectorXd::Constant(n, 1.0);
  counted.bank = b.build();
  return counted;
}

// Times at a fixed rate (exact in binary: every dt the same double), at
// another, then irregular ones.
std::vector<double> step_times() {
  std::vector<double> t;
  for (int k = 0; k <= 20; ++k) t.push_back(0.125 * k);
  for (int k = 1; k <= 20; ++k) t.push_back(2.5 + 0.25 * k);
  for (int k = 1; k <= 20; ++k) t.push_back(t.back() + 0.1 + 0.01 * (k % 3));
  return t;
}

Eigen::VectorXd observed(int n, int k) {
  Eigen::VectorXd z(n);
  for (int i = 0; i < n; ++i) z[i] = 1.0 + 0.5 * std::sin(0.3 * k + i) + 0.05 * std::cos(1.7 * k * (i + 1));
  return z;
}

void expect_same_to_the_bit(const ImmEstimate& a, const ImmEstimate& b, int k) {
  ASSERT_EQ(a.status, b.status) << "step " << k;
  EXPECT_TRUE(a.state == b.state) << "step " << k;
  EXPECT_TRUE(a.covariance == b.covariance) << "step " << k;
  EXPECT_TRUE(a.mode_probabilities == b.mode_probabilities) << "step " << k;
  EXPECT_TRUE(a.log_likelihoods == b.log_likelihoods) << "step " << k;
  for (std::size_t j = 0; j < a.mode_states.size(); ++j) {
    EXPECT_TRUE(a.mode_states[j] == b.mode_states[j]) << "step " << k << ", mode " << j;
    EXPECT_TRUE(a.mode_covariances[j] == b.mode_covariances[j]) << "step " << k << ", mode " << j;
  }
}

class StepMatrixReuse : public ::testing::TestWithParam<int> {};

TEST_P(StepMatrixReuse, AsksOncePerNewDtAndGivesTheSameResultsToTheBit) {
  const int n = GetParam();
  CountedBank reusing = counted_bank(n, true);
  CountedBank asking = counted_bank(n, false);
  Imm fast(reusing.bank);
  Imm plain(asking.bank);
  ASSERT_TRUE(fast.uses_fixed_size_kernel());
  const std::vector<double> t = step_times();
  int new_dts = 0;
  for (std::size_t k = 0; k < t.size(); ++k) {
    if (k >= 2 && !(t[k] - t[k - 1] == t[k - 1] - t[k - 2])) ++new_dts;
    if (k == 1) ++new_dts;
    const Eigen::VectorXd u = vec({std::sin(0.2 * static_cast<double>(k))});
    const Eigen::VectorXd z = observed(n, static_cast<int>(k));
    const ImmEstimate& a = fast.step(t[k], u, z);
    const ImmEstimate& b = plain.step(t[k], u, z);
    expect_same_to_the_bit(a, b, static_cast<int>(k));
    ASSERT_EQ(a.status, skidimm::StepStatus::kUpdated) << "step " << k;
  }
  // The first dt, the change to 0.25 s, then at most one per irregular step
  // (the differences of rounded times: some may repeat).
  EXPECT_GE(new_dts, 3);
  EXPECT_LE(new_dts, 22);
  const int predictions = static_cast<int>(t.size()) - 1;
  for (int j = 0; j < 3; ++j) {
    EXPECT_EQ(asking.models[j]->jacobian_calls(), predictions) << "mode " << j;
    EXPECT_EQ(asking.models[j]->noise_calls(), predictions) << "mode " << j;
    EXPECT_EQ(reusing.models[j]->jacobian_calls(), new_dts) << "mode " << j;
    EXPECT_EQ(reusing.models[j]->noise_calls(), new_dts) << "mode " << j;
  }
}

// Parameters changed between runs (a fit, then the next run) reach the
// filters from the first prediction after reset().
TEST_P(StepMatrixReuse, ResetAsksAfreshSoNewParametersTakeEffect) {
  const int n = GetParam();
  CountedBank reused = counted_bank(n, true);
  Imm imm(reused.bank);
  for (int k = 0; k < 10; ++k) imm.step(0.125 * k, vec({0.5}), observed(n, k));
  for (const auto& model : reused.models) {
    Eigen::VectorXd a(model->parameter_info().size());
    model->get_parameters(a);
    ASSERT_TRUE(model->set_parameters(a * 3.0, nullptr));
  }
  imm.reset();
  CountedBank fresh = counted_bank(n, false);
  for (std::size_t j = 0; j < fresh.models.size(); ++j) {
    Eigen::VectorXd a(reused.models[j]->parameter_info().size());
    reused.models[j]->get_parameters(a);
    ASSERT_TRUE(fresh.models[j]->set_parameters(a, nullptr));
  }
  Imm expected(fresh.bank);
  for (int k = 0; k < 10; ++k) {
    const ImmEstimate& a = imm.step(0.125 * k, vec({0.5}), observed(n, k));
    const ImmEstimate& b = expected.step(0.125 * k, vec({0.5}), observed(n, k));
    expect_same_to_the_bit(a, b, k);
  }
  for (const auto& model : reused.models) EXPECT_EQ(model->jacobian_calls(), 2);
}

// 2 states: the 2 x 2 fixed kernel (FixedFilters); 9: past 4 x 4, where F's
// diagonal is checked (FixedStateFilters). Both are bundled shapes, compiled
// in every build (fixed_size_shapes.h).
INSTANTIATE_TEST_SUITE_P(FixedKernels, StepMatrixReuse, ::testing::Values(2, 9));

}  // namespace
