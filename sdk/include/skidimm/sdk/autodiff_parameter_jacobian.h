// Exact parameter Jacobians by automatic differentiation (Ceres jets).
//
// A model whose equations are a templated function, say
//
//   template <typename T>
//   void my_predict(const T* x, const T* u, const T* parameters, const T& dt, T* x_next);
//
// implements MotionModel::parameter_jacobian() in one line:
//
//   return sdk::autodiff_parameter_jacobian<kStates, kInputs, kParameters>(
//       [](const auto* x, const auto* u, const auto* p, const auto& dt, auto* out) { my_predict(x, u, p, dt, out); },
//       x, u, parameters, dt, jacobian);
//
// and `skidimm fit` then uses exact derivatives for it. This header needs
// Ceres' headers (ceres/jet.h, header only: nothing to link); the rest of the
// SDK does not.
#ifndef SKIDIMM_SDK_AUTODIFF_PARAMETER_JACOBIAN_H_
#define SKIDIMM_SDK_AUTODIFF_PARAMETER_JACOBIAN_H_

#include <ceres/jet.h>

#include <Eigen/Core>
#include <cmath>

namespace skidimm {
namespace sdk {

template <int kStateDim, int kInputDim, int kNumParameters, typename Predict>
bool autodiff_parameter_jacobian(const Predict& predict, const Eigen::Ref<const Eigen::VectorXd>& x,
                                 const Eigen::Ref<const Eigen::VectorXd>& u, const double* parameters, double dt,
                                 Eigen::Ref<Eigen::MatrixXd> jacobian) noexcept {
  using Jet = ceres::Jet<double, kNumParameters>;
  Jet x_jet[kStateDim];
  Jet u_jet[kInputDim > 0 ? kInputDim : 1];
  Jet p_jet[kNumParameters];
  Jet out[kStateDim];
  for (int i = 0; i < kStateDim; ++i) x_jet[i] = Jet(x[i]);
  for (int i = 0; i < kInputDim; ++i) u_jet[i] = Jet(u[i]);
  for (int i = 0; i < kNumParameters; ++i) p_jet[i] = Jet(parameters[i], i);  // seed d p_i / d p_i = 1
  predict(x_jet, u_jet, p_jet, Jet(dt), out);
  for (int r = 0; r < kStateDim; ++r) {
    for (int c = 0; c < kNumParameters; ++c) {
      jacobian(r, c) = out[r].v[c];
      if (!std::isfinite(jacobian(r, c))) return false;
    }
  }
  return true;
}

// The same for MotionModel::output_parameter_jacobian(): outputs a
// templated function
//
//   template <typename T>
//   void my_outputs(const T* u, const T* parameters, T* y);
//
// of the input and the parameters.
template <int kInputDim, int kNumOutputs, int kNumParameters, typename Outputs>
bool autodiff_output_parameter_jacobian(const Outputs& outputs, const Eigen::Ref<const Eigen::VectorXd>& u,
                                        const double* parameters, Eigen::Ref<Eigen::MatrixXd> jacobian) noexcept {
  using Jet = ceres::Jet<double, kNumParameters>;
  Jet u_jet[kInputDim > 0 ? kInputDim : 1];
  Jet p_jet[kNumParameters];
  Jet out[kNumOutputs];
  for (int i = 0; i < kInputDim; ++i) u_jet[i] = Jet(u[i]);
  for (int i = 0; i < kNumParameters; ++i) p_jet[i] = Jet(parameters[i], i);
  outputs(u_jet, p_jet, out);
  for (int r = 0; r < kNumOutputs; ++r) {
    for (int c = 0; c < kNumParameters; ++c) {
      jacobian(r, c) = out[r].v[c];
      if (!std::isfinite(jacobian(r, c))) return false;
    }
  }
  return true;
}

}  // namespace sdk
}  // namespace skidimm

#endif  // SKIDIMM_SDK_AUTODIFF_PARAMETER_JACOBIAN_H_
