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

  // The dynamic-size virtuals the engine calls, once for all sized models.
  // Vectors behind an Eigen::Ref<VectorXd> are contiguous, so the arguments
  // reach the fixed-size forms through fixed-size maps: an unrolled copy of
  // the n + m doubles their signatures take by value, no dynamic-size
  // evaluation, and the results go straight into the caller's storage.
  bool predict(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
               Eigen::Ref<Eigen::VectorXd> x_next) const noexcept final {
    const State x_fixed = Eigen::Map<const State>(x.data());
    const Input u_fixed = input(u);
    State next;
    if (!predict_fixed(x_fixed, u_fixed, dt, &next)) return false;
    Eigen::Map<State>(x_next.data()) = next;
    return true;
  }

  bool jacobian(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
                Eigen::Ref<Eigen::MatrixXd> jacobian) const noexcept final {
    const State x_fixed = Eigen::Map<const State>(x.data());
    const Input u_fixed = input(u);
    Jacobian fixed;
    if (has_analytic_jacobian()) {
      if (!jacobian_fixed(x_fixed, u_fixed, dt, &fixed)) return false;
    } else {
      // Fixed-size central differences: no heap allocation in the hot path.
      auto step = [&](const State& xp, State& out) { return predict_fixed(xp, u_fixed, dt, &out); };
      auto angle = [this](int i) { return is_angle(i); };
      if (!numeric_state_jacobian_fixed(step, angle, x_fixed, &fixed)) return false;
    }
    if (kStateDim > 1 && jacobian.outerStride() == kStateDim) {
      Eigen::Map<Jacobian>(jacobian.data()) = fixed;
    } else {
      // Element-wise: for 1x1 models GCC 12 misreads a packet copy as out of bounds.
      for (int i = 0; i < kStateDim; ++i) {
        for (int j = 0; j < kStateDim; ++j) jacobian(i, j) = fixed(i, j);
      }
    }
    return true;
  }

 private:
  static Input input(const Eigen::Ref<const Eigen::VectorXd>& u) {
    if constexpr (kInputDim == 0) {
      return Input();
    } else {
      return Eigen::Map<const Input>(u.data());
    }
  }
};

}  // namespace sdk
}  // namespace skidimm

#endif  // SKIDIMM_SDK_SIZED_MOTION_MODEL_H_
