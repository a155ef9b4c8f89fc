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
// or, better, over the region where the model will be used:
//
//   OperatingRegion region;
//   region.x_min = ...; region.x_max = ...; region.u_min = ...; region.u_max = ...;
//   EXPECT_MOTION_MODEL_CONFORMS_OVER(*model, region);
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
//    does the parameter Jacobian if the model provides one;
//  * outputs, if the model has any, are uniquely named and finite, and their
//    parameter Jacobian, if provided, matches central differences.
// The model is left with the parameters it had.
#ifndef SKIDIMM_SDK_TESTING_CONFORMANCE_H_
#define SKIDIMM_SDK_TESTING_CONFORMANCE_H_

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

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

namespace internal {

inline std::string vector_text(const Eigen::VectorXd& v) {
  std::ostringstream out;
  out.precision(6);
  out << "[";
  for (Eigen::Index i = 0; i < v.size(); ++i) out << (i ? ", " : "") << v[i];
  out << "]";
  return out.str();
}

// Central differences over set_parameters() of evaluate(out), a function of
// `rows` values (predict() or outputs()), into *numeric (rows x parameters);
// rows where is_angle(i) are differenced modulo 2 pi. The model gets
// `values` back. False if a perturbed evaluation fails.
template <typename Evaluate, typename IsAngle>
bool numeric_parameter_jacobian(MotionModel& model, const Eigen::VectorXd& values, Eigen::Index rows,
                                const Evaluate& evaluate, const IsAngle& is_angle, Eigen::MatrixXd* numeric) {
  Eigen::VectorXd plus(rows), minus(rows), perturbed = values;
  bool evaluated = true;
  for (Eigen::Index j = 0; j < values.size() && evaluated; ++j) {
    const double h = std::cbrt(std::numeric_limits<double>::epsilon()) * std::max(1.0, std::abs(values[j]));
    perturbed[j] = values[j] + h;
    evaluated = model.set_parameters(perturbed, nullptr) && evaluate(plus);
    perturbed[j] = values[j] - h;
    evaluated = evaluated && model.set_parameters(perturbed, nullptr) && evaluate(minus);
    perturbed[j] = values[j];
    for (Eigen::Index i = 0; i < rows; ++i) {
      double difference = plus[i] - minus[i];
      if (is_angle(i)) difference = wrap_angle(difference);
      (*numeric)(i, j) = difference / (2.0 * h);
    }
  }
  model.set_parameters(values, nullptr);
  return evaluated;
}

// The entries of `analytic` that differ from `numeric` by more than
// `tolerance`, worst first (at most five), each named by row and column.
inline std::string differing_entries(const Eigen::MatrixXd& analytic, const Eigen::MatrixXd& numeric, double tolerance,
                                     const std::vector<std::string>& row_names,
                                     const std::vector<std::string>& column_names) {
  std::vector<std::pair<double, std::pair<int, int>>> entries;
  for (int r = 0; r < analytic.rows(); ++r) {
    for (int c = 0; c < analytic.cols(); ++c) {
      const double difference = std::abs(analytic(r, c) - numeric(r, c));
      if (!(difference <= tolerance)) entries.push_back({std::isnan(difference) ? HUGE_VAL : difference, {r, c}});
    }
  }
  std::sort(entries.begin(), entries.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  std::ostringstream out;
  out.precision(10);
  for (std::size_t k = 0; k < entries.size() && k < 5; ++k) {
    const int r = entries[k].second.first, c = entries[k].second.second;
    out << "\n    entry (row " << r << " '" << (r < static_cast<int>(row_names.size()) ? row_names[r] : "?")
        << "', column " << c << " '" << (c < static_cast<int>(column_names.size()) ? column_names[c] : "?")
        << "'): analytic " << analytic(r, c) << ", numeric " << numeric(r, c);
  }
  if (entries.size() > 5) out << "\n    and " << entries.size() - 5 << " more entries";
  return out.str();
}

}  // namespace internal

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

