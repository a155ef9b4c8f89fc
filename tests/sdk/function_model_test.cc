// A model written as one templated function (sdk/function_model.h): the
// fixture slip_ratio plugin, a 3-state model, loaded as skidimm
// loads any plugin.
#include "skidimm/sdk/function_model.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <string>

#include "core/temp_files.h"
#include "skidimm/engine/plugin_registry.h"
#include "skidimm/errors.h"
#include "skidimm/sdk/testing/conformance.h"
#include "skidimm/sdk/testing/load_plugin_model.h"

namespace skidimm {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

const fs::path kSlipRatioDir = fs::path(SKIDIMM_TEST_PLUGIN_ROOT) / "slip_ratio";
const fs::path kNanAboveDir = fs::path(SKIDIMM_TEST_PLUGIN_ROOT) / "nan_above";

sdk::ParameterSet husky() {
  sdk::ParameterSet p;
  p.set_scalar("s_ss", 0.2);
  p.set_scalar("m", 0.6);
  p.set_scalar("tau", 0.05);
  p.set_scalar("tau_s", 0.5);
  p.set_scalar("r", 0.165);
  p.set_scalar("b", 0.555);
  return p;
}

TEST(FunctionModel, TheSlipRatioModelIsAtMostFortyLinesWithItsParameterTable) {
  std::ifstream source(std::string(SKIDIMM_SOURCE_DIR) + "/sdk/examples/slip_ratio/slip_ratio_plugin.cc");
  ASSERT_TRUE(source);
  int lines = 0;
  for (std::string line; std::getline(source, line);) ++lines;
  EXPECT_LE(lines, 40);
}

TEST(FunctionModel, ConformsAtManyOperatingPoints) {
  PluginRegistry registry({kSlipRatioDir});
  ModelHandle model = registry.create("slip_ratio", husky());
  ASSERT_EQ(model->state_dim(), 3);
  EXPECT_TRUE(model->has_analytic_jacobian());  // by jets
  for (double v : {-0.5, 0.0, 0.7, 2.0}) {
    for (double s : {0.0, 0.3}) {
      for (double dt : {0.001, 0.05}) {
        EXPECT_MOTION_MODEL_CONFORMS(*model, Eigen::Vector3d(v, 0.4 * v, s), Eigen::Vector2d(5.0, 9.0), dt);
      }
    }
  }
  // The values are the function's.
  Eigen::VectorXd next(3);
  ASSERT_TRUE(model->predict(Eigen::Vector3d(1.0, 0.0, 0.1), Eigen::Vector2d(10.0, 10.0), 0.01, next));
  EXPECT_DOUBLE_EQ(next[0], 1.0 + 0.01 * ((1.0 - 0.1) * 0.165 * 10.0 - 1.0) / 0.05);
  EXPECT_DOUBLE_EQ(next[2], 0.1 + 0.01 * (0.2 - 0.1) / 0.5);
}

TEST(FunctionModel, TheParameterJacobianIsExact) {
  PluginRegistry registry({kSlipRatioDir});
  ModelHandle model = registry.create("slip_ratio", husky());
  const Eigen::Vector3d x(1.2, -0.3, 0.15);
  const Eigen::Vector2d u(4.0, 7.0);
  const double dt = 0.02;
  Eigen::MatrixXd jacobian(3, 6);
  ASSERT_TRUE(model->parameter_jacobian(x, u, dt, jacobian));
  Eigen::VectorXd p(6), plus(3), minus(3);
  model->get_parameters(p);
  for (int k = 0; k < 6; ++k) {
    const double h = 1e-6 * std::max(1.0, std::abs(p[k]));
    Eigen::VectorXd q = p;
    q[k] += h;
    ASSERT_TRUE(model->set_parameters(q, nullptr));
    ASSERT_TRUE(model->predict(x, u, dt, plus));
    q[k] -= 2 * h;
    ASSERT_TRUE(model->set_parameters(q, nullptr));
    ASSERT_TRUE(model->predict(x, u, dt, minus));
    ASSERT_TRUE(model->set_parameters(p, nullptr));
    const Eigen::Vector3d numeric = (plus - minus) / (2 * h);
    EXPECT_TRUE(jacobian.col(k).isApprox(numeric, 1e-6) || (jacobian.col(k) - numeric).norm() < 1e-8)
        << model->parameter_info()[static_cast<std::size_t>(k)].name << ": " << jacobian.col(k).transpose() << " vs "
        << numeric.transpose();
  }
}

TEST(FunctionModel, CreateNamesUnknownMissingAndOutOfBoundsParameters) {
  PluginRegistry registry({kSlipRatioDir});
  auto error = [&](const sdk::ParameterSet& p) {
    try {
      registry.create("slip_ratio", p);
    } catch (const PluginError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  sdk::ParameterSet typo = husky();
  typo.set_scalar("tua", 1.0);
  EXPECT_THAT(error(typo), HasSubstr("unknown parameter 'tua' (this model takes: s_ss, m, tau, tau_s, r, b)"));
  sdk::ParameterSet missing;
  missing.set_scalar("s_ss", 0.1);
  EXPECT_THAT(error(missing), HasSubstr("missing parameter 'm' (a number)"));
  sdk::ParameterSet outside = husky();
  outside.set_scalar("s_ss", 1.5);
  EXPECT_THAT(error(outside), HasSubstr("parameter 's_ss' = 1.500000 is outside [0.000000, 1.000000]"));
}

TEST(FunctionModel, ThePluginDescribesStatesInputsAndEveryParameterWithBoundsAndScope) {
  PluginRegistry registry({kSlipRatioDir});
  const PluginDescriptor& d = registry.find("slip_ratio");
  EXPECT_EQ(d.version, "0.1.0");
  ASSERT_EQ(d.states.size(), 3u);
  EXPECT_EQ(d.states[2].name, "s");
  EXPECT_EQ(d.states[2].description, "longitudinal slip ratio (-)");
  ASSERT_EQ(d.inputs.size(), 2u);
  EXPECT_EQ(d.parameter_keys, (std::vector<std::string>{"s_ss", "m", "tau", "tau_s", "r", "b"}));
  EXPECT_THAT(d.parameter_docs, ::testing::Contains("s_ss (scalar): steady slip ratio (-), in [0, 1], per mode"));
  EXPECT_THAT(d.parameter_docs,
              ::testing::Contains("r (scalar): wheel radius (m), in [0.001, 1], bank-level (shared:)"));
  ModelHandle model = registry.create("slip_ratio", husky());
  EXPECT_EQ(model->parameter_info()[4].scope, sdk::ParameterScope::kBank);
  EXPECT_EQ(model->parameter_info()[2].lower_bound, 1e-3);
}

// A heading that turns at rate * u, with its own (hand-written) Jacobian.
struct Turning {
  static constexpr const char* kName = "turning";
  static constexpr const char* kVersion = "0.1.0";
  static constexpr const char* kDescription = "heading driven by a turn rate";
  static constexpr sdk::VariableDoc kStates[] = {{"theta", "heading (rad)", true}, {"w", "rate (rad/s)", false}};
  static constexpr sdk::VariableDoc kInputs[] = {{"u", "command (-)", false}};
  static constexpr sdk::ParameterSpec kParameters[] = {{"gain", "rate per command (rad/s)", 0.0, 10.0}};
  template <typename T>
  static void predict(const T* x, const double* u, const T* p, double dt, T* x_next) {
    x_next[0] = x[0] + x[1] * dt;
    x_next[1] = x[1] + (p[0] * u[0] - x[1]) * dt;
  }
  static inline int jacobian_calls = 0;
  static void jacobian(const double*, const double*, const double*, double dt, double* j) {
    ++jacobian_calls;
    j[0] = 1.0, j[1] = dt, j[2] = 0.0, j[3] = 1.0 - dt;
  }
};

TEST(FunctionModel, WrapsAngleStatesAndUsesAHandWrittenJacobianIfGiven) {
  sdk::ParameterSet p;
  p.set_scalar("gain", 2.0);
  std::string error;
  auto model = sdk::FunctionModel<Turning>::Create(p, &error);
  ASSERT_TRUE(model) << error;
  EXPECT_TRUE(model->is_angle(0));
  Eigen::VectorXd next(2);
  ASSERT_TRUE(model->predict(Eigen::Vector2d(3.0, 2.0), Eigen::VectorXd::Constant(1, 1.0), 0.1, next));
  EXPECT_NEAR(next[0], 3.2 - 2.0 * M_PI, 1e-12);  // 3.2 wrapped into [-pi, pi)
  EXPECT_NEAR(next[1], 2.0, 1e-15);
  Turning::jacobian_calls = 0;
  Eigen::MatrixXd j(2, 2);
  ASSERT_TRUE(model->jacobian(Eigen::Vector2d(3.0, 2.0), Eigen::VectorXd::Constant(1, 1.0), 0.1, j));
  EXPECT_EQ(Turning::jacobian_calls, 1);
  EXPECT_DOUBLE_EQ(j(0, 1), 0.1);
  EXPECT_DOUBLE_EQ(j(1, 1), 0.9);
  EXPECT_MOTION_MODEL_CONFORMS(*model, Eigen::Vector2d(3.1, 1.0), Eigen::VectorXd::Constant(1, 0.5), 0.05);
}

sdk::ParameterSet nan_above(double speed) {
  sdk::ParameterSet p;
  p.set_scalar("above", speed);
  return p;
}

// The nan_above fixture's yaw rate is sqrt(above - V): NaN, with its
// derivative, for V > above. The reason names the entry and the point.
TEST(FunctionModel, AStateOrJacobianThatIsNotFiniteIsNamedByEntry) {
  PluginRegistry registry({kNanAboveDir});
  ModelHandle model = registry.create("nan_above", nan_above(0.5));
  const Eigen::Vector2d x(1.0, 0.2), u(3.0, 4.0);
  Eigen::MatrixXd jacobian(2, 2);
  EXPECT_FALSE(model->jacobian(x, u, 0.02, jacobian));
  EXPECT_THAT(std::string(model->failure_reason()),
              HasSubstr("jacobian() is not finite: entry (row 1 'omega', column 0 'V') = "));
  Eigen::VectorXd next(2);
  EXPECT_FALSE(model->predict(x, u, 0.02, next));
  const std::string reason = model->failure_reason();
  EXPECT_THAT(reason, HasSubstr("predict() gave a state that is not finite: omega = "));
  EXPECT_THAT(reason, HasSubstr("(x_next[1]) at x = [1, 0.2], u = [3, 4], dt = 0.02"));
  // Below the speed, all is finite.
  EXPECT_TRUE(model->jacobian(Eigen::Vector2d(0.1, 0.2), u, 0.02, jacobian));
  EXPECT_TRUE(model->predict(Eigen::Vector2d(0.1, 0.2), u, 0.02, next));
}

TEST(FunctionModel, TheConformanceKitNamesTheEntryThatIsNotFinite) {
  auto model = sdk::testing::load_plugin_model((kNanAboveDir / "nan_above_plugin.so").string(), nan_above(0.5));
  const auto result =
      sdk::testing::MotionModelConforms(*model, Eigen::Vector2d(1.0, 0.2), Eigen::Vector2d(3.0, 4.0), 0.02);
  EXPECT_FALSE(result);
  EXPECT_THAT(result.message(), HasSubstr("jacobian(x, u, 0) failed: jacobian() is not finite: entry (row 1 "
                                          "'omega', column 0 'V')"));
  EXPECT_THAT(result.message(), HasSubstr("predict(x, u, dt) failed: predict() gave a state that is not finite: "
                                          "omega"));
}

TEST(FunctionModel, RunNamesTheEntryThatIsNotFiniteInItsSummary) {
  const fs::path dir = skidimm_test::test_directory();
  const fs::path bank = skidimm_test::write_file(dir / "bank.yaml", R"(
name: nan
states: [V, omega]
inputs: [phi_dot_L, phi_dot_R]
measurement:
  observe: [V, omega]
  R: {std: [0.05, 0.02]}
transition: {mean_dwell_time: 10.0}
initial:
  covariance: {std: [0.5, 0.5]}
modes:
  - name: good
    model: ltc_linear
    params: {A: [[-5, 0], [0, -4]], B: [[0.39, 0.39], [-0.83, 0.83]]}
    Q: {diagonal: [0.01, 0.01]}
  - name: broken
    model: nan_above
    params: {above: 0.5}
    Q: {diagonal: [0.01, 0.01]}
)");
  std::string log = "t,phi_dot_L,phi_dot_R,V,omega\n";
  for (int k = 0; k < 5; ++k) log += std::to_string(0.1 * k) + ",6,6,1.0,0.0\n";
  skidimm_test::write_file(dir / "log.csv", log);
  const std::string command = std::string(SKIDIMM_EXECUTABLE) + " run --bank " + bank.string() + " --plugin-path " +
                              kNanAboveDir.string() + " --input " + (dir / "log.csv").string() + " --output " +
                              (dir / "out.csv").string() + " > " + (dir / "stdout").string() + " 2> " +
                              (dir / "stderr").string();
  ASSERT_EQ(std::system(command.c_str()), 0) << skidimm_test::read_file(dir / "stderr");
  const std::string summary = skidimm_test::read_file(dir / "stderr");
  EXPECT_THAT(summary, HasSubstr("mode 'broken' (plugin nan_above 0.0.1"));
  EXPECT_THAT(summary, HasSubstr("jacobian() is not finite: entry (row 1 'omega', column 0 'V')"));
  EXPECT_THAT(summary, ::testing::Not(HasSubstr("without a reason")));
}

}  // namespace
}  // namespace skidimm
