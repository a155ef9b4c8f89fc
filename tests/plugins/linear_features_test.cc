// linear_features, loaded from its real plugin file: a model defined by the
// bank alone. The references here are independent of the plugin's maths:
// Eigen's own matrix exponential (unsupported/MatrixFunctions), fine RK4
// integration, Simpson quadrature, closed forms by hand and a Lyapunov solve.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <Eigen/LU>
#include <cmath>
#include <string>
#include <unsupported/Eigen/MatrixFunctions>
#include <vector>

#include "core/temp_files.h"
#include "linear_features/zero_order_hold.h"
#include "skidimm/config/bank.h"
#include "skidimm/engine/plugin_registry.h"
#include "skidimm/errors.h"
#include "skidimm/sdk/angles.h"
#include "skidimm/sdk/testing/conformance.h"
#include "skidimm/sdk/testing/plugin_lifecycle.h"

namespace skidimm {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;

const std::vector<std::string> kStates{"omega", "current", "vibration"};
const std::vector<std::string> kInputs{"v", "dv"};

Eigen::Matrix3d full_a() {
  Eigen::Matrix3d a;
  a << -4.0, 1.5, 0.0,  //
      0.5, -20.0, 0.3,  //
      0.0, 2.0, -0.8;
  return a;
}
Eigen::Vector3d diagonal_a() { return Eigen::Vector3d(-4.0, -20.0, -0.8); }
Eigen::Matrix<double, 3, 2> input_b() {
  Eigen::Matrix<double, 3, 2> b;
  b << 0.8, -0.3,  //
      1.2, 0.5,    //
      0.0, 0.7;
  return b;
}
Eigen::Vector3d offset_c() { return Eigen::Vector3d(0.1, -0.4, 0.25); }

// A mode's params as the bank loader hands them over: the bank's names too.
sdk::ParameterSet bank_params(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b, const Eigen::VectorXd* c,
                              const std::vector<std::string>& states = kStates,
                              const std::vector<std::string>& inputs = kInputs, std::vector<bool> angles = {}) {
  sdk::ParameterSet p;
  p.set("A", a);
  p.set("B", b);
  if (c != nullptr) p.set("c", *c);
  if (angles.empty()) angles.assign(states.size(), false);
  p.set_bank_names(states, angles, inputs);
  return p;
}

struct Form {
  const char* name;
  bool full;
  bool offset;
};
const Form kForms[] = {
    {"diagonal", false, false}, {"diagonal + c", false, true}, {"full", true, false}, {"full + c", true, true}};

sdk::ParameterSet form_params(const Form& form) {
  const Eigen::VectorXd c = offset_c();
  return bank_params(form.full ? Eigen::MatrixXd(full_a()) : Eigen::MatrixXd(diagonal_a()), input_b(),
                     form.offset ? &c : nullptr);
}

Eigen::MatrixXd a_matrix(const Form& form) {
  return form.full ? Eigen::MatrixXd(full_a()) : Eigen::MatrixXd(diagonal_a().asDiagonal());
}
Eigen::VectorXd drive(const Form& form, const Eigen::VectorXd& u) {
  Eigen::VectorXd w = input_b() * u;
  if (form.offset) w += offset_c();
  return w;
}

const Eigen::Vector3d kX(0.4, 3.0, -0.2);
const Eigen::Vector2d kU(2.5, 0.8);

// --- Independent references ---

// x(dt) of dx/dt = A x + w by classical RK4 with `steps` substeps.
Eigen::VectorXd rk4(const Eigen::MatrixXd& a, const Eigen::VectorXd& w, Eigen::VectorXd x, double dt, int steps) {
  const double h = dt / steps;
  auto f = [&](const Eigen::VectorXd& y) -> Eigen::VectorXd { return a * y + w; };
  for (int i = 0; i < steps; ++i) {
    const Eigen::VectorXd k1 = f(x);
    const Eigen::VectorXd k2 = f(x + 0.5 * h * k1);
    const Eigen::VectorXd k3 = f(x + 0.5 * h * k2);
    const Eigen::VectorXd k4 = f(x + h * k3);
    x += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
  }
  return x;
}

// int_0^dt expm(A s) Q expm(A s)' ds by composite Simpson, expm by Eigen.
Eigen::MatrixXd noise_by_quadrature(const Eigen::MatrixXd& a, const Eigen::MatrixXd& q, double dt, int intervals) {
  const double h = dt / intervals;
  Eigen::MatrixXd sum = Eigen::MatrixXd::Zero(a.rows(), a.cols());
  for (int i = 0; i <= intervals; ++i) {
    const Eigen::MatrixXd e = (a * (i * h)).exp();
    const double weight = (i == 0 || i == intervals) ? 1.0 : (i % 2 == 1 ? 4.0 : 2.0);
    sum += weight * e * q * e.transpose();
  }
  return sum * (h / 3.0);
}

// The stationary covariance P of a stable A: A P + P A' + Q = 0, by a
// Kronecker-form linear solve.
Eigen::MatrixXd stationary_covariance(const Eigen::MatrixXd& a, const Eigen::MatrixXd& q) {
  const Eigen::Index n = a.rows();
  Eigen::MatrixXd lyapunov = Eigen::MatrixXd::Zero(n * n, n * n);
  for (Eigen::Index i = 0; i < n; ++i) {
    for (Eigen::Index j = 0; j < n; ++j) {
      // vec(A P + P A') with column-major vec: (I (x) A + A (x) I) vec(P).
      lyapunov.block(i * n, j * n, n, n) += a(i, j) * Eigen::MatrixXd::Identity(n, n);
    }
    lyapunov.block(i * n, i * n, n, n) += a;
  }
  const Eigen::VectorXd p = lyapunov.fullPivLu().solve(-Eigen::Map<const Eigen::VectorXd>(q.data(), n * n));
  return Eigen::Map<const Eigen::MatrixXd>(p.data(), n, n);
}

// d predict / d parameters by central differences through set_parameters().
Eigen::MatrixXd numeric_parameter_jacobian(sdk::MotionModel& model, const Eigen::VectorXd& x, const Eigen::VectorXd& u,
                                           double dt) {
  const Eigen::Index p = static_cast<Eigen::Index>(model.parameter_info().size());
  Eigen::VectorXd values(p), perturbed(p), plus(model.state_dim()), minus(model.state_dim());
  model.get_parameters(values);
  Eigen::MatrixXd jacobian(model.state_dim(), p);
  for (Eigen::Index j = 0; j < p; ++j) {
    const double h = 1e-6 * std::max(1.0, std::abs(values[j]));
    perturbed = values;
    perturbed[j] = values[j] + h;
    EXPECT_TRUE(model.set_parameters(perturbed, nullptr) && model.predict(x, u, dt, plus));
    perturbed[j] = values[j] - h;
    EXPECT_TRUE(model.set_parameters(perturbed, nullptr) && model.predict(x, u, dt, minus));
    jacobian.col(j) = (plus - minus) / (2.0 * h);
  }
  model.set_parameters(values, nullptr);
  return jacobian;
}

double max_abs(const Eigen::MatrixXd& m) { return m.cwiseAbs().maxCoeff(); }

class LinearFeatures : public ::testing::Test {
 protected:
  ModelHandle create(const sdk::ParameterSet& params) { return registry_.create("linear_features", params); }
  std::string creation_error(const sdk::ParameterSet& params) {
    try {
      create(params);
    } catch (const std::exception& e) {
      return e.what();
    }
    return "no error";
  }

