// Conformance kit: the checks every motion model must pass, as GoogleTest
// assertions (the checks themselves: model_checks.h).
//
// In a GoogleTest test of your plugin, on the built file loaded as skidimm
// loads it (load_plugin_model.h), over the region where the model is used:
//
//   #include "skidimm/sdk/testing/conformance.h"
//   TEST(MyModel, ConformsOverItsOperatingRegion) {
//     auto model = skidimm::sdk::testing::load_plugin_model(MY_PLUGIN_FILE, params);
//     skidimm::sdk::testing::OperatingRegion region;
//     region.x_min = ...; region.x_max = ...; region.u_min = ...; region.u_max = ...;
//     EXPECT_MOTION_MODEL_CONFORMS_OVER(*model, region);
//   }
//
// or at one operating point (pick one away from singular configurations,
// with non-zero inputs so every term is exercised):
//
//   EXPECT_MOTION_MODEL_CONFORMS(*model, x, u, dt);
//
// Given a function model in-process (`auto model = FunctionModel<MySpec>::Create(...)`),
// the same assertions also compare each derivative the spec writes by hand
// (function_model.h) with the one the SDK would generate by jets, entry by
// entry, to 1e-9 of its scale: both are exact, so any difference is a
// mistake, and one central differences (to 1e-6) can miss. (A spec whose
// shapes come from the bank has no jets; central differences check it.)
#ifndef SKIDIMM_SDK_TESTING_CONFORMANCE_H_
#define SKIDIMM_SDK_TESTING_CONFORMANCE_H_

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <algorithm>
#include <sstream>
#include <string>
#include <type_traits>
#include <vector>

#include "skidimm/sdk/bank_layout.h"
#include "skidimm/sdk/motion_model.h"
#include "skidimm/sdk/testing/model_checks.h"

