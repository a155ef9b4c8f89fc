// Conformance kit: the checks every motion-model plugin must pass.
//
// In a GoogleTest test of your plugin:
//
//   #include "skidimm/sdk/testing/conformance.h"
//   TEST(MyModel, Conforms) {
//     auto model = MyModel::Create(params, &error);
//     EXPECT_MOTION_MODEL_CONFORMS(*model, x, u, dt);
//   }
//
// Checks, at the operating point (x, u, dt) you choose (pick one away from
// singular configurations, with non-zero inputs so every term is exercised):
//  * dimensions and names agree and names are unique and non-empty;
//  * predict(x, u, 0) == x and jacobian(x, u, 0) == I;
//  * predict(x, u, dt) is finite, with angle components in [-pi, pi);
//  * the parameters round-trip through get/set, with unique names, valid
//    bounds and current values inside them;
//  * process_noise(I, x, u, dt) is symmetric positive semidefinite;
//  * the reported Jacobian matches central differences of predict(), and so
//    does the parameter Jacobian if the model provides one.
// The model is left with the parameters it had.
#ifndef SKIDIMM_SDK_TESTING_CONFORMANCE_H_
#define SKIDIMM_SDK_TESTING_CONFORMANCE_H_

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <sstream>
#include <string>

#include "skidimm/sdk/angles.h"
#include "skidimm/sdk/motion_model.h"
#include "skidimm/sdk/numeric_jacobian.h"