  PluginRegistry registry_{{SKIDIMM_PLUGIN_DIR}};
};

TEST_F(LinearFeatures, ConformsWithDiagonalAndFullAWithAndWithoutC) {
  for (const Form& form : kForms) {
    SCOPED_TRACE(form.name);
    ModelHandle model = create(form_params(form));
    for (double dt : {0.001, 0.05, 0.5, 2.0}) EXPECT_MOTION_MODEL_CONFORMS(*model, kX, kU, dt);
    EXPECT_TRUE(model->has_analytic_jacobian());
  }
}

// Where the parameter Jacobian can be nonzero (a mode with parameter
// uncertainty asks for those entries alone): with a diagonal A, a_r, B[r, :]
// and c[r] move state r alone; with a full A, every parameter every state.
// That the other entries are zero, and the entries are the Jacobian's, the
// conformance kit checks above.
TEST_F(LinearFeatures, DeclaresWhichStatesEachParameterMoves) {
  for (const Form& form : kForms) {
    SCOPED_TRACE(form.name);
    ModelHandle model = create(form_params(form));
    const std::vector<std::vector<int>>& rows = model->parameter_jacobian_rows();
    const std::vector<sdk::ParameterInfo>& info = model->parameter_info();
    ASSERT_EQ(rows.size(), info.size());
    for (std::size_t k = 0; k < rows.size(); ++k) {
      if (form.full) {
        EXPECT_EQ(rows[k], (std::vector<int>{0, 1, 2})) << info[k].name;
      } else {
        // The flat names: "A[r]", "B[r,j]", "c[r]".
        const int state = info[k].name[2] - '0';
        EXPECT_EQ(rows[k], std::vector<int>{state}) << info[k].name;
      }
    }
  }
}

// A bank without inputs: dx/dt = A x + c, and B is not a parameter.
TEST_F(LinearFeatures, WorksWithoutInputs) {
  sdk::ParameterSet params;
  params.set("A", Eigen::MatrixXd(full_a()));
  params.set("c", Eigen::MatrixXd(offset_c()));
  params.set_bank_names(kStates, {false, false, false}, {});
  ModelHandle model = create(params);
  EXPECT_EQ(model->input_dim(), 0);
  EXPECT_EQ(model->parameter_info().size(), 9u + 3u);
  const Eigen::VectorXd no_input(0);
  EXPECT_MOTION_MODEL_CONFORMS(*model, kX, no_input, 0.3);
  Eigen::VectorXd next(3);
  ASSERT_TRUE(model->predict(kX, no_input, 0.3, next));
  EXPECT_LT(max_abs(next - rk4(full_a(), offset_c(), kX, 0.3, 2000)), 1e-12);

  params.set("B", Eigen::MatrixXd(input_b()));
  EXPECT_THAT(creation_error(params), HasSubstr("the bank has no inputs, so linear_features takes no 'B'"));
}

TEST_F(LinearFeatures, SurvivesRepeatedLoadAndUnload) {
  for (const Form& form : kForms) {
    EXPECT_PLUGIN_SURVIVES_RELOAD(SKIDIMM_LINEAR_FEATURES_PLUGIN, form_params(form), kX, kU, 0.05) << form.name;
  }
}

TEST_F(LinearFeatures, DocumentsItselfAndItsKeys) {
  const PluginDescriptor& descriptor = registry_.find("linear_features");
  EXPECT_EQ(descriptor.version, "1.1.0");
  EXPECT_THAT(descriptor.description, HasSubstr("dx/dt = A x + B u + c"));
  EXPECT_EQ(descriptor.parameter_keys, (std::vector<std::string>{"A", "B", "c", "fixed"}));
}

// n = 1: x+ = e^{a dt} x + (e^{a dt} - 1) / a (b u + c), F = e^{a dt},
// Qd = q (e^{2 a dt} - 1) / (2 a).
TEST_F(LinearFeatures, ScalarStepMatchesTheClosedFormByHand) {
  const Eigen::VectorXd c = Eigen::VectorXd::Constant(1, 0.5);
  ModelHandle model = create(
      bank_params(Eigen::MatrixXd::Constant(1, 1, -2.0), Eigen::MatrixXd::Constant(1, 1, 3.0), &c, {"omega"}, {"dv"}));
  const Eigen::VectorXd x = Eigen::VectorXd::Constant(1, 1.0), u = Eigen::VectorXd::Constant(1, 2.0);
  Eigen::VectorXd next(1);
  Eigen::MatrixXd f(1, 1), noise(1, 1);
  ASSERT_TRUE(model->predict(x, u, 0.1, next));
  ASSERT_TRUE(model->jacobian(x, u, 0.1, f));
  ASSERT_TRUE(model->process_noise(Eigen::MatrixXd::Constant(1, 1, 0.3), x, u, 0.1, noise));
  const double decay = std::exp(-0.2);  // e^{a dt}
  EXPECT_NEAR(next[0], decay * 1.0 + (1.0 - decay) / 2.0 * (3.0 * 2.0 + 0.5), 1e-15);
  EXPECT_NEAR(f(0, 0), decay, 1e-16);
  EXPECT_NEAR(noise(0, 0), 0.3 * (1.0 - std::exp(-0.4)) / 4.0, 1e-17);

  // dt = 0 is exactly the identity.
  ASSERT_TRUE(model->predict(x, u, 0.0, next));
  EXPECT_EQ(next[0], 1.0);

  // a = 0: an integrator, x + dt (b u + c); and a tiny a has no cancellation.
  for (double a : {0.0, 1e-13, -1e-13}) {
    model = create(
        bank_params(Eigen::MatrixXd::Constant(1, 1, a), Eigen::MatrixXd::Constant(1, 1, 3.0), &c, {"omega"}, {"dv"}));
    ASSERT_TRUE(model->predict(x, u, 0.1, next));
    ASSERT_TRUE(model->process_noise(Eigen::MatrixXd::Constant(1, 1, 0.3), x, u, 0.1, noise));
    const double z = a * 0.1;  // to first order in z: e^z x + dt (1 + z / 2) w
    EXPECT_NEAR(next[0], (1.0 + z) * 1.0 + 0.1 * (1.0 + z / 2.0) * 6.5, 1e-15) << a;
    EXPECT_NEAR(noise(0, 0), 0.3 * 0.1 * (1.0 + z), 1e-17) << a;
  }
}

TEST_F(LinearFeatures, ScalarIntegralsAreAccurateAcrossTheirSeriesBoundary) {
  // int_0^dt s e^{a s} ds = (1 + (z - 1) e^z) / a^2, z = a dt, in long double
  // where that form is well conditioned; its series 1/2 + z/3 + z^2/8 near 0.
  for (double z : {-1.001, -0.999, -0.5, 0.999, 1.001, 3.0, -30.0}) {
    const long double zl = z;
    const long double expected = (1.0L + (zl - 1.0L) * std::exp(zl)) / (zl * zl);
    EXPECT_NEAR(plugins::exp_integral_derivative(z, 1.0), static_cast<double>(expected), 2e-15) << z;
  }
  EXPECT_DOUBLE_EQ(plugins::exp_integral_derivative(1e-7, 1.0), 0.5 + 1e-7 / 3.0 + 1e-14 / 8.0);
  EXPECT_DOUBLE_EQ(plugins::exp_integral_derivative(0.0, 2.0), 2.0);  // dt^2 / 2
  EXPECT_DOUBLE_EQ(plugins::exp_integral(0.0, 0.3), 0.3);
  EXPECT_DOUBLE_EQ(plugins::exp_integral(-1e-12, 0.3), 0.3 - 0.5e-12 * 0.09);
}

TEST_F(LinearFeatures, FullAMatchesRk4AndEigensMatrixExponential) {
  // Complex eigenvalues: a damped oscillation between the two states.
  Eigen::Matrix2d a;
  a << -1.0, 2.0, -3.0, -0.5;
  Eigen::Matrix2d b;
  b << 1.0, 0.5, 0.0, 2.0;
  const Eigen::VectorXd c = Eigen::Vector2d(0.3, -0.2);
  ModelHandle model = create(bank_params(a, b, &c, {"omega", "current"}, {"v", "dv"}));
  const Eigen::Vector2d x(0.7, -1.1), u(1.5, -0.4);
  const Eigen::VectorXd w = b * u + c;
  for (double dt : {0.01, 0.37, 3.0}) {
    Eigen::VectorXd next(2);
    ASSERT_TRUE(model->predict(x, u, dt, next));
    const Eigen::VectorXd expected = rk4(a, w, x, dt, 4000);
    EXPECT_LT(max_abs(next - expected), 1e-12)
        << "dt " << dt << ": " << next.transpose() << " vs " << expected.transpose();
    Eigen::MatrixXd f(2, 2);
    ASSERT_TRUE(model->jacobian(x, u, dt, f));
    EXPECT_LT(max_abs(f - Eigen::MatrixXd((a * dt).exp())), 1e-14) << dt;
  }

  // 3 states against Eigen's exponential of the augmented matrix [[A, w], [0, 0]] dt.
  const Form form = kForms[3];
  model = create(form_params(form));
  Eigen::MatrixXd augmented = Eigen::MatrixXd::Zero(4, 4);
  augmented.topLeftCorner(3, 3) = full_a();
  augmented.topRightCorner(3, 1) = drive(form, kU);
  for (double dt : {0.02, 0.5}) {
    const Eigen::MatrixXd e = (augmented * dt).exp();
    const Eigen::VectorXd expected = e.topLeftCorner(3, 3) * kX + e.topRightCorner(3, 1);
    Eigen::VectorXd next(3);
    ASSERT_TRUE(model->predict(kX, kU, dt, next));
    EXPECT_LT(max_abs(next - expected), 1e-13) << dt;
  }
}

// A Jordan block has no eigenvector basis; expm has the closed form
// e^{-2t} [[1, t], [0, 1]], and Gamma = [[g0, g1], [0, g0]] with
// g0 = (1 - e^{-2t}) / 2, g1 = int_0^t s e^{-2s} ds = (1 - e^{-2t} (1 + 2t)) / 4.
TEST_F(LinearFeatures, DefectiveFullAMatchesItsClosedForm) {
  Eigen::Matrix2d a;
  a << -2.0, 1.0, 0.0, -2.0;
  const Eigen::Matrix2d b = Eigen::Matrix2d::Identity();
  ModelHandle model = create(bank_params(a, b, nullptr, {"omega", "current"}, {"v", "dv"}));
  const Eigen::Vector2d x(1.0, 2.0), u(0.5, -1.0);
  const double t = 0.8, e = std::exp(-2.0 * t);
  Eigen::Matrix2d phi, gamma;
  phi << e, t * e, 0.0, e;
  const double g0 = (1.0 - e) / 2.0, g1 = (1.0 - e * (1.0 + 2.0 * t)) / 4.0;
  gamma << g0, g1, 0.0, g0;
  Eigen::VectorXd next(2);
  ASSERT_TRUE(model->predict(x, u, t, next));
  EXPECT_LT(max_abs(next - (phi * x + gamma * u)), 1e-15);
}

// A full A that happens to be diagonal is the diagonal form by another road:
// the matrix exponentials must agree with the closed forms to rounding.
TEST_F(LinearFeatures, FullAWithZeroCouplingAgreesWithTheDiagonalForm) {
  const Eigen::VectorXd c = offset_c();
  ModelHandle diagonal = create(bank_params(diagonal_a(), input_b(), &c));
  ModelHandle full = create(bank_params(Eigen::MatrixXd(diagonal_a().asDiagonal()), input_b(), &c));
  Eigen::Matrix3d q;
  q << 0.5, 0.1, 0.0, 0.1, 2.0, -0.3, 0.0, -0.3, 0.2;
  for (double dt : {1e-4, 0.05, 0.5, 2.0}) {
    Eigen::VectorXd next_d(3), next_f(3);
    Eigen::MatrixXd f_d(3, 3), f_f(3, 3), q_d(3, 3), q_f(3, 3), j_d(3, 12), j_f(3, 18);
    ASSERT_TRUE(diagonal->predict(kX, kU, dt, next_d) && full->predict(kX, kU, dt, next_f));
    ASSERT_TRUE(diagonal->jacobian(kX, kU, dt, f_d) && full->jacobian(kX, kU, dt, f_f));
    ASSERT_TRUE(diagonal->process_noise(q, kX, kU, dt, q_d) && full->process_noise(q, kX, kU, dt, q_f));
    ASSERT_TRUE(diagonal->parameter_jacobian(kX, kU, dt, j_d) && full->parameter_jacobian(kX, kU, dt, j_f));
    EXPECT_LT(max_abs(next_d - next_f), 1e-14) << dt;
    EXPECT_LT(max_abs(f_d - f_f), 1e-15) << dt;
    EXPECT_LT(max_abs(q_d - q_f), 1e-14) << dt;
    // d/dA[i] (diagonal) is d/dA[i,i] (full); B and c columns are the same.
    for (int i = 0; i < 3; ++i) EXPECT_LT(max_abs(j_d.col(i) - j_f.col(4 * i)), 1e-13) << dt << " A" << i;
    EXPECT_LT(max_abs(j_d.rightCols(9) - j_f.rightCols(9)), 1e-14) << dt;
  }
}

TEST_F(LinearFeatures, ProcessNoiseMatchesQuadratureInBothForms) {
  Eigen::Matrix3d q;
  q << 0.5, 0.1, 0.0, 0.1, 2.0, -0.3, 0.0, -0.3, 0.2;
  for (const Form& form : {kForms[0], kForms[2]}) {
    ModelHandle model = create(form_params(form));
    for (double dt : {0.01, 0.3, 1.0}) {
      Eigen::MatrixXd noise(3, 3);
      ASSERT_TRUE(model->process_noise(q, kX, kU, dt, noise));
      const Eigen::MatrixXd expected = noise_by_quadrature(a_matrix(form), q, dt, 20000);
      EXPECT_LT(max_abs(noise - expected), 1e-12 * max_abs(expected)) << form.name << " dt " << dt << "\n"
                                                                      << noise << "\nvs\n"
                                                                      << expected;
      EXPECT_EQ(noise, noise.transpose());
    }
  }
}

// The point of the exact Qd: a fast stable state's added variance saturates
// at the stationary value (q / 2|a| for a scalar) instead of growing as Q dt.
TEST_F(LinearFeatures, ProcessNoiseSaturatesForAFastStableState) {
  const Eigen::VectorXd x = Eigen::VectorXd::Zero(1), u = Eigen::VectorXd::Zero(1);
  ModelHandle scalar = create(bank_params(Eigen::MatrixXd::Constant(1, 1, -50.0), Eigen::MatrixXd::Constant(1, 1, 1.0),
                                          nullptr, {"omega"}, {"dv"}));
  Eigen::MatrixXd noise(1, 1);
  ASSERT_TRUE(scalar->process_noise(Eigen::MatrixXd::Constant(1, 1, 1.0), x, u, 2.0, noise));
  EXPECT_NEAR(noise(0, 0), 1.0 / 100.0, 1e-17);  // Q dt would be 2: 200 times more
  ASSERT_TRUE(scalar->process_noise(Eigen::MatrixXd::Constant(1, 1, 1.0), x, u, 1e-4, noise));
  EXPECT_NEAR(noise(0, 0), 1e-4, 1e-6);  // a short step is still about Q dt
  EXPECT_NEAR(noise(0, 0), -std::expm1(-0.01) / 100.0, 1e-19);

  // Full A, coupled: Qd -> the solution of A P + P A' + Q = 0, even at
  // |A| dt = 1000 where Van Loan's expm(-A dt) alone would overflow.
  Eigen::Matrix2d a, q;
  a << -50.0, 5.0, 0.0, -30.0;
  q << 1.0, 0.2, 0.2, 0.5;
  ModelHandle full = create(bank_params(a, Eigen::Matrix2d::Identity(), nullptr, {"omega", "current"}, {"v", "dv"}));
  const Eigen::MatrixXd stationary = stationary_covariance(a, q);
  for (double dt : {2.0, 20.0}) {
    Eigen::MatrixXd qd(2, 2);
    ASSERT_TRUE(full->process_noise(q, Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero(), dt, qd)) << dt;
    EXPECT_LT(max_abs(qd - stationary), 1e-14) << dt << "\n" << qd << "\nvs\n" << stationary;
  }
}

TEST_F(LinearFeatures, ParameterJacobianMatchesCentralDifferencesInBothForms) {
  for (const Form& form : kForms) {
    ModelHandle model = create(form_params(form));
    const Eigen::Index p = static_cast<Eigen::Index>(model->parameter_info().size());
    for (double dt : {0.02, 0.4, 2.0}) {
      Eigen::MatrixXd exact(3, p);
      ASSERT_TRUE(model->parameter_jacobian(kX, kU, dt, exact)) << form.name;
      const Eigen::MatrixXd numeric = numeric_parameter_jacobian(*model, kX, kU, dt);
      EXPECT_LT(max_abs(exact - numeric), 1e-8 * std::max(1.0, max_abs(numeric))) << form.name << " dt " << dt << "\n"
                                                                                  << exact << "\nvs\n"
                                                                                  << numeric;
    }
  }
  // A diagonal rate near zero takes the series branch of d Gamma / d a.
  const Eigen::VectorXd c = offset_c();
  ModelHandle slow = create(bank_params(Eigen::Vector3d(1e-9, -0.5, 0.3), input_b(), &c));
  Eigen::MatrixXd exact(3, 12);
  ASSERT_TRUE(slow->parameter_jacobian(kX, kU, 0.7, exact));
  EXPECT_LT(max_abs(exact - numeric_parameter_jacobian(*slow, kX, kU, 0.7)), 1e-8);
}

TEST_F(LinearFeatures, FixedKeysAreHeldAndNotOffered) {
  for (const Form& form : kForms) {
    for (const std::vector<std::string>& keys :
         {std::vector<std::string>{"A"}, std::vector<std::string>{"B"}, std::vector<std::string>{"A", "B"}}) {
      sdk::ParameterSet params = form_params(form);
      params.set_text("fixed", keys);
      ModelHandle fixed = create(params);
      ModelHandle free = create(form_params(form));
      // The same step; only the flat parameter vector differs.
      Eigen::VectorXd a(3), b(3);
      ASSERT_TRUE(fixed->predict(kX, kU, 0.4, a) && free->predict(kX, kU, 0.4, b));
      EXPECT_EQ(a, b) << form.name;
      const std::size_t a_count = form.full ? 9 : 3;
      std::size_t expected = free->parameter_info().size();
      for (const std::string& k : keys) expected -= k == "A" ? a_count : 6;
      ASSERT_EQ(fixed->parameter_info().size(), expected) << form.name;
      for (const auto& info : fixed->parameter_info()) {
        for (const std::string& k : keys) EXPECT_NE(info.key, k) << form.name;
      }
      // The exact Jacobian of what is left, against central differences.
      const Eigen::Index p = static_cast<Eigen::Index>(expected);
      if (p == 0) continue;
      Eigen::MatrixXd exact(3, p);
      ASSERT_TRUE(fixed->parameter_jacobian(kX, kU, 0.4, exact)) << form.name;
      const Eigen::MatrixXd numeric = numeric_parameter_jacobian(*fixed, kX, kU, 0.4);
      EXPECT_LT(max_abs(exact - numeric), 1e-8 * std::max(1.0, max_abs(numeric))) << form.name;
    }
  }
  sdk::ParameterSet bad = form_params(kForms[0]);
  bad.set_text("fixed", {"Q"});
  EXPECT_THAT(creation_error(bad), HasSubstr("'Q' is not a key of linear_features (A, B, c)"));
  bad.set_text("fixed", {"c"});
  EXPECT_THAT(creation_error(bad), HasSubstr("names c, but the bank gives no c"));
}

TEST_F(LinearFeatures, LongStepOfAFastStateIsFiniteAndReachesTheSteadyState) {
  Eigen::Matrix3d a;
  a << -50.0, 10.0, 0.0,  //
      0.0, -45.0, 5.0,    //
      2.0, 0.0, -60.0;
  const Eigen::VectorXd c = offset_c();
  for (bool full : {false, true}) {
    const Eigen::MatrixXd a_used = full ? Eigen::MatrixXd(a) : Eigen::MatrixXd(a.diagonal().asDiagonal());
    ModelHandle model = create(bank_params(full ? a_used : Eigen::MatrixXd(a.diagonal()), input_b(), &c));
    const Eigen::VectorXd w = input_b() * kU + c;
    const Eigen::VectorXd steady = a_used.partialPivLu().solve(-w);  // -A^{-1} (B u + c)
    Eigen::VectorXd next(3);
    Eigen::MatrixXd f(3, 3), noise(3, 3), derivative(3, full ? 18 : 12);
    ASSERT_TRUE(model->predict(kX * 100.0, kU, 2.0, next));
    EXPECT_LT(max_abs(next - steady), 1e-14 * max_abs(steady)) << next.transpose() << " vs " << steady.transpose();
    ASSERT_TRUE(model->jacobian(kX, kU, 2.0, f));
    EXPECT_LT(max_abs(f), 1e-30);  // about e^{-90}
    ASSERT_TRUE(model->process_noise(Eigen::Matrix3d::Identity(), kX, kU, 2.0, noise));
    EXPECT_TRUE(noise.allFinite());
    EXPECT_LT(max_abs(noise), 0.02);
    ASSERT_TRUE(model->parameter_jacobian(kX, kU, 2.0, derivative));
    EXPECT_TRUE(derivative.allFinite());
  }
}

TEST_F(LinearFeatures, AngleStatesAreReportedAndWrapped) {
  // theta' = omega, omega' = -2 omega + u: a heading driven by a yaw rate.
  Eigen::Matrix2d a;
  a << 0.0, 1.0, 0.0, -2.0;
  ModelHandle model =
      create(bank_params(a, Eigen::Vector2d(0.0, 2.0), nullptr, {"theta", "omega"}, {"dv"}, {true, false}));
  EXPECT_TRUE(model->is_angle(0));
  EXPECT_FALSE(model->is_angle(1));
  const Eigen::VectorXd u = Eigen::VectorXd::Constant(1, 1.0);
  for (double theta : {0.0, 3.1, -3.14}) {
    EXPECT_MOTION_MODEL_CONFORMS(*model, Eigen::Vector2d(theta, 1.0), u, 0.1);
  }
  Eigen::VectorXd next(2);
  ASSERT_TRUE(model->predict(Eigen::Vector2d(3.1, 1.0), u, 0.1, next));
  EXPECT_LT(next[0], 0.0);  // crossed +pi
  const Eigen::VectorXd unwrapped = rk4(a, Eigen::Vector2d(0.0, 2.0), Eigen::Vector2d(3.1, 1.0), 0.1, 100);
  EXPECT_NEAR(next[0], sdk::wrap_angle(unwrapped[0]), 1e-12);
}

TEST_F(LinearFeatures, ParametersAreNamedSoAFittedBankKeepsItsShape) {
  ModelHandle diagonal = create(form_params(kForms[1]));
  std::vector<std::string> names;
  for (const auto& info : diagonal->parameter_info()) {
    names.push_back(info.name);
    EXPECT_EQ(info.scope, sdk::ParameterScope::kMode);
  }
  EXPECT_EQ(names, (std::vector<std::string>{"A[0]", "A[1]", "A[2]", "B[0,0]", "B[0,1]", "B[1,0]", "B[1,1]", "B[2,0]",
                                             "B[2,1]", "c[0]", "c[1]", "c[2]"}));
  EXPECT_THAT(diagonal->parameter_info()[4].description, HasSubstr("d(omega)/dt per unit of input dv"));
  Eigen::VectorXd values(12);
  diagonal->get_parameters(values);
  EXPECT_EQ(values[1], -20.0);
  EXPECT_EQ(values[5], 1.2);  // B[1,0]
  EXPECT_EQ(values[11], 0.25);

  ModelHandle full = create(form_params(kForms[2]));  // no c: not a parameter
  ASSERT_EQ(full->parameter_info().size(), 9u + 6u);
  EXPECT_EQ(full->parameter_info()[1].name, "A[0,1]");
  EXPECT_EQ(full->parameter_info()[1].key, "A");
  EXPECT_THAT(full->parameter_info()[1].description, HasSubstr("d(omega)/dt per unit of current"));
  EXPECT_EQ(full->parameter_info()[14].name, "B[2,1]");
}

TEST_F(LinearFeatures, RejectsBadParametersAndStepsWithClearMessages) {
  const Eigen::VectorXd c = offset_c();
  EXPECT_THAT(creation_error(bank_params(full_a(), Eigen::MatrixXd(input_b().transpose()), nullptr)),
              HasSubstr("parameter 'B' must be 3x2 (states omega, current, vibration x inputs v, dv), got 2x3"));
  EXPECT_THAT(creation_error(bank_params(Eigen::MatrixXd::Zero(2, 3), input_b(), nullptr)),
              HasSubstr("parameter 'A' must be a 3x3 matrix for a full A, or a list of 3 numbers for a diagonal A "
                        "(states omega, current, vibration), got 2x3"));
  EXPECT_THAT(creation_error(bank_params(full_a(), input_b(), nullptr, kStates, kInputs)), HasSubstr("no error"));
  Eigen::VectorXd short_c = Eigen::Vector2d(1.0, 2.0);
  EXPECT_THAT(
      creation_error(bank_params(full_a(), input_b(), &short_c)),
      HasSubstr("parameter 'c' must be a list of 3 numbers, one per state (omega, current, vibration), got 2x1"));
  Eigen::Vector3d with_nan = diagonal_a();
  with_nan[1] = std::nan("");
  EXPECT_THAT(creation_error(bank_params(with_nan, input_b(), &c)), HasSubstr("parameter 'A[1]' is not finite"));

  sdk::ParameterSet no_bank;
  no_bank.set("A", Eigen::MatrixXd(diagonal_a()));
  no_bank.set("B", Eigen::MatrixXd(input_b()));
  EXPECT_THAT(creation_error(no_bank), HasSubstr("takes its states and inputs from the bank"));

  sdk::ParameterSet text = form_params(kForms[0]);
  text.set_text("A", {"-4"});
  EXPECT_THAT(creation_error(text), HasSubstr("parameter 'A' must be numbers, not text"));

  std::vector<std::string> many_inputs;
  for (int i = 0; i < 17; ++i) many_inputs.push_back("u" + std::to_string(i));
  EXPECT_THAT(creation_error(bank_params(diagonal_a(), Eigen::MatrixXd::Zero(3, 17), nullptr, kStates, many_inputs)),
              HasSubstr("linear_features supports at most 16 inputs, the bank has 17 (u0, u1,"));

  // Steps the model cannot take fail by return value.
  ModelHandle model = create(form_params(kForms[3]));
  Eigen::VectorXd next(3);
  EXPECT_FALSE(model->predict(kX, kU, -0.1, next));
  EXPECT_FALSE(model->predict(kX, kU, std::nan(""), next));
  ModelHandle unstable = create(bank_params(Eigen::Vector3d(800.0, -1.0, -1.0), input_b(), nullptr));
  EXPECT_FALSE(unstable->predict(kX, kU, 1.0, next));  // e^{800} overflows
}

// --- Through the bank loader ---

std::filesystem::path fixture_bank() {
  return std::filesystem::path(SKIDIMM_SOURCE_DIR) / "tests/fixtures/banks/linear_features_vibration.yaml";
}

TEST_F(LinearFeatures, BankFileDefinesTheModelWithItsOwnNames) {
  const Bank bank = Bank::load(fixture_bank(), {SKIDIMM_PLUGIN_DIR});
  ASSERT_EQ(bank.models.size(), 2u);
  for (const ModelHandle& model : bank.models) {
    EXPECT_EQ(model->state_names(), kStates);
    EXPECT_EQ(model->input_names(), kInputs);
    EXPECT_FALSE(model->is_angle(2));
  }
  // grip: diagonal A with c; slip: full A, no c.
  const auto& grip = bank.models[0]->parameter_info();
  ASSERT_EQ(grip.size(), 3u + 6u + 3u);
  EXPECT_EQ(grip[0].name, "A[0]");
  EXPECT_EQ(grip[11].name, "c[2]");
  const auto& slip = bank.models[1]->parameter_info();
  ASSERT_EQ(slip.size(), 9u + 6u);
  EXPECT_EQ(slip[7].name, "A[2,1]");

  // Both predict the exact solution of their equations.
  Eigen::Matrix3d a_slip;
  a_slip << -2.0, 0.0, 0.0, 0.0, -12.0, 0.0, 0.0, 0.6, -1.5;
  Eigen::Matrix<double, 3, 2> b_slip;
  b_slip << 0.0, 0.2, 0.6, 0.9, 0.0, 1.1;
  Eigen::Matrix<double, 3, 2> b_grip;
  b_grip << 0.0, 0.35, 1.2, 0.5, 0.0, 0.7;
  const Eigen::Vector3d a_grip(-4.0, -20.0, -0.8), c_grip(0.0, 0.4, 0.05);
  const double dt = 0.5;  // a 2 Hz filter; current's time constant is 0.05 s
  Eigen::VectorXd next(3);
  ASSERT_TRUE(bank.models[0]->predict(kX, kU, dt, next));
  EXPECT_LT(max_abs(next - rk4(a_grip.asDiagonal(), b_grip * kU + c_grip, kX, dt, 5000)), 1e-12);
  ASSERT_TRUE(bank.models[1]->predict(kX, kU, dt, next));
  EXPECT_LT(max_abs(next - rk4(a_slip, b_slip * kU, kX, dt, 5000)), 1e-12);
}

class LinearFeaturesBankErrors : public ::testing::Test {
 protected:
  // The fixture with mode grip's params replaced by `params`.
  std::string load_error(const std::string& params) {
    std::string text = skidimm_test::read_file(fixture_bank());
    const std::string grip = "      A: [-4.0, -20.0, -0.8]";
    const std::size_t begin = text.find(grip);
    const std::size_t end = text.find("    Q:", begin);
    text.replace(begin, end - begin, params);
    return error_of(text);
  }
  std::string error_of(const std::string& text) {
    const auto file = skidimm_test::write_file(skidimm_test::test_directory() / "bank.yaml", text);
    try {
      Bank::load(file, {SKIDIMM_PLUGIN_DIR});
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "no error";
  }
};

TEST_F(LinearFeaturesBankErrors, NameTheKeyAndTheShapeInTheBanksTerms) {
  EXPECT_THAT(load_error("      A: [-4.0, -20.0, -0.8]\n      B: [[0.0, 0.35], [1.2, 0.5], [0.0, 0.7]]\n"),
              HasSubstr("no error"));
  EXPECT_THAT(load_error("      A: [-4.0, -20.0, -0.8]\n      B: [[0.0, 0.35, 1.2], [0.5, 0.0, 0.7]]\n"),
              AllOf(HasSubstr("bank.yaml:26: modes[0].params.B: mode 'grip' (model linear_features)"),
                    HasSubstr("parameter 'B' must be 3x2 (states omega, current, vibration x inputs v, dv), got 2x3")));
  EXPECT_THAT(load_error("      A: [-4.0, -20.0, -0.8]\n"),
              HasSubstr("missing parameter 'B': expected 3x2 (states omega, current, vibration x inputs v, dv)"));
  EXPECT_THAT(load_error("      A: [-4.0, -20.0]\n      B: [[0.0, 0.35], [1.2, 0.5], [0.0, 0.7]]\n"),
              HasSubstr("parameter 'A' must be a 3x3 matrix for a full A, or a list of 3 numbers for a diagonal A "
                        "(states omega, current, vibration), got 2x1"));
  EXPECT_THAT(load_error("      A: [-4.0, -20.0, -0.8]\n      B: [[0.0, 0.35], [1.2, 0.5], [0.0, 0.7]]\n"
                         "      C: [1, 2, 3]\n"),
              HasSubstr("unknown parameter 'C' (this model takes: A, B, c, fixed)"));
}

TEST_F(LinearFeaturesBankErrors, TooManyStatesAreRejectedWithTheLimit) {
  std::string states, rates, inputs, variances;
  for (int i = 0; i < 13; ++i) {
    states += (i ? ", s" : "s") + std::to_string(i);
    rates += (i ? ", -1" : "-1");
    inputs += (i ? ", [1]" : "[1]");
    variances += (i ? ", 1" : "1");
  }
  const std::string bank = "name: big\nstates: [" + states + "]\ninputs: [u]\nmeasurement:\n  observe: [s0]\n" +
                           "  R: {std: [0.1]}\ntransition: {stay: 0.99}\ninitial:\n  covariance: {diagonal: [" +
                           variances + "]}\nmodes:\n  - name: one\n    model: linear_features\n    params: {A: [" +
                           rates + "], B: [" + inputs + "]}\n    Q: {diagonal: [" + variances + "]}\n";
  EXPECT_THAT(error_of(bank), HasSubstr("linear_features supports at most 12 states, the bank has 13 (s0, s1,"));
}

}  // namespace
}  // namespace skidimm
