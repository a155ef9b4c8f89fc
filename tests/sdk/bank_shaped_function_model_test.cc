// A function model whose states, inputs and parameter shapes come from the
// bank (sdk/bank_layout.h, bank_shaped_function_model.h), in-process: a
// small spec here, each state decaying at its own rate towards gain times
// the sum of the inputs. (linear_features, the bundled one, is tested on its
// own maths in tests/plugins/linear_features_test.cc.)
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "skidimm/sdk/function_model.h"
#include "skidimm/sdk/testing/conformance.h"

namespace skidimm {
namespace {

using ::testing::HasSubstr;

// x_i+ = x_i + dt (g sum(u) - k_i x_i): forward Euler. It throws above
// x_0 = 100 and gives NaN below x_0 = -100, to reach the boundary.
struct BankDecay {
  static constexpr const char* kName = "bank_decay";
  static constexpr const char* kVersion = "0.1.0";
  static constexpr const char* kDescription = "states decaying towards gain times the inputs' sum";
  static constexpr int kMaxStates = 3, kMaxInputs = 2, kMaxParameters = kMaxStates + 1;
  static constexpr sdk::ParameterSpec kParameters[] = {
      {"k", "decay rate of each state (1/s)", sdk::BankShape{"n"}},
      {"g", "gain (-)", 0.0, 10.0},
      {"hold", "keys held at their given values", sdk::TextList{"text list, optional"}},
  };
  enum Row { kK, kG, kHold };

