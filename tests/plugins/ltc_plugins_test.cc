// ltc_linear and ltc_shared, loaded from their real plugin files.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <type_traits>
#include <utility>

#include "ltc_common/ltc_model.h"
#include "skidimm/engine/plugin_registry.h"
#include "skidimm/sdk/testing/conformance.h"
#include "skidimm/sdk/testing/plugin_lifecycle.h"

namespace skidimm {
namespace {

sdk::ParameterSet terrain_params() {
  Eigen::Matrix2d a, b;
  a << -5.0, 0.2, 0.1, -4.0;
  b << 0.39, 0.39, -0.83, 0.83;
  sdk::ParameterSet p;
  p.set("A", a);
  p.set("B", b);
  return p;
}

class LtcPlugins : public ::testing::TestWithParam<const char*> {
 protected:
  PluginRegistry registry_{{SKIDIMM_PLUGIN_DIR}};
};

TEST_P(LtcPlugins, Conforms) {
  ModelHandle model = registry_.create(GetParam(), terrain_params());
  for (double dt : {0.001, 0.02, 0.5}) {
    EXPECT_MOTION_MODEL_CONFORMS(*model, Eigen::Vector2d(0.8, -0.3), Eigen::Vector2d(3.0, 6.5), dt);
  }
}

TEST_P(LtcPlugins, PredictsEquationTwoByHand) {
  ModelHandle model = registry_.create(GetParam(), terrain_params());
  Eigen::VectorXd next(2);
  ASSERT_TRUE(model->predict(Eigen::Vector2d(1.0, 0.5), Eigen::Vector2d(2.0, 4.0), 0.1, next));
  // V' = -5 * 1 + 0.2 * 0.5 + 0.39 * 6 = -2.56; omega' = 0.1 - 2 + 0.83 * 2 = -0.24.
  EXPECT_NEAR(next[0], 1.0 - 0.256, 1e-15);
  EXPECT_NEAR(next[1], 0.5 - 0.024, 1e-15);
  EXPECT_EQ(model->state_names(), (std::vector<std::string>{"V", "omega"}));
  EXPECT_EQ(model->input_names(), (std::vector<std::string>{"phi_dot_L", "phi_dot_R"}));
}

TEST_P(LtcPlugins, ParametersAreAThenBRowMajor) {
  ModelHandle model = registry_.create(GetParam(), terrain_params());
  ASSERT_EQ(model->parameter_info().size(), 8u);
  EXPECT_EQ(model->parameter_info()[1].name, "A[0,1]");
  EXPECT_EQ(model->parameter_info()[6].name, "B[1,0]");
  Eigen::VectorXd values(8);
  model->get_parameters(values);
  EXPECT_EQ(values[1], 0.2);
  EXPECT_EQ(values[6], -0.83);
}

TEST_P(LtcPlugins, RejectsMissingOrMisshapedParameters) {
  auto creation_error = [&](const sdk::ParameterSet& params) {
    try {
      registry_.create(GetParam(), params);
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  sdk::ParameterSet missing_b;
  missing_b.set("A", Eigen::Matrix2d::Identity());
  EXPECT_THAT(creation_error(missing_b), ::testing::HasSubstr("missing parameter 'B' (a 2x2 matrix)"));
  sdk::ParameterSet wrong = terrain_params();
  wrong.set("A", Eigen::Matrix3d::Identity());
  EXPECT_THAT(creation_error(wrong), ::testing::HasSubstr("parameter 'A' must be 2x2, got 3x3"));
}

TEST_P(LtcPlugins, SurvivesRepeatedLoadAndUnload) {
  const std::string file =
      std::string(GetParam()) == "ltc_linear" ? SKIDIMM_LTC_LINEAR_PLUGIN : SKIDIMM_LTC_SHARED_PLUGIN;
  EXPECT_PLUGIN_SURVIVES_RELOAD(file, terrain_params(), Eigen::Vector2d(0.8, -0.3), Eigen::Vector2d(3.0, 6.5), 0.02);
}

INSTANTIATE_TEST_SUITE_P(Bundled, LtcPlugins, ::testing::Values("ltc_linear", "ltc_shared"));

// The hand-written F = I + A dt is what jets of predict gave before it was
// written, to the bit (banks' outputs did not move), for A with zero and
// negative entries, steps short and long, and any state and input.
TEST(LtcJacobian, IsTheJetsJacobianBitForBit) {
  std::mt19937 random(20261126);
  std::uniform_real_distribution<double> entry(-8.0, 8.0);
  for (int trial = 0; trial < 200; ++trial) {
    Eigen::Matrix2d a, b;
    a << entry(random), entry(random), entry(random), entry(random);
    b << entry(random), entry(random), entry(random), entry(random);
    if (trial % 4 == 1) a(0, 1) = a(1, 0) = 0.0;  // decoupled
    if (trial % 4 == 2) a.setZero();
    sdk::ParameterSet params;
    params.set("A", a);
    params.set("B", b);
    std::string error;
    const auto model = plugins::LtcModel<sdk::ParameterScope::kMode>::Create(params, &error);
    ASSERT_NE(model, nullptr) << error;
    const Eigen::Vector2d x(entry(random), entry(random)), u(entry(random), entry(random));
    for (double dt : {1e-4, 0.02, 0.5, 3.0}) {
      Eigen::Matrix2d written, jets;
      ASSERT_TRUE(model->jacobian_fixed(x, u, dt, &written));
      model->automatic_jacobian(x, u, dt, &jets);
      for (int r = 0; r < 2; ++r) {
        for (int c = 0; c < 2; ++c) {
          EXPECT_EQ(std::memcmp(&written(r, c), &jets(r, c), sizeof(double)), 0)
              << "entry (" << r << ", " << c << ") at trial " << trial << ", dt " << dt << ": " << written(r, c)
              << " against " << jets(r, c);
        }
      }
    }
  }
}

TEST(LtcScopes, SharedVariantDeclaresBankScope) {
  PluginRegistry registry({SKIDIMM_PLUGIN_DIR});
  // The handles are named: the vectors parameter_info() returns live in the models.
  const ModelHandle shared = registry.create("ltc_shared", terrain_params());
  ASSERT_EQ(shared->parameter_info().size(), 8u);
  for (const auto& info : shared->parameter_info()) {
    EXPECT_EQ(info.scope, sdk::ParameterScope::kBank) << info.name;
  }
  const ModelHandle linear = registry.create("ltc_linear", terrain_params());
  ASSERT_EQ(linear->parameter_info().size(), 8u);
  for (const auto& info : linear->parameter_info()) {
    EXPECT_EQ(info.scope, sdk::ParameterScope::kMode) << info.name;
  }
}

// Whether `expr->` compiles for an expression of type T (an rvalue when T is
// not a reference).
template <typename T, typename = void>
struct CanArrow : std::false_type {};
template <typename T>
struct CanArrow<T, std::void_t<decltype(std::declval<T>().operator->())>> : std::true_type {};

// `for (auto& x : registry.create(...)->parameter_info())`
// read a destroyed model. A temporary handle cannot be dereferenced; a named
// one can.
TEST(ModelHandleLifetime, ATemporaryHandleCannotBeDereferencedANamedOneCan) {
  constexpr bool temporary = CanArrow<ModelHandle>::value;
  constexpr bool named = CanArrow<ModelHandle&>::value;
  constexpr bool named_const = CanArrow<const ModelHandle&>::value;
  EXPECT_FALSE(temporary);
  EXPECT_TRUE(named);
  EXPECT_TRUE(named_const);
}

}  // namespace
}  // namespace skidimm
