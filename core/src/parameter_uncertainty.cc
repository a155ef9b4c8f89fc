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
      : model_(std::move(model)), covariance_(std::move(covariance)) {
    // Sigma's nonzero entries by column: a fitted covariance is often block
    // diagonal (fitting/parameter_covariance.h), and its exact zeros add
    // nothing to G Sigma G'.
    const Eigen::Index p = covariance_.rows();
    column_start_.assign(1, 0);
    for (Eigen::Index k = 0; k < p; ++k) {
      for (Eigen::Index l = 0; l < p; ++l) {
        if (covariance_(l, k) != 0.0) {
          column_rows_.push_back(l);
          column_values_.push_back(covariance_(l, k));
        }
      }
      column_start_.push_back(static_cast<Eigen::Index>(column_rows_.size()));
      if (column_start_[static_cast<std::size_t>(k + 1)] > column_start_[static_cast<std::size_t>(k)]) {
        uncertain_.push_back(k);
      }
    }
  }

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
      thread_local Eigen::MatrixXd g;
      thread_local Eigen::VectorXd sigma_g;  // a column of Sigma G'
      thread_local std::vector<Eigen::Index> nonzero, row_count, touched;
      thread_local std::vector<char> is_touched;
      const Eigen::Index n = noise.rows();
      const Eigen::Index p = covariance_.rows();
      g.resize(n, p);
      if (!model_->parameter_jacobian(x, u, dt, g)) {
        own_failure() = "parameter_covariance: the model's parameter_jacobian() failed";
        return false;
      }
      // G is mostly zeros (a parameter moves the states it belongs to: in
      // linear_features with a diagonal A, a ninth of G), and so is a
      // fitted Sigma, so G Sigma G' runs over the nonzero entries of both:
      // for each row i of G, the column i of Sigma G' at the rows it can be
      // nonzero, then the lower triangle's row i of G (Sigma G'). Each sum
      // in increasing index order, as the dense products take it, less the
      // exact zeros. Dense, the BorealTC bank's 10 modes spent ten times a
      // step's filtering on it.
      nonzero.resize(static_cast<std::size_t>(n * p));  // row i's at [i p, i p + row_count[i])
      row_count.assign(static_cast<std::size_t>(n), 0);
      // (Plain pointers: through the containers, every store would reload them.)
      Eigen::Index* const nonzero_of = nonzero.data();
      Eigen::Index* const count_of = row_count.data();
      const double* const g_of = g.data();
      // Down the columns, as G is stored; only those of parameters with some
      // variance (a held parameter's column of G adds nothing).
      // Without a branch per entry: k is written at row i's next place
      // either way, and kept by counting it only when G(i, k) is nonzero.
      for (const Eigen::Index k : uncertain_) {
        for (Eigen::Index i = 0; i < n; ++i) {
          nonzero_of[i * p + count_of[i]] = k;
          count_of[i] += g_of[k * n + i] != 0.0;
        }
      }
      const auto row = [nonzero_of, count_of, p](Eigen::Index i) {
        const Eigen::Index* first = nonzero_of + i * p;
        return std::make_pair(first, first + count_of[i]);
      };
      sigma_g.resize(p);
      is_touched.assign(static_cast<std::size_t>(p), 0);
      touched.resize(static_cast<std::size_t>(p));
      double* const column_i = sigma_g.data();
      char* const seen = is_touched.data();
      Eigen::Index* const touched_of = touched.data();
      const Eigen::Index* const start_of = column_start_.data();
      const Eigen::Index* const rows_of = column_rows_.data();
      const double* const values_of = column_values_.data();
      for (Eigen::Index i = 0; i < n; ++i) {
        const auto [first, last] = row(i);
        Eigen::Index touched_count = 0;
        for (const Eigen::Index* k = first; k != last; ++k) {
          const double g_ik = g_of[*k * n + i];
          for (Eigen::Index e = start_of[*k]; e < start_of[*k + 1]; ++e) {
            const Eigen::Index l = rows_of[e];
            if (!seen[l]) {
              seen[l] = 1;
              touched_of[touched_count++] = l;
              column_i[l] = 0.0;
            }
            column_i[l] += g_ik * values_of[e];
          }
        }
        for (Eigen::Index j = 0; j <= i; ++j) {
          const auto [j_first, j_last] = row(j);
          double added = 0.0;
          for (const Eigen::Index* l = j_first; l != j_last; ++l) {
            if (seen[*l]) added += column_i[*l] * g_of[*l * n + j];
          }
          noise(i, j) += added;
          if (j != i) noise(j, i) += added;
        }
        for (Eigen::Index t = 0; t < touched_count; ++t) seen[touched_of[t]] = 0;
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
  // Sigma's nonzero entries: column k's rows are column_rows_[column_start_[k] .. column_start_[k + 1]),
  // their values column_values_[...] at the same places.
  std::vector<Eigen::Index> column_rows_;
  std::vector<double> column_values_;
  std::vector<Eigen::Index> column_start_;
  std::vector<Eigen::Index> uncertain_;  // the columns with some nonzero entry
};