  if (!model.predict(x, u, dt, next)) {
    const char* reason = model.failure_reason();
    fail("predict(x, u, dt) failed" + std::string(reason != nullptr && reason[0] != '\0' ? ": " : "") +
         (reason != nullptr ? reason : ""));
  } else if (!next.allFinite()) {
    fail("predict(x, u, dt) is not finite: " + internal::vector_text(next));
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
        out << "jacobian() differs from central differences by " << error_norm << " at x = "
            << internal::vector_text(x) << ", u = " << internal::vector_text(u) << ", dt = " << dt
            << internal::differing_entries(jacobian, numeric, options.jacobian_tolerance * scale,
                                           model.state_names(), model.state_names())
            << "\n    reported:\n"
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
    const bool evaluated = internal::numeric_parameter_jacobian(
        model, values, n, [&](Eigen::VectorXd& out) { return model.predict(x, u, dt, out); },
        [&](Eigen::Index i) { return model.is_angle(static_cast<int>(i)); }, &numeric);
    if (!evaluated) {
      fail("could not perturb the parameters to check parameter_jacobian() (a parameter on its bound?)");
    } else {
      const double scale = std::max(1.0, numeric.cwiseAbs().maxCoeff());
      const double error_norm = (parameter_jacobian - numeric).cwiseAbs().maxCoeff();
      if (error_norm > options.jacobian_tolerance * scale) {
        std::ostringstream out;
        std::vector<std::string> parameter_names;
        for (const auto& entry : info) parameter_names.push_back(entry.name);
        out << "parameter_jacobian() differs from central differences by " << error_norm << " at x = "
            << internal::vector_text(x) << ", u = " << internal::vector_text(u) << ", dt = " << dt
            << internal::differing_entries(parameter_jacobian, numeric, options.jacobian_tolerance * scale,
                                           model.state_names(), parameter_names)
            << "\n    reported:\n"
            << parameter_jacobian << "\n    numeric:\n"
            << numeric;
        fail(out.str());
      }
    }
  }

  // Outputs, if any: unique names, finite values, and their parameter
  // Jacobian, if provided, against differences over set_parameters().
  const std::vector<std::string>& outputs = model.output_names();
  const Eigen::Index num_outputs = static_cast<Eigen::Index>(outputs.size());
  for (std::size_t i = 0; i < outputs.size(); ++i) {
    if (outputs[i].empty()) fail("output_names()[" + std::to_string(i) + "] is empty");
    for (std::size_t j = 0; j < i; ++j) {
      if (outputs[i] == outputs[j]) fail("output name '" + outputs[i] + "' appears twice");
    }
  }
  Eigen::VectorXd y(num_outputs);
  if (num_outputs > 0 && (!model.outputs(u, y) || !y.allFinite())) {
    fail("outputs(u) failed or is not finite at u = " + internal::vector_text(u));
  }
  Eigen::MatrixXd output_jacobian(num_outputs, num_parameters);
  if (num_outputs > 0 && num_parameters > 0 && model.output_parameter_jacobian(u, output_jacobian)) {
    Eigen::MatrixXd numeric(num_outputs, num_parameters);
    const bool evaluated = internal::numeric_parameter_jacobian(
        model, values, num_outputs, [&](Eigen::VectorXd& out) { return model.outputs(u, out); },
        [](Eigen::Index) { return false; }, &numeric);
    const double scale = std::max(1.0, numeric.cwiseAbs().maxCoeff());
    if (!evaluated) {
      fail("could not perturb the parameters to check output_parameter_jacobian() (a parameter on its bound?)");
    } else if ((output_jacobian - numeric).cwiseAbs().maxCoeff() > options.jacobian_tolerance * scale) {
      std::ostringstream out;
      out << "output_parameter_jacobian() differs from central differences at u = " << internal::vector_text(u)
          << "\n    reported:\n"
          << output_jacobian << "\n    numeric:\n"
          << numeric;
      fail(out.str());
    }
  }