namespace skidimm {
namespace sdk {
namespace testing {

// Relative tolerance of a hand-written derivative against the automatic one.
inline constexpr double kHandWrittenTolerance = 1e-9;

namespace internal {

inline ::testing::AssertionResult as_assertion(const std::vector<std::string>& failures) {
  if (failures.empty()) return ::testing::AssertionSuccess();
  std::ostringstream out;
  out << "motion model does not conform:";
  for (const std::string& failure : failures) out << "\n  - " << failure;
  return ::testing::AssertionFailure() << out.str();
}

// The spec's hand-written derivatives against the automatic ones (jets), for
// a spec with compile-time shapes.
template <typename Spec>
std::vector<std::string> hand_written_derivative_failures(FunctionModel<Spec>& model, const Eigen::VectorXd& x,
                                                          const Eigen::VectorXd& u, double dt) {
  if constexpr (std::is_same_v<::skidimm::sdk::internal::ShapesOf<Spec>, ::skidimm::sdk::internal::BankShapes>) {
    // No jets for shapes known only at load time: central differences
    // (motion_model_failures) are what checks its derivatives.
    return {};
  } else {
    using Model = FunctionModel<Spec>;
    std::vector<std::string> failures;
    if (x.size() != Model::kStates || u.size() != Model::kInputs) return failures;
    const typename Model::State x_fixed = x;
    typename Model::Input u_fixed;
    for (int i = 0; i < Model::kInputs; ++i) u_fixed[i] = u[i];
    std::vector<std::string> parameter_names;
    for (const auto& entry : model.parameter_info()) parameter_names.push_back(entry.name);
    const std::string point = point_text(x, u, dt);
    auto compare = [&](const std::string& what, const Eigen::MatrixXd& hand, const Eigen::MatrixXd& automatic,
                       const std::vector<std::string>& rows, const std::vector<std::string>& columns) {
      const double scale = std::max(1.0, automatic.cwiseAbs().maxCoeff());
      const double error = (hand - automatic).cwiseAbs().maxCoeff();
      if (error <= kHandWrittenTolerance * scale) return;
      std::ostringstream out;
      out << "the hand-written " << what << " differs from the automatic one by " << error << " at " << point
          << differing_entries(hand, automatic, kHandWrittenTolerance * scale, rows, columns);
      failures.push_back(out.str());
    };
    const std::vector<std::string>& states = model.state_names();
    if constexpr (Model::kHandWrittenJacobian) {
      typename Model::Jacobian automatic;
      model.automatic_jacobian(x_fixed, u_fixed, dt, &automatic);
      Eigen::MatrixXd hand(Model::kStates, Model::kStates);
      if (!model.jacobian(x, u, dt, hand)) {
        failures.push_back(failed(model, "jacobian(x, u, dt)"));
      } else {
        compare("jacobian()", hand, automatic, states, states);
      }
    }
    if constexpr (Model::kHandWrittenParameterJacobian && Model::kNumParameters > 0) {
      Eigen::MatrixXd automatic(Model::kStates, Model::kNumParameters), hand(Model::kStates, Model::kNumParameters);
      model.automatic_parameter_jacobian(x_fixed, u_fixed, dt, &automatic);
      if (!model.parameter_jacobian(x, u, dt, hand)) {
        failures.push_back(failed(model, "parameter_jacobian(x, u, dt)"));
      } else {
        compare("parameter_jacobian()", hand, automatic, states, parameter_names);
      }
    }
    if constexpr (Model::kHandWrittenOutputParameterJacobian && Model::kOutputs > 0 && Model::kNumParameters > 0) {
      Eigen::MatrixXd automatic(Model::kOutputs, Model::kNumParameters), hand(Model::kOutputs, Model::kNumParameters);
      model.automatic_output_parameter_jacobian(u_fixed, &automatic);
      if (!model.output_parameter_jacobian(u, hand)) {
        failures.push_back(failed(model, "output_parameter_jacobian(u)"));
      } else {
        compare("output_parameter_jacobian()", hand, automatic, model.output_names(), parameter_names);
      }
    }
    return failures;
  }
}

template <typename Model, typename Check>
::testing::AssertionResult conforms_over(Model& model, const OperatingRegion& region, const Check& check) {
  const int n = model.state_dim(), p = model.input_dim();
  if (region.x_min.size() != n || region.x_max.size() != n || region.u_min.size() != p || region.u_max.size() != p) {
    return ::testing::AssertionFailure() << "the operating region's bounds have the wrong sizes for this model (" << n
                                         << " states, " << p << " inputs)";
  }
  const std::vector<OperatingPoint> points = operating_points(region);
  int failed_points = 0;
  std::ostringstream report;
  for (std::size_t k = 0; k < points.size(); ++k) {
    const OperatingPoint& point = points[k];
    const ::testing::AssertionResult result = check(point);
    if (result) continue;
    if (++failed_points <= 3) {
      report << "\n at operating point " << k << ": " << point_text(point.x, point.u, point.dt) << ": "
             << result.message();
    }
  }
  if (failed_points == 0) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "motion model does not conform at " << failed_points << " of "
                                       << points.size() << " operating points" << report.str();
}

}  // namespace internal

inline ::testing::AssertionResult MotionModelConforms(MotionModel& model, const Eigen::VectorXd& x,
                                                      const Eigen::VectorXd& u, double dt,
                                                      const ConformanceOptions& options = {}) {
  return internal::as_assertion(motion_model_failures(model, x, u, dt, options));
}

// A function model in-process: the same checks, and its hand-written
// derivatives against the automatic ones.
template <typename Spec>
::testing::AssertionResult MotionModelConforms(FunctionModel<Spec>& model, const Eigen::VectorXd& x,
                                               const Eigen::VectorXd& u, double dt,
                                               const ConformanceOptions& options = {}) {
  std::vector<std::string> failures = motion_model_failures(model, x, u, dt, options);
  for (std::string& failure : internal::hand_written_derivative_failures(model, x, u, dt)) {
    failures.push_back(std::move(failure));
  }
  return internal::as_assertion(failures);
}

// MotionModelConforms at the region's centre, its all-minimum and
// all-maximum corners and `samples` uniformly drawn points. The message says
// how many points failed and, for the first three, the point and what failed
// (a wrong Jacobian entry is named by row and column with both values).
template <typename Model>
::testing::AssertionResult MotionModelConformsOver(Model& model, const OperatingRegion& region,
                                                   const ConformanceOptions& options = {}) {
  return internal::conforms_over(model, region, [&](const OperatingPoint& point) {
    return MotionModelConforms(model, point.x, point.u, point.dt, options);
  });
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
