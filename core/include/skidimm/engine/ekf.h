// ExtendedKalmanFilter: the model-matched filter of one IMM mode (paper,
// section IV-3), with its own preallocated workspace.
//
//   predict:  x- = f(x, u, dt),  P- = F P F' + Q(dt)          F = df/dx
//   update:   nu = z - H x- (angles wrapped),  S = H P- H' + R
//             K = P- H' S^-1 (Cholesky solve, never an inverse)
//             x+ = x- + K nu,  P+ = (I-KH) P- (I-KH)' + K R K'  (Joseph form)
//             log Lambda = -1/2 (nu' S^-1 nu + log det(2 pi S))   (paper eq. 8)
//
// A linear model is the special case of a constant F. The Joseph form keeps P
// symmetric positive semidefinite under round-off, where P - KHP does not.
// After construction no member allocates.
#ifndef SKIDIMM_ENGINE_EKF_H_
#define SKIDIMM_ENGINE_EKF_H_

#include <Eigen/Core>
#include <limits>
#include <vector>

#include "skidimm/engine/measurement_model.h"
#include "skidimm/sdk/motion_model.h"

namespace skidimm {

struct UpdateResult {
  bool ok = false;              // false: S not positive definite or result non-finite
  bool gated = false;           // nis was above the gate: x and P were left as predicted
  // log N(nu; 0, S); when gated, the density at the gate's boundary,
  // -1/2 (gate + log det(2 pi S)): the most a gated measurement can score.
  double log_likelihood = 0.0;
  double nis = 0.0;  // nu' S^-1 nu, chi-square with size() dof if consistent
};

class ExtendedKalmanFilter {
 public:
  // `model` must outlive the filter. q_intensity: the mode's continuous-time Q.
  ExtendedKalmanFilter(const sdk::MotionModel& model, Eigen::MatrixXd q_intensity, int measurement_dim);

  Eigen::VectorXd& state() { return x_; }
  const Eigen::VectorXd& state() const { return x_; }
  Eigen::MatrixXd& covariance() { return p_; }
  const Eigen::MatrixXd& covariance() const { return p_; }

  // Propagates state() and covariance() by dt with input u. Returns false if
  // the model fails or produces non-finite values (state is then unspecified).
  bool predict(const Eigen::Ref<const Eigen::VectorXd>& u, double dt);

  // Corrects state() and covariance() with the selected measurement, unless
  // its NIS is above `gate` (then only the result is written, gated).
  UpdateResult update(const SelectedMeasurement& measurement, double gate = std::numeric_limits<double>::infinity());

  // The last update's whitened innovation L^-1 nu (S = L L', its Cholesky
  // factor), one entry per measured component; valid after an update whose
  // result is ok (gated or not). Computed on demand from what update() kept.
  Eigen::Ref<const Eigen::VectorXd> whitened_innovation();

  // Wraps the angle components of a state in place.
  void wrap_angles(Eigen::Ref<Eigen::VectorXd> x) const;
  bool is_angle(int i) const { return is_angle_[i]; }

 private:
  const sdk::MotionModel& model_;
  Eigen::MatrixXd q_intensity_;
  std::vector<bool> is_angle_;

  Eigen::VectorXd x_;
  Eigen::MatrixXd p_;
  // Workspace.
  Eigen::VectorXd x_next_;
  Eigen::MatrixXd f_;
  Eigen::MatrixXd q_;
  Eigen::MatrixXd fp_;
  Eigen::VectorXd innovation_;
  Eigen::VectorXd whitened_;
  Eigen::VectorXd whitened_innovation_;  // L^-1 nu
  int last_size_ = 0;                    // components of the last update
  Eigen::MatrixXd hp_;    // H P-          (k x n)
  Eigen::MatrixXd s_;     // S, then its Cholesky factor
  Eigen::MatrixXd gain_;  // K             (n x k)
  Eigen::MatrixXd i_kh_;  // I - K H       (n x n)
  Eigen::MatrixXd kr_;    // K R           (n x k)
};

}  // namespace skidimm

#endif  // SKIDIMM_ENGINE_EKF_H_
