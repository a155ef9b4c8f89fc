#include "skidimm/engine/parameter_uncertainty.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <memory>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "covariance.h"
#include "skidimm/config/bank.h"
#include "skidimm/errors.h"

namespace skidimm {

namespace {

// The model it wraps with G Sigma G' added to process_noise(); everything
// else is the wrapped model's. Like any model it may be shared by filters on
// several threads: its buffers are per thread.
class ParameterUncertainModel final : public sdk::MotionModel {
 public:
  ParameterUncertainModel(ModelHandle model, Eigen::MatrixXd covariance)
      : model_(std::move(model)), covariance_(std::move(covariance)) {}

  const ModelHandle& wrapped() const { return model_; }
  const Eigen::MatrixXd& covariance() const { return covariance_; }

  int state_dim() const noexcept override { return model_->state_dim(); }
  int input_dim() const noexcept override { return model_->input_dim(); }
  const std::vector<std::string>& state_names() const noexcept override { return model_->state_names(); }
  const std::vector<std::string>& input_names() const noexcept override { return model_->input_names(); }
  bool is_angle(int state_index) const noexcept override { return model_->is_angle(state_index); }
  const std::vector<sdk::ParameterInfo>& parameter_info() const noexcept override { return model_->parameter_info(); }
  void get_parameters(Eigen::Ref<Eigen::VectorXd> values) const noexcept override { model_->get_parameters(values); }
  bool set_parameters(const Eigen::Ref<const Eigen::VectorXd>& values, std::string* error) noexcept override {
    return model_->set_parameters(values, error);
  }
  bool predict(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
               Eigen::Ref<Eigen::VectorXd> x_next) const noexcept override {
    own_failure() = nullptr;
    return model_->predict(x, u, dt, x_next);
  }
  bool jacobian(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
                Eigen::Ref<Eigen::MatrixXd> jacobian) const noexcept override {
    own_failure() = nullptr;
    return model_->jacobian(x, u, dt, jacobian);
  }
  bool has_analytic_jacobian() const noexcept override { return model_->has_analytic_jacobian(); }
  bool parameter_jacobian(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u,
                          double dt, Eigen::Ref<Eigen::MatrixXd> jacobian) const noexcept override {
    return model_->parameter_jacobian(x, u, dt, jacobian);
  }

  bool process_noise(const Eigen::Ref<const Eigen::MatrixXd>& intensity, const Eigen::Ref<const Eigen::VectorXd>& x,
                     const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
                     Eigen::Ref<Eigen::MatrixXd> noise) const noexcept override {
    own_failure() = nullptr;
    if (!model_->process_noise(intensity, x, u, dt, noise)) return false;
    try {
      // Sized once per thread: no allocation per step after the first.
      thread_local Eigen::MatrixXd g, sigma_g;
      thread_local std::vector<Eigen::Index> nonzero;
      thread_local std::vector<Eigen::Index> row_start;
      const Eigen::Index n = noise.rows();
      const Eigen::Index p = covariance_.rows();
      g.resize(n, p);
      sigma_g.resize(p, n);
      if (!model_->parameter_jacobian(x, u, dt, g)) {
        own_failure() = "parameter_covariance: the model's parameter_jacobian() failed";
        return false;
      }
      // G is mostly zeros (a parameter moves the states it belongs to: in
      // linear_features with a diagonal A, a ninth of G), so the products
      // run over each row's nonzero entries: Sigma G' column by column, then
      // G (Sigma G'). Dense, the BorealTC bank's 10 modes spent ten times a
      // step's filtering on it.
      nonzero.resize(static_cast<std::size_t>(n * p));
      row_start.resize(static_cast<std::size_t>(n + 1));
      std::size_t count = 0;
      for (Eigen::Index i = 0; i < n; ++i) {
        row_start[static_cast<std::size_t>(i)] = static_cast<Eigen::Index>(count);
        for (Eigen::Index k = 0; k < p; ++k) {
          if (g(i, k) != 0.0) nonzero[count++] = k;
        }
      }
      row_start[static_cast<std::size_t>(n)] = static_cast<Eigen::Index>(count);
      for (Eigen::Index i = 0; i < n; ++i) {
        auto column = sigma_g.col(i);
        column.setZero();
        for (Eigen::Index e = row_start[static_cast<std::size_t>(i)]; e < row_start[static_cast<std::size_t>(i + 1)];
             ++e) {
          const Eigen::Index k = nonzero[static_cast<std::size_t>(e)];
          column += g(i, k) * covariance_.col(k);  // Sigma is symmetric: its column k is its row k
        }
      }
      for (Eigen::Index i = 0; i < n; ++i) {
        for (Eigen::Index j = 0; j <= i; ++j) {
          double added = 0.0;
          for (Eigen::Index e = row_start[static_cast<std::size_t>(j)]; e < row_start[static_cast<std::size_t>(j + 1)];
               ++e) {
            const Eigen::Index k = nonzero[static_cast<std::size_t>(e)];
            added += sigma_g(k, i) * g(j, k);
          }
          noise(i, j) += added;
          if (j != i) noise(j, i) += added;
        }
      }
    } catch (...) {  // bad_alloc
      own_failure() = "parameter_covariance: out of memory";
      return false;
    }
    return true;
  }