  static bool layout(const sdk::ParameterSet& params, sdk::Layout* layout, std::string* error) {
    (*layout)[kK].shape = sdk::Shape{layout->num_states(), 1};
    (*layout)[kK].is_list = true;
    if (const std::vector<std::string>* held = params.find_text("hold")) {
      for (const std::string& key : *held) {
        if (key != "k") {
          *error = "parameter 'hold': only k can be held, not '" + key + "'";
          return false;
        }
        (*layout)[kK].fixed = true;
      }
    }
    return true;
  }
  static void predict(const sdk::Layout& layout, const double* x, const double* u, const double* p, double dt,
                      double* x_next) {
    if (x[0] > 100.0) throw std::runtime_error("x_0 above 100");
    double drive = 0.0;
    for (int j = 0; j < layout.num_inputs(); ++j) drive += u[j];
    const double* k = p + layout[kK].offset;
    const double g = p[layout[kG].offset];
    for (int i = 0; i < layout.num_states(); ++i) x_next[i] = x[i] + dt * (g * drive - k[i] * x[i]);
    if (x[0] < -100.0) x_next[1] = std::nan("");
  }
  // Every entry of p, k's columns too even when held (the SDK drops them).
  static void parameter_jacobian(const sdk::Layout& layout, const double* x, const double* u, const double* /*p*/,
                                 double dt, double* jacobian) {
    const int n = layout.num_states(), columns = layout.num_entries();
    double drive = 0.0;
    for (int j = 0; j < layout.num_inputs(); ++j) drive += u[j];
    for (int i = 0; i < n; ++i) {
      jacobian[i * columns + layout[kK].offset + i] = -dt * x[i];
      jacobian[i * columns + layout[kG].offset] = dt * drive;
    }
  }
};
using BankDecayModel = sdk::FunctionModel<BankDecay>;

// BankDecay with a hand-written state Jacobian and process noise, each with
// an entry off the diagonal on one side only (so that a transposed copy
// shows), and with entries that are not finite below x_0 = -100.
struct BankCoupled : BankDecay {
  static constexpr double kCoupling = 0.5, kNoiseCoupling = 0.25;
  static void jacobian(const sdk::Layout& layout, const double* x, const double* /*u*/, const double* p, double dt,
                       double* jacobian) {
    const int n = layout.num_states();
    const double* k = p + layout[kK].offset;
    for (int i = 0; i < n * n; ++i) jacobian[i] = 0.0;
    for (int i = 0; i < n; ++i) jacobian[i * n + i] = 1.0 - dt * k[i];
    jacobian[0 * n + 1] = kCoupling * dt;
    if (x[0] < -100.0) {
      jacobian[1 * n + 2] = std::nan("");
      jacobian[2 * n + 0] = std::numeric_limits<double>::infinity();
    }
  }
  static void process_noise(const sdk::Layout& layout, const double* intensity, const double* x, const double* /*u*/,
                            const double* /*p*/, double dt, double* noise) {
    const int n = layout.num_states();
    for (int i = 0; i < n * n; ++i) noise[i] = intensity[i] * dt;
    noise[0 * n + 2] += kNoiseCoupling * dt;
    if (x[0] < -100.0) {
      noise[2 * n + 1] = -std::numeric_limits<double>::infinity();
      noise[2 * n + 2] = std::nan("");
    }
  }
};
using BankCoupledModel = sdk::FunctionModel<BankCoupled>;

sdk::ParameterSet decay_params(std::vector<std::string> states = {"a", "b", "theta"}) {
  sdk::ParameterSet p;
  p.set("k", Eigen::Vector3d(1.0, 2.0, 4.0).head(static_cast<Eigen::Index>(std::min<std::size_t>(states.size(), 3))));
  p.set_scalar("g", 0.5);
  std::vector<bool> angles(states.size(), false);
  angles.back() = true;
  p.set_bank_names(states, angles, {"u0", "u1"});
  return p;
}

std::string creation_error(const sdk::ParameterSet& p) {
  std::string error;
  return BankDecayModel::Create(p, &error) ? "no error" : error;
}

TEST(BankShapedFunctionModel, TakesItsNamesAndShapesFromTheBank) {
  std::string error;
  auto model = BankDecayModel::Create(decay_params(), &error);
  ASSERT_TRUE(model) << error;
  EXPECT_EQ(model->state_names(), (std::vector<std::string>{"a", "b", "theta"}));
  EXPECT_EQ(model->input_dim(), 2);
  EXPECT_TRUE(model->is_angle(2));
  EXPECT_FALSE(model->is_angle(0));
  std::vector<std::string> names;
  for (const sdk::ParameterInfo& p : model->parameter_info()) names.push_back(p.name);
  EXPECT_EQ(names, (std::vector<std::string>{"k[0]", "k[1]", "k[2]", "g"}));
  EXPECT_EQ(model->parameter_info()[3].upper_bound, 10.0);
  // By hand: a+ = 1 + 0.1 (0.5 (2 + 1) - 1 * 1) = 1.05; theta wraps.
  Eigen::VectorXd next(3);
  ASSERT_TRUE(model->predict(Eigen::Vector3d(1.0, 0.0, 3.1), Eigen::Vector2d(2.0, 1.0), 0.1, next));
  EXPECT_DOUBLE_EQ(next[0], 1.05);
  EXPECT_DOUBLE_EQ(next[1], 0.15);
  EXPECT_NEAR(next[2], 3.1 + 0.1 * (1.5 - 4.0 * 3.1), 1e-15);
  ASSERT_TRUE(model->predict(Eigen::Vector3d(1.0, 0.0, 3.1), Eigen::Vector2d(40.0, 1.0), 0.1, next));
  EXPECT_NEAR(next[2], 3.1 + 0.1 * (20.5 - 4.0 * 3.1) - 2.0 * M_PI, 1e-12);
}

TEST(BankShapedFunctionModel, AHeldKeyStaysInTheFunctionsButLeavesTheParameters) {
  sdk::ParameterSet p = decay_params();
  p.set_text("hold", {"k"});
  std::string error;
  auto model = BankDecayModel::Create(p, &error);
  ASSERT_TRUE(model) << error;
  ASSERT_EQ(model->parameter_info().size(), 1u);
  EXPECT_EQ(model->parameter_info()[0].name, "g");
  Eigen::VectorXd values(1);
  model->get_parameters(values);
  EXPECT_EQ(values[0], 0.5);
  ASSERT_TRUE(model->set_parameters(Eigen::VectorXd::Constant(1, 2.0), &error)) << error;
  Eigen::VectorXd next(3);
  ASSERT_TRUE(model->predict(Eigen::Vector3d(1.0, 0.0, 0.0), Eigen::Vector2d(2.0, 1.0), 0.1, next));
  EXPECT_DOUBLE_EQ(next[0], 1.0 + 0.1 * (6.0 - 1.0));  // k_0 = 1 still applies
  // One column, g's: d a+ / d g = dt (u0 + u1).
  Eigen::MatrixXd jacobian(3, 1);
  ASSERT_TRUE(model->parameter_jacobian(Eigen::Vector3d(1.0, 0.0, 0.0), Eigen::Vector2d(2.0, 1.0), 0.1, jacobian));
  EXPECT_DOUBLE_EQ(jacobian(0, 0), 0.3);
  EXPECT_FALSE(model->set_parameters(Eigen::VectorXd::Constant(1, 11.0), &error));
  EXPECT_THAT(error, HasSubstr("parameter 'g' = 11"));
}

TEST(BankShapedFunctionModel, CreateRefusesWhatTheBankGetsWrongNamingIt) {
  sdk::ParameterSet no_bank = decay_params();
  no_bank.set_bank_names({}, {}, {});
  EXPECT_THAT(creation_error(no_bank),
              HasSubstr("bank_decay takes its states and inputs from the bank (its 'states:' and 'inputs:')"));
  EXPECT_THAT(creation_error(decay_params({"a", "b", "c", "d"})),
              HasSubstr("bank_decay supports at most 3 states, the bank has 4 (a, b, c, d)"));
  sdk::ParameterSet unknown = decay_params();
  unknown.set_scalar("q", 1.0);
  EXPECT_THAT(creation_error(unknown), HasSubstr("unknown parameter 'q' (this model takes: k, g, hold)"));
  sdk::ParameterSet wrong_shape = decay_params();
  wrong_shape.set("k", Eigen::Vector2d(1.0, 2.0));
  EXPECT_THAT(creation_error(wrong_shape), HasSubstr("parameter 'k' must be 3x1, got 2x1"));
  sdk::ParameterSet held_nan = decay_params();
  held_nan.set("k", Eigen::Vector3d(1.0, std::nan(""), 4.0));
  held_nan.set_text("hold", {"k"});  // held or not, a value that is not finite is refused
  EXPECT_THAT(creation_error(held_nan), HasSubstr("parameter 'k[1]' is not finite"));
  sdk::ParameterSet bad_hold = decay_params();
  bad_hold.set_text("hold", {"g"});
  EXPECT_THAT(creation_error(bad_hold), HasSubstr("only k can be held, not 'g'"));
  sdk::ParameterSet too_large = decay_params();
  too_large.set_scalar("g", 20.0);
  EXPECT_THAT(creation_error(too_large), HasSubstr("parameter 'g' = 20"));
}

TEST(BankShapedFunctionModel, AThrowOrANanRejectsTheStepWithTheReason) {
  std::string error;
  auto model = BankDecayModel::Create(decay_params(), &error);
  ASSERT_TRUE(model) << error;
  Eigen::VectorXd next(3);
  EXPECT_FALSE(model->predict(Eigen::Vector3d(200.0, 0.0, 0.0), Eigen::Vector2d(1.0, 1.0), 0.1, next));
  EXPECT_EQ(std::string(model->failure_reason()), "predict() threw: x_0 above 100");
  EXPECT_FALSE(model->predict(Eigen::Vector3d(-200.0, 0.0, 0.0), Eigen::Vector2d(1.0, 1.0), 0.1, next));
  EXPECT_THAT(std::string(model->failure_reason()),
              HasSubstr("predict() gave a state that is not finite: b = nan (x_next[1]) at x = [-200, 0, 0]"));
  EXPECT_FALSE(model->predict(Eigen::Vector3d(1.0, 0.0, 0.0), Eigen::Vector2d(1.0, 1.0), -0.1, next));
  EXPECT_THAT(std::string(model->failure_reason()), HasSubstr("dt = -0.1 is not finite and non-negative"));
}

// The spec writes its matrices row by row; the model hands them over column
// major, into any view (a corner of a larger matrix here, whose other
// entries stay as they were), or names the first entry that is not finite.
TEST(BankShapedFunctionModel, HandWrittenMatricesArriveWholeOrNameTheirFirstEntryThatIsNotFinite) {
  std::string error;
  auto model = BankCoupledModel::Create(decay_params(), &error);
  ASSERT_TRUE(model) << error;
  ASSERT_TRUE(model->has_analytic_jacobian());
  const Eigen::Vector2d u(1.0, 1.0);
  const double dt = 0.1;
  const Eigen::Vector3d k(1.0, 2.0, 4.0);
  Eigen::Matrix3d expected_f = Eigen::Matrix3d::Zero();
  for (int i = 0; i < 3; ++i) expected_f(i, i) = 1.0 - dt * k[i];
  expected_f(0, 1) = BankCoupled::kCoupling * dt;
  Eigen::Matrix3d intensity;
  intensity << 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0;
  Eigen::Matrix3d expected_q = intensity * dt;
  expected_q(0, 2) += BankCoupled::kNoiseCoupling * dt;

  Eigen::MatrixXd f = Eigen::MatrixXd::Constant(5, 4, -7.0), q = Eigen::MatrixXd::Constant(5, 4, -7.0);
  ASSERT_TRUE(model->jacobian(Eigen::Vector3d(1.0, 0.0, 0.0), u, dt, f.topLeftCorner(3, 3)));
  ASSERT_TRUE(model->process_noise(intensity, Eigen::Vector3d(1.0, 0.0, 0.0), u, dt, q.topLeftCorner(3, 3)));
  EXPECT_EQ(Eigen::Matrix3d(f.topLeftCorner(3, 3)), expected_f);
  EXPECT_EQ(Eigen::Matrix3d(q.topLeftCorner(3, 3)), expected_q);
  for (const Eigen::MatrixXd* m : {&f, &q}) {
    EXPECT_TRUE((m->bottomRows(2).array() == -7.0).all());
    EXPECT_TRUE((m->rightCols(1).array() == -7.0).all());
  }

  Eigen::MatrixXd out(3, 3);
  EXPECT_FALSE(model->jacobian(Eigen::Vector3d(-200.0, 0.0, 0.0), u, dt, out));
  EXPECT_THAT(std::string(model->failure_reason()),
              HasSubstr("jacobian() is not finite: entry (row 1 'b', column 2 'theta') = nan"));
  EXPECT_FALSE(model->process_noise(intensity, Eigen::Vector3d(-200.0, 0.0, 0.0), u, dt, out));
  EXPECT_THAT(std::string(model->failure_reason()),
              HasSubstr("process_noise() is not finite: entry (row 2 'theta', column 1 'b') = -inf"));
}

// No jets at runtime sizes: the state Jacobian is differenced, and the
// hand-written parameter Jacobian is checked against central differences.
TEST(BankShapedFunctionModel, ConformsWithItsHandWrittenParameterJacobian) {
  std::string error;
  auto model = BankDecayModel::Create(decay_params(), &error);
  ASSERT_TRUE(model) << error;
  EXPECT_FALSE(model->has_analytic_jacobian());
  EXPECT_MOTION_MODEL_CONFORMS(*model, Eigen::Vector3d(0.4, -1.0, 2.0), Eigen::Vector2d(1.5, -0.5), 0.05);
  Eigen::MatrixXd jacobian(3, 4);
  ASSERT_TRUE(model->parameter_jacobian(Eigen::Vector3d(0.4, -1.0, 2.0), Eigen::Vector2d(1.5, -0.5), 0.05, jacobian));
  EXPECT_DOUBLE_EQ(jacobian(1, 1), 0.05);  // d b+ / d k_1 = -dt b
  EXPECT_DOUBLE_EQ(jacobian(1, 0), 0.0);
}

// A parameter Jacobian that is not finite names its first such entry among
// the parameters the model fits; one in a held parameter's column, which
// the model drops, is no failure.
TEST(BankShapedFunctionModel, AParameterJacobianNotFiniteNamesItsEntryUnlessTheColumnIsHeld) {
  const Eigen::Vector3d x(1e308, 0.0, 0.0);  // d a+ / d k_0 = -dt a overflows at dt = 10
  const Eigen::Vector2d u(1.0, 2.0);
  std::string error;
  auto model = BankDecayModel::Create(decay_params(), &error);
  ASSERT_TRUE(model) << error;
  Eigen::MatrixXd jacobian(3, 4);
  EXPECT_FALSE(model->parameter_jacobian(x, u, 10.0, jacobian));
  EXPECT_THAT(std::string(model->failure_reason()),
              HasSubstr("parameter_jacobian() is not finite: entry (row 0 'a', column 0 'k[0]') = -inf"));

  sdk::ParameterSet held = decay_params();
  held.set_text("hold", {"k"});
  auto holding = BankDecayModel::Create(held, &error);
  ASSERT_TRUE(holding) << error;
  Eigen::MatrixXd g_only(3, 1);
  ASSERT_TRUE(holding->parameter_jacobian(x, u, 10.0, g_only)) << holding->failure_reason();
  EXPECT_EQ(g_only, Eigen::Vector3d::Constant(30.0));  // d x+ / d g = dt sum(u)
}

TEST(BankShapedFunctionModel, ThePluginInfoShowsTheTableWithoutStatesOrInputs) {
  const sdk::PluginInfo& info = BankDecayModel::info();
  EXPECT_STREQ(info.name, "bank_decay");
  EXPECT_EQ(info.num_states, 0);
  EXPECT_EQ(info.num_inputs, 0);
  ASSERT_EQ(info.num_parameters, 3);
  EXPECT_STREQ(info.parameters[0].shape, "n");
  EXPECT_STREQ(info.parameters[0].description, "decay rate of each state (1/s), per mode");
  EXPECT_STREQ(info.parameters[1].description, "gain (-), in [0, 10], per mode");
  EXPECT_STREQ(info.parameters[2].shape, "text list, optional");
}

}  // namespace
}  // namespace skidimm
