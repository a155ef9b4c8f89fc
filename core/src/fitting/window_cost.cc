#include "window_cost.h"

#include <cmath>
#include <cstring>

#include "all_finite.h"
#include "skidimm/sdk/angles.h"

namespace skidimm {
namespace fitting {
namespace internal {

using skidimm::internal::all_finite;

std::string window_text(const Trajectory& t, const Window& w) {
  return t.source + ": the prediction from step " + std::to_string(w.start + 1) +
         " (t = " + std::to_string(t.t[w.start]) + " s) to t = " + std::to_string(t.t[w.targets.back()]) + " s";
}

WindowCost::WindowCost(sdk::MotionModel* model, Eigen::VectorXd base, ParameterMapping mapping,
                       const MeasurementLayout* m, Window window, int block_size,
                       std::shared_ptr<WindowWorkspace> workspace)
    : model_(model),
      base_(std::move(base)),
      mapping_(std::move(mapping)),
      m_(m),
      window_(std::move(window)),
      positions_(output_positions(*model, *m)),
      w_(std::move(workspace)) {
  mutable_parameter_block_sizes()->push_back(block_size);
  set_num_residuals(window_.residuals);
  const int n = model_->state_dim();
  const Eigen::Index parameters = base_.size();
  w_->x.resize(n);
  w_->next.resize(n);
  w_->expected = Eigen::VectorXd::Zero(m_->h.rows());
  w_->predicted.resize(m_->h.rows());
  w_->f.resize(n, n);
  w_->g.resize(n, parameters);
  w_->output_g.resize(static_cast<Eigen::Index>(model_->output_names().size()), parameters);
  w_->d.resize(block_size);
}

bool WindowCost::EvaluateWindow(const Window& window, double const* const* parameters, double* residuals,
                                double** jacobians) const {
  WindowWorkspace& w = *w_;
  w.full = base_;
  for (std::size_t i = 0; i < mapping_.model_index.size(); ++i) {
    w.full[mapping_.model_index[i]] = parameters[0][mapping_.block_index[i]];
  }
  // The same parameters, bit for bit, leave the model as it is.
  if (w.set.size() != w.full.size() ||
      std::memcmp(w.set.data(), w.full.data(), sizeof(double) * static_cast<std::size_t>(w.full.size())) != 0) {
    if (!model_->set_parameters(w.full, nullptr)) return false;
    w.set = w.full;
  }
  const bool derivatives = jacobians != nullptr && jacobians[0] != nullptr;
  const Trajectory& t = *window.trajectory;
  const int n = model_->state_dim();
  const int block = parameter_block_sizes()[0];
  for (int s = 0; s < n; ++s) w.x[s] = t.z(m_->state_row[static_cast<std::size_t>(s)], window.start);
  // S is +0 at the start; it is written at the first step.
  bool sensitivity_zero = true;
  int row = window.start;
  int r = 0;
  for (int target : window.targets) {
    for (int k = row; k < target; ++k) {
      const double dt = t.t[k + 1] - t.t[k];
      if (derivatives) {
        if (!model_->jacobian(w.x, t.u.col(k), dt, w.f) || !model_->parameter_jacobian(w.x, t.u.col(k), dt, w.g)) {
          return false;
        }
        if (sensitivity_zero && all_finite(w.f)) {
          // F S with S = +0 is +0: only the parameters' own terms remain.
          w.sensitivity.setZero(n, block);
          for (std::size_t i = 0; i < mapping_.model_index.size(); ++i) {
            w.sensitivity.col(mapping_.block_index[i]) += w.g.col(mapping_.model_index[i]);
          }
        } else {
          if (sensitivity_zero) w.sensitivity.setZero(n, block);
          w.updated.noalias() = w.f * w.sensitivity;
          for (std::size_t i = 0; i < mapping_.model_index.size(); ++i) {
            w.updated.col(mapping_.block_index[i]) += w.g.col(mapping_.model_index[i]);
          }
          w.sensitivity.swap(w.updated);
        }
        sensitivity_zero = false;
      }
      if (!model_->predict(w.x, t.u.col(k), dt, w.next)) return false;
      w.x = w.next;
    }
    row = target;
    if (!expected_outputs(*model_, *m_, positions_, t.u.col(target), &w.all_outputs, &w.expected)) return false;
    if (derivatives && !m_->outputs.empty() && !model_->output_parameter_jacobian(t.u.col(target), w.output_g)) {
      return false;
    }
    // H x + expected; a row of H that picks one state gives it directly
    // (+0 where the product's sum of zeros would), other rows the product.
    if (!m_->every_row_picks) {
      w.predicted.noalias() = m_->h * w.x;
      w.predicted += w.expected;
    }
    // A non-finite entry would spread through the products' zeros: then
    // take the products.
    const bool direct = all_finite(w.x) && (!derivatives || all_finite(w.sensitivity));
    if (!direct && m_->every_row_picks) {
      w.predicted.noalias() = m_->h * w.x;
      w.predicted += w.expected;
    }
    for (Eigen::Index c = 0; c < t.z.rows(); ++c) {
      if (!std::isfinite(t.z(c, target))) continue;
      const int picked = direct ? m_->row_picks[static_cast<std::size_t>(c)] : -1;
      const double predicted = picked >= 0 ? (w.x[picked] + 0.0) + w.expected[c] : w.predicted[c];
      double e = t.z(c, target) - predicted;
      if (m_->row_is_angle[static_cast<std::size_t>(c)]) e = sdk::wrap_angle(e);
      residuals[r] = e / m_->sigma[c];
      if (derivatives) {
        double* jacobian_row = jacobians[0] + static_cast<std::ptrdiff_t>(r) * block;
        if (picked >= 0) {
          for (int p = 0; p < block; ++p) jacobian_row[p] = -(w.sensitivity(picked, p) + 0.0) / m_->sigma[c];
        } else {
          w.d.noalias() = m_->h.row(c) * w.sensitivity;
          w.d = -w.d / m_->sigma[c];
          if (c >= m_->first_output_row) {
            const int output = positions_[static_cast<std::size_t>(c - m_->first_output_row)];
            for (std::size_t i = 0; i < mapping_.model_index.size(); ++i) {
              w.d[mapping_.block_index[i]] -= w.output_g(output, mapping_.model_index[i]) / m_->sigma[c];
            }
          }
          for (int p = 0; p < block; ++p) jacobian_row[p] = w.d[p];
        }
      }
      ++r;
    }
  }
  return all_finite(w.x);
}

bool has_parameter_jacobian(const sdk::MotionModel& model, const MeasurementLayout& m, const Trajectory& t) {
  if (t.size() < 2) return false;
  const Eigen::Index parameters = static_cast<Eigen::Index>(model.parameter_info().size());
  Eigen::MatrixXd g(model.state_dim(), parameters);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(model.state_dim());
  Eigen::MatrixXd output_g(static_cast<Eigen::Index>(model.output_names().size()), parameters);
  return model.parameter_jacobian(x, t.u.col(0), t.t[1] - t.t[0], g) &&
         (m.outputs.empty() || model.output_parameter_jacobian(t.u.col(0), output_g));
}

}  // namespace internal
}  // namespace fitting
}  // namespace skidimm