  const std::vector<std::string>& output_names() const noexcept override { return model_->output_names(); }
  bool outputs(const Eigen::Ref<const Eigen::VectorXd>& u, Eigen::Ref<Eigen::VectorXd> y) const noexcept override {
    return model_->outputs(u, y);
  }
  bool output_parameter_jacobian(const Eigen::Ref<const Eigen::VectorXd>& u,
                                 Eigen::Ref<Eigen::MatrixXd> jacobian) const noexcept override {
    return model_->output_parameter_jacobian(u, jacobian);
  }
  const char* failure_reason() const noexcept override {
    const char* own = own_failure();
    own_failure() = nullptr;
    return own != nullptr ? own : model_->failure_reason();
  }

 private:
  static const char*& own_failure() noexcept {
    thread_local const char* reason = nullptr;
    return reason;
  }

  ModelHandle model_;
  Eigen::MatrixXd covariance_;
};

}  // namespace

ModelHandle with_parameter_uncertainty(ModelHandle model, const Eigen::MatrixXd& covariance, double dt) {
  if (const auto* wrapped = dynamic_cast<const ParameterUncertainModel*>(model.get())) {
    model = ModelHandle(wrapped->wrapped());
  }
  if (covariance.size() == 0) return model;
  const Eigen::Index p = static_cast<Eigen::Index>(model->parameter_info().size());
  if (covariance.rows() != p || covariance.cols() != p) {
    throw Error("a parameter covariance must be " + std::to_string(p) + "x" + std::to_string(p) +
                " (one row and column per parameter of the model), got " + std::to_string(covariance.rows()) + "x" +
                std::to_string(covariance.cols()));
  }
  std::string why;
  if (!check_parameter_covariance(covariance, &why)) throw Error("a parameter covariance must be a covariance: " + why);
  // Written to 10 digits, a covariance with directions of no variance (held
  // parameters, exact combinations) can read back a hair below zero there.
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(covariance);
  const Eigen::MatrixXd psd =
      eigen.eigenvectors() * eigen.eigenvalues().cwiseMax(0.0).asDiagonal() * eigen.eigenvectors().transpose();
  Eigen::MatrixXd g(model->state_dim(), p);
  const Eigen::VectorXd x = Eigen::VectorXd::Zero(model->state_dim());
  const Eigen::VectorXd u = Eigen::VectorXd::Zero(model->input_dim());
  if (!model->parameter_jacobian(x, u, dt, g)) {
    model->failure_reason();  // clear it
    throw Error("the model gives no parameter Jacobian (parameter_jacobian()), which a parameter covariance needs");
  }
  return ModelHandle(std::make_shared<ParameterUncertainModel>(std::move(model), 0.5 * (psd + psd.transpose())));
}

bool check_parameter_covariance(const Eigen::MatrixXd& covariance, std::string* why) {
  auto fail = [why](const std::string& message) {
    if (why != nullptr) *why = message;
    return false;
  };
  if (covariance.rows() != covariance.cols()) {
    return fail("not square (" + std::to_string(covariance.rows()) + "x" + std::to_string(covariance.cols()) + ")");
  }
  if (covariance.size() == 0) return true;
  if (!covariance.allFinite()) return fail("has non-finite entries");
  // Symmetry as check_covariance() asks it; definiteness to the file's rounding.
  const double scale = covariance.cwiseAbs().maxCoeff();
  Eigen::MatrixXd symmetric_part = 0.5 * (covariance + covariance.transpose());
  std::string reason;
  if (!check_covariance(covariance, /*strict=*/false, &reason) && reason.rfind("not symmetric", 0) == 0) {
    return fail(reason);
  }
  const Eigen::VectorXd lambda = Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(symmetric_part).eigenvalues();
  if (lambda.minCoeff() < -1e-6 * std::max(lambda.maxCoeff(), 1e-300) || (scale > 0.0 && !(lambda.maxCoeff() > 0.0))) {
    std::ostringstream out;
    out << "not positive semidefinite: smallest eigenvalue " << lambda.minCoeff() << ", largest " << lambda.maxCoeff();
    return fail(out.str());
  }
  return true;
}

const Eigen::MatrixXd& parameter_covariance_of(const sdk::MotionModel& model) {
  static const Eigen::MatrixXd kNone;
  const auto* wrapped = dynamic_cast<const ParameterUncertainModel*>(&model);
  return wrapped != nullptr ? wrapped->covariance() : kNone;
}

void set_parameter_covariance(Bank* bank, int mode, const Eigen::MatrixXd& covariance) {
  const std::size_t j = static_cast<std::size_t>(mode);
  const double dt = bank->config.sampling.rate > 0.0 ? 1.0 / bank->config.sampling.rate : 0.1;
  bank->models[j] = with_parameter_uncertainty(bank->models[j], covariance, dt);
  bank->config.modes[j].parameter_covariance = covariance;
}

}  // namespace skidimm
