// MotionModel: the contract every motion-model plugin implements.
//
// A motion model propagates the state of one traction mode over a step:
//
//   x_{k+1} = predict(x_k, u_k, dt)                        (paper, eq. 1)
//   F_k     = d predict / d x  at (x_k, u_k, dt)           (EKF Jacobian)
//   Q_k     = process_noise(intensity, x_k, u_k, dt)       (default: intensity * dt)
//
// Units are SI (m, rad, s); angles are in radians and the engine wraps the
// components for which is_angle() is true to [-pi, pi).
//
// Threading: the engine calls a model from one thread at a time; the const
// members must not modify shared state, so several IMMs may share a model.
//
// Errors never cross the plugin boundary as exceptions (Boost.DLL gives no
// guarantee they could be caught): every virtual is noexcept and reports
// failure by its return value. A false from predict()/jacobian()/
// process_noise() makes the engine reject that mode for the step, never
// crash, and report the reason the model gave with report_failure()
// (failure.h). SizedMotionModel also turns exceptions thrown by its fixed-size
// forms into such a failure; a plain MotionModel must catch its own.
//
// Authors who know their dimensions at compile time derive from
// SizedMotionModel<kStateDim, kInputDim> (sized_motion_model.h) instead.
#ifndef SKIDIMM_SDK_MOTION_MODEL_H_
#define SKIDIMM_SDK_MOTION_MODEL_H_

#include <Eigen/Core>
#include <boost/config.hpp>
#include <string>
#include <vector>

#include "skidimm/sdk/failure.h"
#include "skidimm/sdk/numeric_jacobian.h"
#include "skidimm/sdk/parameters.h"

namespace skidimm {
namespace sdk {

class BOOST_SYMBOL_VISIBLE MotionModel {
 public:
  virtual ~MotionModel() = default;
  MotionModel(const MotionModel&) = delete;
  MotionModel& operator=(const MotionModel&) = delete;

  // --- Dimensions and names (constant for the model's lifetime) ---
  virtual int state_dim() const noexcept = 0;
  virtual int input_dim() const noexcept = 0;
  // state_names().size() == state_dim(), input_names().size() == input_dim().
  virtual const std::vector<std::string>& state_names() const noexcept = 0;
  virtual const std::vector<std::string>& input_names() const noexcept = 0;
  // True for components in radians that wrap at +-pi (e.g. a heading).
  virtual bool is_angle(int /*state_index*/) const noexcept { return false; }

  // --- Parameters as a flat vector, for generic tools (fitting) ---
  virtual const std::vector<ParameterInfo>& parameter_info() const noexcept = 0;
  // values.size() == parameter_info().size().
  virtual void get_parameters(Eigen::Ref<Eigen::VectorXd> values) const noexcept = 0;
  // Returns false (and explains in *error, if given) when values are invalid;
  // the model is then unchanged.
  virtual bool set_parameters(const Eigen::Ref<const Eigen::VectorXd>& values, std::string* error) noexcept = 0;

  // --- Dynamics ---
  // x_next = x after a step of dt seconds with input u held constant.
  // predict(x, u, 0) must return x. Returns false if the state cannot be
  // propagated (the output is then unspecified).
  virtual bool predict(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u,
                       double dt, Eigen::Ref<Eigen::VectorXd> x_next) const noexcept = 0;

  // Jacobian of predict() with respect to x (state_dim x state_dim). The
  // default differentiates predict() numerically; models override it with an
  // analytic form and report so in has_analytic_jacobian().
  virtual bool jacobian(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u,
                        double dt, Eigen::Ref<Eigen::MatrixXd> jacobian) const noexcept {
    auto step = [&](const Eigen::VectorXd& xp, Eigen::VectorXd& out) { return predict(xp, u, dt, out); };
    auto angle = [this](int i) { return is_angle(i); };
    return numeric_state_jacobian(step, angle, x, jacobian);
  }
  virtual bool has_analytic_jacobian() const noexcept { return false; }

  // Jacobian of predict() with respect to the flat parameter vector
  // (state_dim x parameter_info().size()), for fitting. Models whose
  // equations are a templated function get it exactly from
  // autodiff_parameter_jacobian() (autodiff_parameter_jacobian.h); the
  // default returns false and the fitter differentiates numerically.
  virtual bool parameter_jacobian(const Eigen::Ref<const Eigen::VectorXd>& /*x*/,
                                  const Eigen::Ref<const Eigen::VectorXd>& /*u*/, double /*dt*/,
                                  Eigen::Ref<Eigen::MatrixXd> /*jacobian*/) const noexcept {
    return false;
  }

