// SizedMotionModel: a MotionModel whose dimensions are known at compile time.
//
// In the spirit of Ceres' SizedCostFunction: the dimensions become template
// arguments, checked by static_assert, and the derived class implements
// fixed-size versions of predict()/jacobian() on Eigen::Matrix types, which
// keeps plugin hot paths free of heap allocation. The dynamic-size virtuals
// the engine calls are implemented here once.
//
// The fixed-size forms are not noexcept: an exception thrown by model code
// (an `.at()` out of range, a std::bad_alloc) is caught here, at the plugin
// boundary, and becomes a false return with the exception's text as the
// failure reason (failure.h). The engine then rejects that mode for the step
// and names the mode, the plugin and the reason; skidimm never terminates.
// (Declaring an override noexcept would forfeit this: a throw inside it calls
// std::terminate before it reaches the catch.)
#ifndef SKIDIMM_SDK_SIZED_MOTION_MODEL_H_
#define SKIDIMM_SDK_SIZED_MOTION_MODEL_H_

#include <Eigen/Core>
#include <exception>

#include "skidimm/sdk/failure.h"
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
  using Covariance = Eigen::Matrix<double, kStateDim, kStateDim>;

  int state_dim() const noexcept final { return kStateDim; }
  int input_dim() const noexcept final { return kInputDim; }

  // Fixed-size forms the derived class implements. They may throw (see
  // above) or return false after report_failure("why").
  virtual bool predict_fixed(const State& x, const Input& u, double dt, State* x_next) const = 0;
  // Analytic Jacobian, if the model has one. Returning false from
  // has_analytic_jacobian() (the default) makes jacobian() numeric.
  virtual bool jacobian_fixed(const State& /*x*/, const Input& /*u*/, double /*dt*/, Jacobian* /*jacobian*/) const {
    return false;
  }
  // Process noise over dt given the bank's continuous-time intensity; the
  // default is MotionModel's intensity * dt. (A model may instead override
  // process_noise() itself, noexcept, as a plain MotionModel does; exceptions
  // are then its own to catch.)
  virtual bool process_noise_fixed(const Covariance& intensity, const State& /*x*/, const Input& /*u*/, double dt,
                                   Covariance* noise) const {
    *noise = intensity * dt;
    return true;
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
    try {
      if (!predict_fixed(x_fixed, u_fixed, dt, &next)) return false;
    } catch (const std::exception& e) {
      return internal::caught("predict_fixed() threw: ", e.what());
    } catch (...) {
      return internal::caught("predict_fixed() threw an exception that is not a std::exception", nullptr);
    }
    Eigen::Map<State>(x_next.data()) = next;
    return true;
  }

  bool jacobian(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
                Eigen::Ref<Eigen::MatrixXd> jacobian) const noexcept final {
    const State x_fixed = Eigen::Map<const State>(x.data());
    const Input u_fixed = input(u);
    Jacobian fixed;
    try {
      if (has_analytic_jacobian()) {
        if (!jacobian_fixed(x_fixed, u_fixed, dt, &fixed)) return false;
      } else {
        // Fixed-size central differences: no heap allocation in the hot path.
        auto step = [&](const State& xp, State& out) { return predict_fixed(xp, u_fixed, dt, &out); };
        auto angle = [this](int i) { return is_angle(i); };
        if (!numeric_state_jacobian_fixed(step, angle, x_fixed, &fixed)) return false;
      }
    } catch (const std::exception& e) {
      return internal::caught(has_analytic_jacobian() ? "jacobian_fixed() threw: " : "predict_fixed() threw: ", e.what());
    } catch (...) {
      return internal::caught("the Jacobian threw an exception that is not a std::exception", nullptr);
    }
    copy_square(fixed, jacobian);
    return true;
  }

  bool process_noise(const Eigen::Ref<const Eigen::MatrixXd>& intensity, const Eigen::Ref<const Eigen::VectorXd>& x,
                     const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
                     Eigen::Ref<Eigen::MatrixXd> noise) const noexcept override {
    Covariance intensity_fixed;
    for (int i = 0; i < kStateDim; ++i) {
      for (int j = 0; j < kStateDim; ++j) intensity_fixed(i, j) = intensity(i, j);
    }
    const State x_fixed = Eigen::Map<const State>(x.data());
    Covariance fixed;
    try {
      if (!process_noise_fixed(intensity_fixed, x_fixed, input(u), dt, &fixed)) return false;
    } catch (const std::exception& e) {
      return internal::caught("process_noise_fixed() threw: ", e.what());
    } catch (...) {
      return internal::caught("process_noise_fixed() threw an exception that is not a std::exception", nullptr);
    }
    copy_square(fixed, noise);
    return true;
  }

 private:
  static void copy_square(const Jacobian& fixed, Eigen::Ref<Eigen::MatrixXd>& out) noexcept {
    if (kStateDim > 1 && out.outerStride() == kStateDim) {
      Eigen::Map<Jacobian>(out.data()) = fixed;
    } else {
      // Element-wise: for 1x1 models GCC 12 misreads a packet copy as out of bounds.
      for (int i = 0; i < kStateDim; ++i) {
        for (int j = 0; j < kStateDim; ++j) out(i, j) = fixed(i, j);
      }
    }
  }

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
