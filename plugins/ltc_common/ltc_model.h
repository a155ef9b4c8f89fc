// LtcModel: the plugin class behind `ltc_linear` and `ltc_shared`.
//
// Both plugins integrate eq. 2 with the same code; they differ only in where A
// and B live. `ltc_linear` gives each mode its own A_i, B_i; `ltc_shared` (the
// paper's alternative, section III-A) takes one A, B from the bank's `shared:`
// block, so modes differ only in their process noise Q_i. The scope is part of
// the parameters' metadata, so the bank loader and the fitter treat A, B as
// one set for the whole bank without knowing this plugin.
#ifndef SKIDIMM_PLUGINS_LTC_COMMON_LTC_MODEL_H_
#define SKIDIMM_PLUGINS_LTC_COMMON_LTC_MODEL_H_

#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "ltc_common/ltc_predict.h"
#include "skidimm/sdk/autodiff_parameter_jacobian.h"
#include "skidimm/sdk/sized_motion_model.h"

namespace skidimm {
namespace plugins {

template <sdk::ParameterScope kScope>
class LtcModel final : public sdk::SizedMotionModel<2, 2> {
 public:
  using Matrix2 = Eigen::Matrix<double, 2, 2, Eigen::RowMajor>;

  static std::unique_ptr<LtcModel> Create(const sdk::ParameterSet& params, std::string* error) {
    Eigen::MatrixXd a, b;
    if (!params.check_only({"A", "B"}, error) || !params.get_matrix("A", 2, 2, &a, error) ||
        !params.get_matrix("B", 2, 2, &b, error)) {
      return nullptr;
    }
    if (!a.allFinite() || !b.allFinite()) {
      *error = "A and B must be finite";
      return nullptr;
    }
    return std::unique_ptr<LtcModel>(new LtcModel(a, b));
  }

  const std::vector<std::string>& state_names() const noexcept override { return state_names_; }
  const std::vector<std::string>& input_names() const noexcept override { return input_names_; }

  const std::vector<sdk::ParameterInfo>& parameter_info() const noexcept override { return parameter_info_; }

  void get_parameters(Eigen::Ref<Eigen::VectorXd> values) const noexcept override {
    values.head<4>() = Eigen::Map<const Eigen::Matrix<double, 4, 1>>(a_.data());
    values.tail<4>() = Eigen::Map<const Eigen::Matrix<double, 4, 1>>(b_.data());
  }

  bool set_parameters(const Eigen::Ref<const Eigen::VectorXd>& values, std::string* error) noexcept override {
    if (!sdk::check_parameter_values(parameter_info_, values, error)) return false;
    Eigen::Map<Eigen::Matrix<double, 4, 1>>(a_.data()) = values.head<4>();
    Eigen::Map<Eigen::Matrix<double, 4, 1>>(b_.data()) = values.tail<4>();
    return true;
  }

  bool predict_fixed(const State& x, const Input& u, double dt, State* x_next) const override {
    ltc_predict(x.data(), u.data(), a_.data(), b_.data(), dt, x_next->data());
    return x_next->allFinite();
  }

  // F = I + A dt, exact for the Euler step.
  bool jacobian_fixed(const State& /*x*/, const Input& /*u*/, double dt, Jacobian* jacobian) const override {
    *jacobian = Jacobian::Identity() + a_ * dt;
    return true;
  }
  bool has_analytic_jacobian() const noexcept override { return true; }

  // d x_next / d [A row-major, B row-major], by Ceres jets on ltc_predict.
  bool parameter_jacobian(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u,
                          double dt, Eigen::Ref<Eigen::MatrixXd> jacobian) const noexcept override {
    double parameters[8];
    Eigen::Map<Eigen::Matrix<double, 8, 1>> flat(parameters);
    get_parameters(flat);
    return sdk::autodiff_parameter_jacobian<2, 2, 8>(
        [](const auto* x_in, const auto* u_in, const auto* p, const auto& step, auto* out) {
          ltc_predict(x_in, u_in, p, p + 4, step, out);
        },
        x, u, parameters, dt, jacobian);
  }

 private:
  LtcModel(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) : a_(a), b_(b) {
    sdk::append_matrix_parameter_info("A", 2, 2, "state matrix of eq. 2 (1/s)", kScope, &parameter_info_);
    sdk::append_matrix_parameter_info("B", 2, 2, "input matrix of eq. 2 (m/rad/s, 1/s)", kScope, &parameter_info_);
  }

  Matrix2 a_;
  Matrix2 b_;
  std::vector<sdk::ParameterInfo> parameter_info_;
  const std::vector<std::string> state_names_{"V", "omega"};
  const std::vector<std::string> input_names_{"phi_dot_L", "phi_dot_R"};
};

}  // namespace plugins
}  // namespace skidimm

#endif  // SKIDIMM_PLUGINS_LTC_COMMON_LTC_MODEL_H_