  // Where parameter_jacobian() can be nonzero, for a model that knows it from
  // its structure: element k lists, increasing, the rows parameter k can move
  // at any x, u and dt. Empty (the default): any row. A mode with parameter
  // uncertainty adds G Sigma G' to its process noise at every step; with the
  // rows known it asks parameter_jacobian_entries() for those entries alone
  // (the BorealTC bank: 9 states and 36 parameters, each moving one state,
  // 36 entries of 324).
  virtual const std::vector<std::vector<int>>& parameter_jacobian_rows() const noexcept {
    static const std::vector<std::vector<int>> any;
    return any;
  }
  // The entries of parameter_jacobian() that parameter_jacobian_rows() names,
  // at (x, u, dt): column by column, each column's rows in their order, into
  // `entries` (as many as the rows name in all). False as parameter_jacobian()
  // (the default: not provided).
  virtual bool parameter_jacobian_entries(const Eigen::Ref<const Eigen::VectorXd>& /*x*/,
                                          const Eigen::Ref<const Eigen::VectorXd>& /*u*/, double /*dt*/,
                                          Eigen::Ref<Eigen::VectorXd> /*entries*/) const noexcept {
    return false;
  }

  // Covariance of the process noise added over a step of dt seconds, given the
  // mode's continuous-time intensity `intensity` (the bank's Q). The default,
  // Q * dt, is the usual random-walk discretisation (robot_localization, fuse)
  // and keeps the noise per second the same when sampling is irregular. A
  // model that needs another form overrides this and documents it.
  virtual bool process_noise(const Eigen::Ref<const Eigen::MatrixXd>& intensity,
                             const Eigen::Ref<const Eigen::VectorXd>& /*x*/,
                             const Eigen::Ref<const Eigen::VectorXd>& /*u*/, double dt,
                             Eigen::Ref<Eigen::MatrixXd> noise) const noexcept {
    noise = intensity * dt;
    return true;
  }

  // True if jacobian() and process_noise() depend on dt, the parameters and
  // the intensity only, never on x or u: a model linear in its state with
  // noise that does not depend on where it is (linear_features, ltc_linear).
  // The engine then asks for them once per mode for each new dt and reuses
  // them while dt repeats, from the first step after Imm::reset() on, so the
  // parameters must not change during a run. The conformance kit checks the
  // claim at distinct states and inputs (testing/conformance.h).
  virtual bool jacobian_and_noise_depend_only_on_dt() const noexcept { return false; }

  // --- Outputs ---
  // Quantities the model predicts from the input alone, besides its state:
  // a yaw rate, a motor current. A bank measures them by name
  // (`measurement.outputs`, docs/bank-format.md): the measurement of output
  // k is y_k = outputs(u)_k + v. An output depends on no state, so
  // measuring it moves no state; it tells the modes apart by how well each
  // predicts it. (That keeps the update linear in the state: an output of
  // the state would need its Jacobian, and is a state the bank can observe.)
  // Every mode of a bank that measures an output must have it.
  virtual const std::vector<std::string>& output_names() const noexcept {
    static const std::vector<std::string> kNone;
    return kNone;
  }
  // y.size() == output_names().size(). Returns false if the outputs cannot
  // be computed for u (the engine then rejects the mode for the step).
  virtual bool outputs(const Eigen::Ref<const Eigen::VectorXd>& /*u*/,
                       Eigen::Ref<Eigen::VectorXd> /*y*/) const noexcept {
    return false;
  }
  // d outputs / d parameters (output_names().size() x parameter_info().size()),
  // for fitting. The default returns false and the fitter differentiates
  // outputs() numerically.
  virtual bool output_parameter_jacobian(const Eigen::Ref<const Eigen::VectorXd>& /*u*/,
                                         Eigen::Ref<Eigen::MatrixXd> /*jacobian*/) const noexcept {
    return false;
  }

  // --- Failures ---
  // Why the last predict(), jacobian() or process_noise() on this thread
  // returned false, as given to report_failure() (failure.h); "" if no reason
  // was given. Reading it clears it. The engine calls it only after a false.
  virtual const char* failure_reason() const noexcept { return take_failure(); }

 protected:
  MotionModel() = default;
};

}  // namespace sdk
}  // namespace skidimm

#endif  // SKIDIMM_SDK_MOTION_MODEL_H_
