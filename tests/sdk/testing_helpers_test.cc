// The plugin author's testing helpers: load_plugin_model and conformance over
// an operating region, which must find what a single point misses and name
// the failing Jacobian entry.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>

#include "skidimm/sdk/function_model.h"
#include "skidimm/sdk/testing/conformance.h"
#include "skidimm/sdk/testing/load_plugin_model.h"

namespace {

using ::testing::HasSubstr;
using skidimm::sdk::testing::load_plugin_model;
using skidimm::sdk::testing::MotionModelConforms;
using skidimm::sdk::testing::MotionModelConformsOver;
using skidimm::sdk::testing::OperatingRegion;

const std::string kTestPlugins = SKIDIMM_TEST_PLUGIN_ROOT;

skidimm::sdk::ParameterSet slip_ratio_params() {
  skidimm::sdk::ParameterSet p;
  p.set_scalar("s_ss", 0.2);
  p.set_scalar("m", 0.6);
  p.set_scalar("tau", 0.05);
  p.set_scalar("tau_s", 0.5);
  p.set_scalar("r", 0.165);
  p.set_scalar("b", 0.555);
  return p;
}

std::string load_error(const std::string& path, const skidimm::sdk::ParameterSet& params) {
  try {
    load_plugin_model(path, params);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  ADD_FAILURE() << "loaded " << path;
  return "";
}

TEST(LoadPluginModel, CreatesTheModelThroughThePluginsOwnFactory) {
  auto model = load_plugin_model(kTestPlugins + "/slip_ratio/slip_ratio_plugin.so", slip_ratio_params());
  ASSERT_EQ(model->state_dim(), 3);
  Eigen::VectorXd next(3);
  ASSERT_TRUE(model->predict(Eigen::Vector3d(1.0, 0.0, 0.1), Eigen::Vector2d(10.0, 10.0), 0.01, next));
  EXPECT_DOUBLE_EQ(next[0], 1.0 + 0.01 * ((1.0 - 0.1) * 0.165 * 10.0 - 1.0) / 0.05);
  EXPECT_DOUBLE_EQ(next[2], 0.1 + 0.01 * (0.2 - 0.1) / 0.5);
}

TEST(LoadPluginModel, SaysWhatIsWrongNamingTheFile) {
  const std::string missing = kTestPlugins + "/nowhere/none.so";
  EXPECT_THAT(load_error(missing, {}), HasSubstr("plugin " + missing + ": cannot load: " + missing + ": cannot open"));
  EXPECT_THAT(load_error(kTestPlugins + "/wrong_abi/wrong_abi_plugin.so", {}), HasSubstr("built for plugin ABI"));
  EXPECT_THAT(load_error(kTestPlugins + "/not_a_plugin/not_a_plugin.so", {}),
              HasSubstr("does not export 'skidimm_abi_version'"));
  EXPECT_THAT(load_error(kTestPlugins + "/old_string_abi/old_string_abi_plugin.so", {}),
              HasSubstr("standard library configuration"));
  skidimm::sdk::ParameterSet p = slip_ratio_params();
  p.set_scalar("tau", -1.0);
  EXPECT_THAT(load_error(kTestPlugins + "/slip_ratio/slip_ratio_plugin.so", p),
              HasSubstr("'slip_ratio' rejected its parameters: "));
}

// [V, omega]; V' = -V + u0, omega' = -omega + V u1. Defects: the (omega, V)
// Jacobian entry loses its u1 factor, or predict gives NaN above 0.5 m/s.
class TwoStateModel : public skidimm::sdk::SizedMotionModel<2, 2> {
 public:
  enum Defect { kNone, kWrongOmegaByV, kNanAboveHalfAMetrePerSecond };
  explicit TwoStateModel(Defect defect) : defect_(defect) {}
  const std::vector<std::string>& state_names() const noexcept override { return states_; }
  const std::vector<std::string>& input_names() const noexcept override { return inputs_; }
  const std::vector<skidimm::sdk::ParameterInfo>& parameter_info() const noexcept override { return info_; }
  void get_parameters(Eigen::Ref<Eigen::VectorXd>) const noexcept override {}
  bool set_parameters(const Eigen::Ref<const Eigen::VectorXd>& v, std::string*) noexcept override {
    return v.size() == 0;
  }
  bool predict_fixed(const State& x, const Input& u, double dt, State* next) const override {
    (*next)[0] = x[0] + (-x[0] + u[0]) * dt;
    (*next)[1] = x[1] + (-x[1] + x[0] * u[1]) * dt;
    if (defect_ == kNanAboveHalfAMetrePerSecond && x[0] > 0.5) (*next)[1] = std::nan("");
    return true;
  }
  bool jacobian_fixed(const State& x, const Input& u, double dt, Jacobian* j) const override {
    *j << 1.0 - dt, 0.0, (defect_ == kWrongOmegaByV ? 1.0 : u[1]) * dt, 1.0 - dt;
    (void)x;
    return true;
  }
  bool has_analytic_jacobian() const noexcept override { return true; }

 private:
  Defect defect_;
  const std::vector<std::string> states_{"V", "omega"};
  const std::vector<std::string> inputs_{"a", "k"};
  const std::vector<skidimm::sdk::ParameterInfo> info_;
};

OperatingRegion region() {
  OperatingRegion r;
  r.x_min = Eigen::Vector2d(-1.0, -1.0);
  r.x_max = Eigen::Vector2d(1.8, 1.0);  // the centre, V = 0.4, is below 0.5
  r.u_min = Eigen::Vector2d(-1.0, 0.5);
  r.u_max = Eigen::Vector2d(1.0, 3.0);
  return r;
}

TEST(ConformanceOverARegion, PassesACorrectModel) {
  TwoStateModel model(TwoStateModel::kNone);
  EXPECT_MOTION_MODEL_CONFORMS_OVER(model, region());
}

TEST(ConformanceOverARegion, FindsANanThatOnePointMissesAndSaysWhere) {
  TwoStateModel model(TwoStateModel::kNanAboveHalfAMetrePerSecond);
  EXPECT_TRUE(MotionModelConforms(model, Eigen::Vector2d(0.2, 0.1), Eigen::Vector2d(0.5, 1.0), 0.05));
  const auto result = MotionModelConformsOver(model, region());
  ASSERT_FALSE(result);
  EXPECT_THAT(result.message(), HasSubstr("operating points"));
  EXPECT_THAT(result.message(), HasSubstr("at operating point 2: x = [1.8, 1], u = [1, 3], dt = 0.1"));
  EXPECT_THAT(result.message(), HasSubstr("predict(x, u, dt) is not finite"));
}

TEST(ConformanceOverARegion, NamesTheWrongJacobianEntryWithBothValues) {
  TwoStateModel model(TwoStateModel::kWrongOmegaByV);
  // At u1 = 1 the defect is invisible.
  EXPECT_TRUE(MotionModelConforms(model, Eigen::Vector2d(0.2, 0.1), Eigen::Vector2d(0.5, 1.0), 0.05));
  const auto at_one_point = MotionModelConforms(model, Eigen::Vector2d(0.2, 0.1), Eigen::Vector2d(0.5, 3.0), 0.1);
  ASSERT_FALSE(at_one_point);
  EXPECT_THAT(at_one_point.message(), HasSubstr("jacobian() differs from central differences"));
  EXPECT_THAT(at_one_point.message(), HasSubstr("at x = [0.2, 0.1], u = [0.5, 3], dt = 0.1"));
  EXPECT_THAT(at_one_point.message(), HasSubstr("entry (row 1 'omega', column 0 'V'): analytic 0.1, numeric 0.3"));
  EXPECT_THAT(at_one_point.message(), ::testing::Not(HasSubstr("(row 0")));
  EXPECT_FALSE(MotionModelConformsOver(model, region()));
}

TEST(ConformanceOverARegion, RefusesBoundsOfTheWrongSize) {
  TwoStateModel model(TwoStateModel::kNone);
  OperatingRegion r = region();
  r.u_max = Eigen::Vector3d(1.0, 1.0, 1.0);
  EXPECT_THAT(MotionModelConformsOver(model, r).message(), HasSubstr("wrong sizes for this model (2 states, 2 inputs)"));
}

}  // namespace
