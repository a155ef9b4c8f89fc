// SizedMotionModel: a MotionModel whose dimensions are known at compile time.
//
// In the spirit of Ceres' SizedCostFunction: the dimensions become template
// arguments, checked by static_assert, and the derived class implements
// fixed-size versions of predict()/jacobian() on Eigen::Matrix types, which
// keeps plugin hot paths free of heap allocation. The dynamic-size virtuals
// the engine calls are implemented here once.
#ifndef SKIDIMM_SDK_SIZED_MOTION_MODEL_H_
#define SKIDIMM_SDK_SIZED_MOTION_MODEL_H_

#include <Eigen/Core>

#include "skidimm/sdk/motion_model.h"

namespace skidimm {
namespace sdk {

template <int kStateDim, int kInputDim>
class SizedMotionModel : public MotionModel {
 public:
  static_assert(kStateDim > 0, "a motion model needs at least one state component");
  static_assert(kInputDim >= 0, "the input dimension cannot be negative");

  static constexpr int kNumStates = kStateDim;
  static constexpr int kNumInputs = kInputDim;
  using State = Eigen::Matrix<double, kStateDim, 1>;
  using Input = Eigen::Matrix<double, kInputDim, 1>;
  using Jacobian = Eigen::Matrix<double, kStateDim, kStateDim>;

  int state_dim() const noexcept final { return kStateDim; }
  int input_dim() const noexcept final { return kInputDim; }

  // Fixed-size forms the derived class implements.
  virtual bool predict_fixed(const State& x, const Input& u, double dt, State* x_next) const noexcept = 0;
  // Analytic Jacobian, if the model has one. Returning false from
  // has_analytic_jacobian() (the default) makes jacobian() numeric.
  virtual bool jacobian_fixed(const State& /*x*/, const Input& /*u*/, double /*dt*/,
                              Jacobian* /*jacobian*/) const noexcept {
    return false;
  }

  bool predict(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
               Eigen::Ref<Eigen::VectorXd> x_next) const noexcept final {
    State next;
    if (!predict_fixed(State(x), Input(u), dt, &next)) return false;
    x_next = next;
    return true;
  }

  bool jacobian(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
                Eigen::Ref<Eigen::MatrixXd> jacobian) const noexcept final {
    const State x_fixed(x);
    const Input u_fixed(u);
    Jacobian fixed;
    if (has_analytic_jacobian()) {
      if (!jacobian_fixed(x_fixed, u_fixed, dt, &fixed)) return false;
    } else {
      // Fixed-size central differences: no heap allocation in the hot path.
      auto step = [&](const State& xp, State& out) { return predict_fixed(xp, u_fixed, dt, &out); };
      auto angle = [this](int i) { return is_angle(i); };
      if (!numeric_state_jacobian_fixed(step, angle, x_fixed, &fixed)) return false;
    }
    // Element-wise: for 1x1 models GCC 12 misreads a packet copy as out of bounds.
    for (int i = 0; i < kStateDim; ++i) {
      for (int j = 0; j < kStateDim; ++j) jacobian(i, j) = fixed(i, j);
    }
    return true;
  }
};

}  // namespace sdk
}  // namespace skidimm

#endif  // SKIDIMM_SDK_SIZED_MOTION_MODEL_H_
