// In-process models and banks for engine tests: no plugin loading, so the
// math is tested apart from the loader.
#ifndef SKIDIMM_TESTS_CORE_TEST_BANKS_H_
#define SKIDIMM_TESTS_CORE_TEST_BANKS_H_

#include <Eigen/Core>
#include <initializer_list>
#include <memory>
#include <string>
#include <vector>

#include "ltc_common/ltc_model.h"
#include "skidimm/config/bank.h"
#include "skidimm/sdk/angles.h"
#include "skidimm/sdk/sized_motion_model.h"

namespace skidimm_test {

// A vector from a brace list: vec({1.0, 2.0}).
inline Eigen::VectorXd vec(std::initializer_list<double> values) {
  Eigen::VectorXd v(static_cast<Eigen::Index>(values.size()));
  Eigen::Index i = 0;
  for (double x : values) v[i++] = x;
  return v;
}

// x_next = x + (a x + b u) dt: the scalar case of eq. 2.
class ScalarLinearModel : public skidimm::sdk::SizedMotionModel<1, 1> {
 public:
  ScalarLinearModel(double a, double b) : a_(a), b_(b) {}
  const std::vector<std::string>& state_names() const noexcept override { return states_; }
  const std::vector<std::string>& input_names() const noexcept override { return inputs_; }
  const std::vector<skidimm::sdk::ParameterInfo>& parameter_info() const noexcept override { return info_; }
  void get_parameters(Eigen::Ref<Eigen::VectorXd> v) const noexcept override { v << a_, b_; }
  bool set_parameters(const Eigen::Ref<const Eigen::VectorXd>& v, std::string* error) noexcept override {
    if (v.size() != 2 || !v.allFinite()) {
      if (error != nullptr) *error = "expected a, b";
      return false;
    }
    a_ = v[0];
    b_ = v[1];
    return true;
  }
  bool predict_fixed(const State& x, const Input& u, double dt, State* next) const override {
    (*next)[0] = x[0] + (a_ * x[0] + b_ * u[0]) * dt;
    return true;
  }
  bool jacobian_fixed(const State&, const Input&, double dt, Jacobian* j) const override {
    (*j)(0, 0) = 1.0 + a_ * dt;
    return true;
  }
  bool has_analytic_jacobian() const noexcept override { return true; }

 private:
  double a_, b_;
  const std::vector<std::string> states_{"x"};
  const std::vector<std::string> inputs_{"u"};
  const std::vector<skidimm::sdk::ParameterInfo> info_{{"a", "a", ""}, {"b", "b", ""}};
};

// A heading that turns at rate * u: theta_next = wrap(theta + rate u dt).
class HeadingModel : public skidimm::sdk::SizedMotionModel<1, 1> {
 public:
  explicit HeadingModel(double rate) : rate_(rate) {}
  const std::vector<std::string>& state_names() const noexcept override { return states_; }
  const std::vector<std::string>& input_names() const noexcept override { return inputs_; }
  bool is_angle(int) const noexcept override { return true; }
  const std::vector<skidimm::sdk::ParameterInfo>& parameter_info() const noexcept override { return info_; }
  void get_parameters(Eigen::Ref<Eigen::VectorXd>) const noexcept override {}
  bool set_parameters(const Eigen::Ref<const Eigen::VectorXd>&, std::string*) noexcept override { return true; }
  bool predict_fixed(const State& x, const Input& u, double dt, State* next) const override {
    (*next)[0] = skidimm::sdk::wrap_angle(x[0] + rate_ * u[0] * dt);
    return true;
  }

 private:
  double rate_;
  const std::vector<std::string> states_{"theta"};
  const std::vector<std::string> inputs_{"u"};
  const std::vector<skidimm::sdk::ParameterInfo> info_{};
};

using LtcModel = skidimm::plugins::LtcModel<skidimm::sdk::ParameterScope::kMode>;

inline std::shared_ptr<LtcModel> make_ltc(const Eigen::Matrix2d& a, const Eigen::Matrix2d& b) {
  skidimm::sdk::ParameterSet params;
  params.set("A", a);
  params.set("B", b);
  std::string error;
  return std::shared_ptr<LtcModel>(LtcModel::Create(params, &error).release());
}

// A bank around the given models: every mode observed directly (H = I unless
// given), the same Q for every mode unless given.
struct BankBuilder {
  std::vector<std::string> states{"x"};
  std::vector<bool> angles{false};
  std::vector<std::string> inputs{"u"};
  std::vector<std::shared_ptr<skidimm::sdk::MotionModel>> models;
  std::vector<Eigen::MatrixXd> q;
  Eigen::MatrixXd h;
  Eigen::MatrixXd r;
  Eigen::MatrixXd transition;  // empty: stay 0.95
  Eigen::VectorXd x0;
  Eigen::MatrixXd p0;
  Eigen::VectorXd mu0;  // empty: uniform
  double floor = 1e-9;

  skidimm::Bank build() const {
    skidimm::Bank bank;
    skidimm::BankConfig& c = bank.config;
    const int n = static_cast<int>(states.size());
    const int num_modes = static_cast<int>(models.size());
    c.file = "in-process";
    c.name = "test";
    c.state_names = states;
    c.angle_mask = angles;
    c.input_names = inputs;
    c.measurement.h = h.size() ? h : Eigen::MatrixXd::Identity(n, n);
    c.measurement.r = r;
    for (int i = 0; i < c.measurement.h.rows(); ++i) c.measurement.names.push_back("z" + std::to_string(i));
    c.measurement.is_angle.assign(c.measurement.h.rows(), false);
    for (int i = 0; i < c.measurement.h.rows() && !h.size(); ++i) c.measurement.is_angle[i] = angles[i];
    if (transition.size()) {
      c.transition.kind = skidimm::TransitionConfig::Kind::kMatrix;
      c.transition.matrix = transition;
    } else {
      c.transition.kind = skidimm::TransitionConfig::Kind::kStay;
      c.transition.stay = 0.95;
    }
    c.initial_state = x0.size() ? x0 : Eigen::VectorXd::Zero(n);
    c.initial_covariance = p0.size() ? p0 : Eigen::MatrixXd::Identity(n, n);
    c.initial_mode_probabilities = mu0.size() ? mu0 : Eigen::VectorXd::Constant(num_modes, 1.0 / num_modes);
    c.mode_probability_floor = floor;
    for (int j = 0; j < num_modes; ++j) {
      skidimm::ModeConfig mode;
      mode.name = "mode" + std::to_string(j);
      mode.model = "in-process";
      mode.q_intensity = q.size() == 1 ? q[0] : q.at(j);
      c.modes.push_back(mode);
      bank.models.push_back(models[j]);
    }
    return bank;
  }
};

}  // namespace skidimm_test

#endif  // SKIDIMM_TESTS_CORE_TEST_BANKS_H_