namespace skidimm {
namespace sdk {
namespace testing {

struct ConformanceOptions {
  double identity_tolerance = 1e-12;  // predict(x, u, 0) vs x, relative to max(1, |x|)
  double jacobian_tolerance = 1e-6;   // analytic vs numeric, relative to max(1, |J|)
};

inline ::testing::AssertionResult MotionModelConforms(MotionModel& model, const Eigen::VectorXd& x,
                                                      const Eigen::VectorXd& u, double dt,
                                                      const ConformanceOptions& options = {}) {
  std::ostringstream failures;
  const int n = model.state_dim();
  const int p = model.input_dim();
  auto fail = [&failures](const std::string& what) { failures << "\n  - " << what; };

  if (n <= 0) fail("state_dim() must be positive");
  if (p < 0) fail("input_dim() cannot be negative");
  if (static_cast<int>(model.state_names().size()) != n) fail("state_names().size() differs from state_dim()");
  if (static_cast<int>(model.input_names().size()) != p) fail("input_names().size() differs from input_dim()");
  std::set<std::string> names;
  for (const auto& name : model.state_names()) {
    if (name.empty() || !names.insert(name).second) fail("state name '" + name + "' is empty or repeated");
  }
  names.clear();
  for (const auto& name : model.input_names()) {
    if (name.empty() || !names.insert(name).second) fail("input name '" + name + "' is empty or repeated");
  }
  if (x.size() != n || u.size() != p) {
    fail("the test's x or u has the wrong size for this model");
    return ::testing::AssertionFailure() << "motion model does not conform:" << failures.str();
  }

  Eigen::VectorXd next(n);
  if (!model.predict(x, u, 0.0, next)) {
    fail("predict(x, u, 0) failed");
  } else {
    for (int i = 0; i < n; ++i) {
      double difference = next[i] - x[i];
      if (model.is_angle(i)) difference = wrap_angle(difference);
      if (std::abs(difference) > options.identity_tolerance * std::max(1.0, std::abs(x[i]))) {
        std::ostringstream out;
        out << "predict(x, u, 0) changed component " << i << " from " << x[i] << " to " << next[i];
        fail(out.str());
      }
    }
  }
  Eigen::MatrixXd jacobian(n, n);
  if (!model.jacobian(x, u, 0.0, jacobian)) {
    fail("jacobian(x, u, 0) failed");
  } else if (!jacobian.isApprox(Eigen::MatrixXd::Identity(n, n), 1e-9) &&
             (jacobian - Eigen::MatrixXd::Identity(n, n)).norm() > 1e-9) {
    fail("jacobian(x, u, 0) is not the identity");
  }

  if (!model.predict(x, u, dt, next) || !next.allFinite()) {
    fail("predict(x, u, dt) failed or is not finite");
  } else {
    for (int i = 0; i < n; ++i) {
      if (model.is_angle(i) && !(next[i] >= -kPi && next[i] < kPi)) fail("predict() left an angle outside [-pi, pi)");
    }
  }

  // Parameters.
  const auto& info = model.parameter_info();
  const Eigen::Index num_parameters = static_cast<Eigen::Index>(info.size());
  names.clear();
  for (const auto& entry : info) {
    if (entry.name.empty() || !names.insert(entry.name).second)
      fail("parameter name '" + entry.name + "' is empty or repeated");
    if (!(entry.lower_bound <= entry.upper_bound)) fail("parameter '" + entry.name + "' has lower bound > upper bound");
  }
  Eigen::VectorXd values(num_parameters);
  model.get_parameters(values);
  for (Eigen::Index i = 0; i < num_parameters; ++i) {
    if (!(values[i] >= info[i].lower_bound && values[i] <= info[i].upper_bound)) {
      fail("parameter '" + info[i].name + "' is outside its own bounds");
    }
  }
  std::string error;
  if (!model.set_parameters(values, &error)) {
    fail("set_parameters(get_parameters()) was rejected: " + error);
  } else {
    Eigen::VectorXd again(num_parameters);
    model.get_parameters(again);
    if (again != values) fail("parameters do not round-trip through set/get");
  }
  if (num_parameters > 0) {
    Eigen::VectorXd wrong_size(num_parameters + 1);
    wrong_size.setZero();
    if (model.set_parameters(wrong_size, &error)) fail("set_parameters() accepted a vector of the wrong size");
    Eigen::VectorXd restored(num_parameters);
    model.get_parameters(restored);
    if (restored != values) fail("a rejected set_parameters() changed the model");
    model.set_parameters(values, &error);
  }

  // Process noise.
  Eigen::MatrixXd noise(n, n);
  if (!model.process_noise(Eigen::MatrixXd::Identity(n, n), x, u, dt, noise)) {
    fail("process_noise() failed");
  } else if (!noise.allFinite() || !noise.isApprox(noise.transpose(), 1e-12)) {
    fail("process_noise() is not finite and symmetric");
  } else if (Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(noise).eigenvalues().minCoeff() <
             -1e-12 * std::max(1.0, noise.norm())) {
    fail("process_noise() is not positive semidefinite");
  }

  // Jacobian against central differences of predict().
  if (!model.jacobian(x, u, dt, jacobian)) {
    fail("jacobian(x, u, dt) failed");
  } else {
    Eigen::MatrixXd numeric(n, n);
    auto step = [&](const Eigen::VectorXd& xp, Eigen::VectorXd& out) { return model.predict(xp, u, dt, out); };
    auto angle = [&model](int i) { return model.is_angle(i); };
    if (!numeric_state_jacobian(step, angle, x, numeric)) {
      fail("numeric differentiation of predict() failed");
    } else {
      const double scale = std::max(1.0, numeric.cwiseAbs().maxCoeff());
      const double error_norm = (jacobian - numeric).cwiseAbs().maxCoeff();
      if (error_norm > options.jacobian_tolerance * scale) {
        std::ostringstream out;
        out << "jacobian() differs from central differences by " << error_norm << "\n    reported:\n"
            << jacobian << "\n    numeric:\n"
            << numeric;
        fail(out.str());
      }
    }
  }

  // Parameter Jacobian, if provided, against differences over set_parameters().
  Eigen::MatrixXd parameter_jacobian(n, num_parameters);
  if (num_parameters > 0 && model.parameter_jacobian(x, u, dt, parameter_jacobian)) {
    Eigen::MatrixXd numeric(n, num_parameters);
    Eigen::VectorXd plus(n), minus(n), perturbed = values;
    bool evaluated = true;
    for (Eigen::Index j = 0; j < num_parameters && evaluated; ++j) {
      const double h = std::cbrt(std::numeric_limits<double>::epsilon()) * std::max(1.0, std::abs(values[j]));
      perturbed[j] = values[j] + h;
      evaluated = model.set_parameters(perturbed, nullptr) && model.predict(x, u, dt, plus);
      perturbed[j] = values[j] - h;
      evaluated = evaluated && model.set_parameters(perturbed, nullptr) && model.predict(x, u, dt, minus);
      perturbed[j] = values[j];
      for (int i = 0; i < n; ++i) {
        double difference = plus[i] - minus[i];
        if (model.is_angle(i)) difference = wrap_angle(difference);
        numeric(i, j) = difference / (2.0 * h);
      }
    }
    model.set_parameters(values, nullptr);
    if (!evaluated) {
      fail("could not perturb the parameters to check parameter_jacobian() (a parameter on its bound?)");
    } else {
      const double scale = std::max(1.0, numeric.cwiseAbs().maxCoeff());
      const double error_norm = (parameter_jacobian - numeric).cwiseAbs().maxCoeff();
      if (error_norm > options.jacobian_tolerance * scale) {
        std::ostringstream out;
        out << "parameter_jacobian() differs from central differences by " << error_norm << "\n    reported:\n"
            << parameter_jacobian << "\n    numeric:\n"
            << numeric;
        fail(out.str());
      }
    }
  }

  if (failures.str().empty()) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "motion model does not conform:" << failures.str();
}

}  // namespace testing
}  // namespace sdk
}  // namespace skidimm

#define EXPECT_MOTION_MODEL_CONFORMS(model, x, u, dt) \
  EXPECT_TRUE(::skidimm::sdk::testing::MotionModelConforms((model), (x), (u), (dt)))

#endif  // SKIDIMM_SDK_TESTING_CONFORMANCE_H_