  if (failures.str().empty()) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "motion model does not conform:" << failures.str();
}

// Where a model is used: each state and input between its bounds, dt between
// its bounds. A single operating point misses what only happens elsewhere (a
// NaN or a throw above some speed, a Jacobian entry wrong only when a state
// is negative); MotionModelConformsOver checks the region at many points.
struct OperatingRegion {
  Eigen::VectorXd x_min, x_max;
  Eigen::VectorXd u_min, u_max;
  double dt_min = 0.01;
  double dt_max = 0.1;
  int samples = 64;          // points drawn uniformly, besides the centre and the two extreme corners
  std::uint64_t seed = 13;   // the same points on every run and platform
};

// MotionModelConforms at the region's centre, its all-minimum and
// all-maximum corners and `samples` uniformly drawn points. The message says
// how many points failed and, for the first three, the point and what failed
// (a wrong Jacobian entry is named by row and column with both values).
inline ::testing::AssertionResult MotionModelConformsOver(MotionModel& model, const OperatingRegion& region,
                                                          const ConformanceOptions& options = {}) {
  const int n = model.state_dim(), p = model.input_dim();
  if (region.x_min.size() != n || region.x_max.size() != n || region.u_min.size() != p ||
      region.u_max.size() != p) {
    return ::testing::AssertionFailure() << "the operating region's bounds have the wrong sizes for this model ("
                                         << n << " states, " << p << " inputs)";
  }
  std::uint64_t state = region.seed;
  auto uniform = [&state](double lo, double hi) {  // splitmix64: portable, unlike std:: distributions
    state += 0x9E3779B97F4A7C15ull;
    std::uint64_t z = state;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    z ^= z >> 31;
    return lo + (hi - lo) * (static_cast<double>(z >> 11) * 0x1.0p-53);
  };
  const int points = 3 + std::max(0, region.samples);
  int failed = 0;
  std::ostringstream report;
  Eigen::VectorXd x(n), u(p);
  for (int k = 0; k < points; ++k) {
    double dt;
    if (k < 3) {
      const double w = k == 0 ? 0.5 : (k == 1 ? 0.0 : 1.0);  // centre, then the two extreme corners
      x = region.x_min + w * (region.x_max - region.x_min);
      u = region.u_min + w * (region.u_max - region.u_min);
      dt = region.dt_min + w * (region.dt_max - region.dt_min);
    } else {
      for (int i = 0; i < n; ++i) x[i] = uniform(region.x_min[i], region.x_max[i]);
      for (int i = 0; i < p; ++i) u[i] = uniform(region.u_min[i], region.u_max[i]);
      dt = uniform(region.dt_min, region.dt_max);
    }
    const ::testing::AssertionResult result = MotionModelConforms(model, x, u, dt, options);
    if (result) continue;
    if (++failed <= 3) {
      report << "\n at operating point " << k << ": x = " << internal::vector_text(x)
             << ", u = " << internal::vector_text(u) << ", dt = " << dt << ": " << result.message();
    }
  }
  if (failed == 0) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "motion model does not conform at " << failed << " of " << points
                                       << " operating points" << report.str();
}

}  // namespace testing
}  // namespace sdk
}  // namespace skidimm

#define EXPECT_MOTION_MODEL_CONFORMS(model, x, u, dt) \
  EXPECT_TRUE(::skidimm::sdk::testing::MotionModelConforms((model), (x), (u), (dt)))

// EXPECT_MOTION_MODEL_CONFORMS_OVER(model, region): at many points of an OperatingRegion.
#define EXPECT_MOTION_MODEL_CONFORMS_OVER(model, region) \
  EXPECT_TRUE(::skidimm::sdk::testing::MotionModelConformsOver((model), (region)))

#endif  // SKIDIMM_SDK_TESTING_CONFORMANCE_H_