ModelHandle unwrapped(ModelHandle model) {
  if (const auto* wrapped = dynamic_cast<const ParameterUncertainModel*>(model.get())) {
    return ModelHandle(wrapped->wrapped());
  }
  return model;
}

void check_size(const sdk::MotionModel& model, const Eigen::MatrixXd& covariance) {
  const Eigen::Index p = static_cast<Eigen::Index>(model.parameter_info().size());
  if (covariance.rows() != p || covariance.cols() != p) {
    throw Error("a parameter covariance must be " + std::to_string(p) + "x" + std::to_string(p) +
                " (one row and column per parameter of the model), got " + std::to_string(covariance.rows()) + "x" +
                std::to_string(covariance.cols()));
  }
}

// `model` (unwrapped) with `covariance` (checked) added to its process noise.
ModelHandle wrapped_with(ModelHandle model, Eigen::MatrixXd covariance, double dt) {
  const Eigen::Index p = covariance.rows();
  Eigen::MatrixXd g(model->state_dim(), p);
  const Eigen::VectorXd x = Eigen::VectorXd::Zero(model->state_dim());
  const Eigen::VectorXd u = Eigen::VectorXd::Zero(model->input_dim());
  if (!model->parameter_jacobian(x, u, dt, g)) {
    model->failure_reason();  // clear it
    throw Error("the model gives no parameter Jacobian (parameter_jacobian()), which a parameter covariance needs");
  }
  return ModelHandle(std::make_shared<ParameterUncertainModel>(std::move(model), std::move(covariance)));
}

double step_of(const Bank& bank) { return bank.config.sampling.rate > 0.0 ? 1.0 / bank.config.sampling.rate : 0.1; }

}  // namespace

ModelHandle with_parameter_uncertainty(ModelHandle model, const Eigen::MatrixXd& covariance, double dt) {
  model = unwrapped(std::move(model));
  if (covariance.size() == 0) return model;
  check_size(*model, covariance);
  std::string why;
  if (!check_parameter_covariance(covariance, &why)) throw Error("a parameter covariance must be a covariance: " + why);
  // Written to 10 digits, a covariance with directions of no variance (held
  // parameters, exact combinations) can read back a hair below zero there.
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(covariance);
  const Eigen::MatrixXd psd =
      eigen.eigenvectors() * eigen.eigenvalues().cwiseMax(0.0).asDiagonal() * eigen.eigenvectors().transpose();
  return wrapped_with(std::move(model), 0.5 * (psd + psd.transpose()), dt);
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
  bank->models[j] = with_parameter_uncertainty(bank->models[j], covariance, step_of(*bank));
  bank->config.modes[j].parameter_covariance = covariance;
}

void set_fitted_parameter_covariance(Bank* bank, int mode, const Eigen::MatrixXd& covariance) {
  const std::size_t j = static_cast<std::size_t>(mode);
  ModelHandle model = unwrapped(bank->models[j]);
  if (covariance.size() > 0) {
    check_size(*model, covariance);
    model = wrapped_with(std::move(model), covariance, step_of(*bank));
  }
  bank->models[j] = std::move(model);
  bank->config.modes[j].parameter_covariance = covariance;
}

}  // namespace skidimm
