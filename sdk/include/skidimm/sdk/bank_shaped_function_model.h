// FunctionModel for a spec whose shapes come from the bank (its layout(),
// bank_layout.h): what function_model.h generates, with the states, inputs
// and parameter shapes read when a bank creates the model. Included by
// function_model.h, which is what a spec's author includes.
//
// The same checks, messages and boundary as with compile-time shapes; the
// differences follow from the sizes being runtime values:
//  * Create() also checks the bank's names: there are some, and at most
//    kMaxStates states and kMaxInputs inputs;
//  * the spec's functions see every numeric entry of its table in p, the
//    fixed ones included; get/set and parameter_info() only the others;
//  * the fixed-size work arrays are bounded by kMaxStates, kMaxInputs and
//    kMaxParameters, on the stack: nothing allocates per step;
//  * no jets: a derivative the spec does not write is differenced (the
//    MotionModel defaults), and the conformance kit checks those it writes
//    against central differences.
#ifndef SKIDIMM_SDK_BANK_SHAPED_FUNCTION_MODEL_H_
#define SKIDIMM_SDK_BANK_SHAPED_FUNCTION_MODEL_H_

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <exception>
#include <iterator>
#include <memory>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "skidimm/sdk/angles.h"
#include "skidimm/sdk/bank_layout.h"
#include "skidimm/sdk/failure.h"
#include "skidimm/sdk/function_model.h"
#include "skidimm/sdk/motion_model.h"
#include "skidimm/sdk/parameter_spec.h"
#include "skidimm/sdk/parameters.h"
#include "skidimm/sdk/plugin_info.h"

namespace skidimm {
namespace sdk {
namespace internal {

// predict(const Layout&, const double* x, const double* u, const double* p, double dt, double* x_next).
template <typename Spec, typename = void>
struct HasLayoutPredict : std::false_type {};
template <typename Spec>
struct HasLayoutPredict<Spec,
                        std::void_t<decltype(Spec::predict(std::declval<const Layout&>(), std::declval<const double*>(),
                                                           std::declval<const double*>(), std::declval<const double*>(),
                                                           0.0, std::declval<double*>()))>> : std::true_type {};

template <typename Spec, typename = void>
struct HasLayoutJacobian : std::false_type {};
template <typename Spec>
struct HasLayoutJacobian<
    Spec, std::void_t<decltype(Spec::jacobian(std::declval<const Layout&>(), std::declval<const double*>(),
                                              std::declval<const double*>(), std::declval<const double*>(), 0.0,
                                              std::declval<double*>()))>> : std::true_type {};

template <typename Spec, typename = void>
struct HasLayoutParameterJacobian : std::false_type {};
template <typename Spec>
struct HasLayoutParameterJacobian<
    Spec, std::void_t<decltype(Spec::parameter_jacobian(std::declval<const Layout&>(), std::declval<const double*>(),
                                                        std::declval<const double*>(), std::declval<const double*>(),
                                                        0.0, std::declval<double*>()))>> : std::true_type {};

template <typename Spec, typename = void>
struct HasLayoutParameterJacobianRows : std::false_type {};
template <typename Spec>
struct HasLayoutParameterJacobianRows<
    Spec, std::void_t<decltype(Spec::parameter_jacobian_may_move(std::declval<const Layout&>(), 0, 0))>>
    : std::true_type {};

template <typename Spec, typename = void>
struct HasLayoutProcessNoise : std::false_type {};
template <typename Spec>
struct HasLayoutProcessNoise<
    Spec, std::void_t<decltype(Spec::process_noise(std::declval<const Layout&>(), std::declval<const double*>(),
                                                   std::declval<const double*>(), std::declval<const double*>(),
                                                   std::declval<const double*>(), 0.0, std::declval<double*>()))>>
    : std::true_type {};

inline std::string join_names(const std::vector<std::string>& names) {
  std::string out;
  for (const std::string& name : names) out += (out.empty() ? "" : ", ") + name;
  return out;
}

// Entry (r, c) of a row as the bank shapes it: "c[i]" in a list, "B[r,c]"
// in a matrix; a row with a compile-time shape is named as usual.
inline std::string bank_flat_name(const ParameterSpec& p, const ParameterLayout& layout, int r, int c) {
  if (p.kind == ParameterKind::kNumbers) return flat_name(p, r, c);
  if (layout.is_list) return std::string(p.key) + "[" + std::to_string(r * layout.shape.cols + c) + "]";
  return std::string(p.key) + "[" + std::to_string(r) + "," + std::to_string(c) + "]";
}

}  // namespace internal

template <typename Spec>
class FunctionModel<Spec, internal::BankShapes> final : public MotionModel {
 public:
  static constexpr int kMaxStates = Spec::kMaxStates;
  static constexpr int kMaxInputs = Spec::kMaxInputs;
  static constexpr int kMaxParameters = Spec::kMaxParameters;
  static constexpr bool kHandWrittenJacobian = internal::HasLayoutJacobian<Spec>::value;
  static constexpr bool kHandWrittenParameterJacobian = internal::HasLayoutParameterJacobian<Spec>::value;

  static_assert(kMaxStates > 0 && kMaxInputs >= 0 && kMaxParameters >= 0,
                "kMaxStates must be positive, kMaxInputs and kMaxParameters not negative");
  static_assert(internal::HasLayoutPredict<Spec>::value,
                "a spec with layout() needs `static void predict(const skidimm::sdk::Layout& layout, const double* "
                "x, const double* u, const double* p, double dt, double* x_next)`");
  static_assert(!internal::HasOutputTable<Spec>::value, "a spec whose shapes come from the bank has no outputs");

  static std::unique_ptr<FunctionModel> Create(const ParameterSet& params, std::string* error) {
    auto fail = [error](const std::string& message) {
      if (error != nullptr) *error = message;
      return std::unique_ptr<FunctionModel>();
    };
    const std::string name = Spec::kName;
    const std::vector<std::string>& states = params.bank_states();
    const std::vector<std::string>& inputs = params.bank_inputs();
    if (states.empty()) {
      return fail(name +
                  " takes its states and inputs from the bank (its 'states:' and 'inputs:'), but none were given: "
                  "create it from a bank file");
    }
    if (static_cast<int>(states.size()) > kMaxStates) {
      return fail(name + " supports at most " + std::to_string(kMaxStates) + " states, the bank has " +
                  std::to_string(states.size()) + " (" + internal::join_names(states) + ")");
    }
    if (static_cast<int>(inputs.size()) > kMaxInputs) {
      return fail(name + " supports at most " + std::to_string(kMaxInputs) + " inputs, the bank has " +
                  std::to_string(inputs.size()) + " (" + internal::join_names(inputs) + ")");
    }
    std::vector<bool> angles = params.bank_angles();
    if (angles.empty()) angles.assign(states.size(), false);
    if (angles.size() != states.size()) return fail("the bank's angle flags do not match its states");
    std::vector<std::string> keys;
    for (const ParameterSpec& p : table()) keys.emplace_back(p.key);
    if (!params.check_only(keys, error)) return nullptr;

    std::unique_ptr<FunctionModel> model(new FunctionModel());
    Layout& layout = model->layout_;
    layout.states = states;
    layout.angles = std::move(angles);
    layout.inputs = inputs;
    layout.parameters.resize(std::size(table()));
    for (std::size_t i = 0; i < std::size(table()); ++i) {
      if (table()[i].kind != ParameterKind::kNumbers) continue;
      layout.parameters[i].shape = table()[i].shape;
      layout.parameters[i].is_list = table()[i].is_vector();
    }
    std::string why;
    if (!Spec::layout(params, &layout, &why)) return fail(why);

    int total = 0;
    for (std::size_t i = 0; i < std::size(table()); ++i) {
      ParameterLayout& row = layout.parameters[i];
      if (table()[i].kind == ParameterKind::kText) row.shape = Shape{0, 0};
      row.offset = total;
      total += row.present() ? row.size() : 0;
    }
    if (total > kMaxParameters) {
      return fail(name + " supports at most " + std::to_string(kMaxParameters) + " parameter entries, this mode has " +
                  std::to_string(total));
    }
    model->p_.assign(static_cast<std::size_t>(total), 0.0);
    // Every entry, fixed ones too, so that a non-finite one is named.
    std::vector<ParameterInfo> every;
    for (std::size_t i = 0; i < std::size(table()); ++i) {
      const ParameterSpec& p = table()[i];
      const ParameterLayout& row = layout.parameters[i];
      if (!row.present()) continue;
      const std::string expected = std::to_string(row.shape.rows) + "x" + std::to_string(row.shape.cols);
      const Eigen::MatrixXd* value = params.find(p.key);
      if (value == nullptr) {
        return fail(params.contains(p.key) ? "parameter '" + std::string(p.key) + "' must be numbers, not text"
                                           : "missing parameter '" + std::string(p.key) + "' (" + expected + ")");
      }
      if (value->rows() != row.shape.rows || value->cols() != row.shape.cols) {
        return fail("parameter '" + std::string(p.key) + "' must be " + expected + ", got " +
                    std::to_string(value->rows()) + "x" + std::to_string(value->cols()));
      }
      for (int r = 0; r < row.shape.rows; ++r) {
        for (int c = 0; c < row.shape.cols; ++c) {
          const int entry = r * row.shape.cols + c;
          model->p_[static_cast<std::size_t>(row.offset + entry)] = (*value)(r, c);
          ParameterInfo info;
          info.name = internal::bank_flat_name(p, row, r, c);
          info.key = p.key;
          info.description = static_cast<int>(row.descriptions.size()) == row.size()
                                 ? row.descriptions[static_cast<std::size_t>(entry)]
                                 : std::string(p.description);
          info.lower_bound = p.lower_bound;
          info.upper_bound = p.upper_bound;
          info.scope = p.scope;
          every.push_back(info);
          if (row.fixed) continue;
          model->free_.push_back(row.offset + entry);
          model->info_.push_back(std::move(info));
        }
      }
    }
    if (!check_parameter_values(every, Eigen::Map<const Eigen::VectorXd>(model->p_.data(), total), error)) {
      return nullptr;
    }
    if constexpr (kHandWrittenParameterJacobian && internal::HasLayoutParameterJacobianRows<Spec>::value) {
      for (int entry : model->free_) {
        std::vector<int> rows;
        for (int r = 0; r < model->layout_.num_states(); ++r) {
          if (Spec::parameter_jacobian_may_move(model->layout_, entry, r)) rows.push_back(r);
        }
        for (int r : rows) model->jacobian_sources_.push_back(r * total + entry);
        model->jacobian_rows_.push_back(std::move(rows));
      }
    }
    return model;
  }

  // --- Names and parameters ---
  int state_dim() const noexcept override { return layout_.num_states(); }
  int input_dim() const noexcept override { return layout_.num_inputs(); }
  const std::vector<std::string>& state_names() const noexcept override { return layout_.states; }
  const std::vector<std::string>& input_names() const noexcept override { return layout_.inputs; }
  bool is_angle(int i) const noexcept override {
    return i >= 0 && i < state_dim() && layout_.angles[static_cast<std::size_t>(i)];
  }
  const std::vector<ParameterInfo>& parameter_info() const noexcept override { return info_; }
  void get_parameters(Eigen::Ref<Eigen::VectorXd> values) const noexcept override {
    for (std::size_t k = 0; k < free_.size(); ++k) {
      values[static_cast<Eigen::Index>(k)] = p_[static_cast<std::size_t>(free_[k])];
    }
  }
  bool set_parameters(const Eigen::Ref<const Eigen::VectorXd>& values, std::string* error) noexcept override {
    if (!check_parameter_values(info_, values, error)) return false;
    for (std::size_t k = 0; k < free_.size(); ++k) {
      p_[static_cast<std::size_t>(free_[k])] = values[static_cast<Eigen::Index>(k)];
    }
    return true;
  }
  // The shapes this model was created with, as the spec's functions see them.
  const Layout& layout() const noexcept { return layout_; }
  // Every numeric entry in table order, fixed ones included, as the spec's functions see them.
  const double* parameters() const noexcept { return p_.data(); }

  // --- Dynamics ---
  bool predict(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
               Eigen::Ref<Eigen::VectorXd> x_next) const noexcept override {
    if (!valid_step(x, u, dt) || x_next.size() != x.size()) return false;
    const int n = state_dim();
    double next[kMaxStates];
    try {
      Spec::predict(layout_, x.data(), input_data(u), p_.data(), dt, next);
    } catch (const std::exception& e) {
      return internal::caught("predict() threw: ", e.what());
    } catch (...) {
      return internal::caught("predict() threw an exception that is not a std::exception", nullptr);
    }
    if (!internal::all_finite(next, n)) {
      for (int i = 0; i < n; ++i) {
        if (std::isfinite(next[i])) continue;
        FailureText why;
        why << "predict() gave a state that is not finite: " << state_name(i) << " = " << next[i] << " (x_next[" << i
            << "])";
        return report_at(why, x, u, dt);
      }
    }
    for (int i = 0; i < n; ++i) x_next[i] = is_angle(i) ? wrap_angle(next[i]) : next[i];
    return true;
  }

  // The spec's own, or MotionModel's differences of predict().
  bool jacobian(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
                Eigen::Ref<Eigen::MatrixXd> jacobian) const noexcept override {
    if constexpr (!kHandWrittenJacobian) {
      return MotionModel::jacobian(x, u, dt, jacobian);
    } else {
      const int n = state_dim();
      if (!valid_step(x, u, dt) || jacobian.rows() != n || jacobian.cols() != n) return false;
      double row_major[kMaxStates * kMaxStates];
      try {
        Spec::jacobian(layout_, x.data(), input_data(u), p_.data(), dt, row_major);
      } catch (const std::exception& e) {
        return internal::caught("jacobian() threw: ", e.what());
      } catch (...) {
        return internal::caught("jacobian() threw an exception that is not a std::exception", nullptr);
      }
      return copy_finite("jacobian()", row_major, n, jacobian, x, u, dt);
    }
  }
  bool has_analytic_jacobian() const noexcept override { return kHandWrittenJacobian; }
  bool jacobian_and_noise_depend_only_on_dt() const noexcept override {
    return internal::JacobianAndNoiseDependOnlyOnDt<Spec>::value;
  }

  // The spec's own, or MotionModel's intensity * dt.
  bool process_noise(const Eigen::Ref<const Eigen::MatrixXd>& intensity, const Eigen::Ref<const Eigen::VectorXd>& x,
                     const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
                     Eigen::Ref<Eigen::MatrixXd> noise) const noexcept override {
    if constexpr (!internal::HasLayoutProcessNoise<Spec>::value) {
      return MotionModel::process_noise(intensity, x, u, dt, noise);
    } else {
      const int n = state_dim();
      if (!valid_step(x, u, dt) || intensity.rows() != n || intensity.cols() != n || noise.rows() != n ||
          noise.cols() != n) {
        return false;
      }
      double intensity_row_major[kMaxStates * kMaxStates], row_major[kMaxStates * kMaxStates];
      for (int r = 0; r < n; ++r) {
        for (int c = 0; c < n; ++c) intensity_row_major[r * n + c] = intensity(r, c);
      }
      try {
        Spec::process_noise(layout_, intensity_row_major, x.data(), input_data(u), p_.data(), dt, row_major);
      } catch (const std::exception& e) {
        return internal::caught("process_noise() threw: ", e.what());
      } catch (...) {
        return internal::caught("process_noise() threw an exception that is not a std::exception", nullptr);
      }
      return copy_finite("process_noise()", row_major, n, noise, x, u, dt);
    }
  }

  // The spec's own over every entry of p, its fixed entries' columns
  // dropped; without one, false, and the fitter differences predict().
  bool parameter_jacobian(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u,
                          double dt, Eigen::Ref<Eigen::MatrixXd> jacobian) const noexcept override {
    if constexpr (!kHandWrittenParameterJacobian) {
      return false;
    } else {
      const int n = state_dim();
      const int columns = static_cast<int>(free_.size());
      const int total = static_cast<int>(p_.size());
      if (!valid_step(x, u, dt) || jacobian.rows() != n || jacobian.cols() != columns) return false;
      if (columns == 0) return true;
      double every[kMaxStates * (kMaxParameters > 0 ? kMaxParameters : 1)];
      if (!spec_parameter_jacobian(x, u, dt, every)) return false;
      // One test of every entry without branches first (a filter with
      // parameter uncertainty asks for this at every step); the entry to
      // blame only when it fails.
      if (!internal::all_finite(every, n * total)) {
        for (int r = 0; r < n; ++r) {
          for (int k = 0; k < columns; ++k) {
            const double value = every[r * total + free_[static_cast<std::size_t>(k)]];
            if (!std::isfinite(value)) return report_not_finite_parameter_jacobian(r, k, value, x, u, dt);
          }
        }
      }
      for (int k = 0; k < columns; ++k) {  // down the columns, as the Jacobian is stored
        const double* column = every + free_[static_cast<std::size_t>(k)];
        for (int r = 0; r < n; ++r) jacobian(r, k) = column[r * total];
      }
      return true;
    }
  }

  // The rows the spec's parameter_jacobian_may_move(layout, entry, row)
  // allows for each parameter, when it has one; empty otherwise.
  const std::vector<std::vector<int>>& parameter_jacobian_rows() const noexcept override { return jacobian_rows_; }
  // Those entries of the spec's parameter Jacobian, tested only they.
  bool parameter_jacobian_entries(const Eigen::Ref<const Eigen::VectorXd>& x,
                                  const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
                                  Eigen::Ref<Eigen::VectorXd> entries) const noexcept override {
    if constexpr (!kHandWrittenParameterJacobian) {
      return false;
    } else {
      const int count = static_cast<int>(jacobian_sources_.size());
      if (jacobian_rows_.empty() || !valid_step(x, u, dt) || entries.size() != count) return false;
      double every[kMaxStates * (kMaxParameters > 0 ? kMaxParameters : 1)];
      if (!spec_parameter_jacobian(x, u, dt, every, &jacobian_sources_)) return false;
      const int* source = jacobian_sources_.data();
      for (int at = 0; at < count; ++at) entries[at] = every[source[at]];
      if (internal::all_finite(entries.data(), count)) return true;
      Eigen::Index at = 0;
      for (std::size_t k = 0; k < free_.size(); ++k) {
        for (int r : jacobian_rows_[k]) {
          const double value = entries[at++];
          if (!std::isfinite(value)) {
            return report_not_finite_parameter_jacobian(r, static_cast<int>(k), value, x, u, dt);
          }
        }
      }
      return true;  // unreachable: the sum is NaN only with an entry not finite
    }
  }

  // What `skidimm plugins` shows: the table, without states or inputs
  // (the bank's); built once, with static storage in the plugin.
  static const PluginInfo& info() {
    static const internal::PluginDocs<Spec> docs;
    return docs.info;
  }

  static constexpr const auto& table() { return internal::parameter_table<Spec>(); }

 private:
  FunctionModel() = default;

  const char* state_name(int i) const noexcept { return layout_.states[static_cast<std::size_t>(i)].c_str(); }

  // The sizes the model was created with and a finite, non-negative step;
  // otherwise false with the reason.
  bool valid_step(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u,
                  double dt) const noexcept {
    if (x.size() != state_dim() || u.size() != input_dim()) {
      FailureText why;
      why << "called with " << static_cast<int>(x.size()) << " states and " << static_cast<int>(u.size())
          << " inputs; the model has " << state_dim() << " and " << input_dim();
      why.report();
      return false;
    }
    if (!(dt >= 0.0) || !std::isfinite(dt)) {
      FailureText why;
      why << "the step dt = " << dt << " is not finite and non-negative";
      why.report();
      return false;
    }
    return true;
  }

  // Copies an n x n row-major result into `out`, or reports its first entry
  // that is not finite. The common case, every entry finite, is one
  // branch-free test and one copy.
  bool copy_finite(const char* what, const double* row_major, int n, Eigen::Ref<Eigen::MatrixXd>& out,
                   const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u,
                   double dt) const noexcept {
    if (internal::all_finite(row_major, n * n)) {
      using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
      out = Eigen::Map<const RowMajor>(row_major, n, n);
      return true;
    }
    for (int r = 0; r < n; ++r) {
      for (int c = 0; c < n; ++c) {
        const double value = row_major[r * n + c];
        if (std::isfinite(value)) continue;
        FailureText why;
        why << what << " is not finite: entry (row " << r << " '" << state_name(r) << "', column " << c << " '"
            << state_name(c) << "') = " << value;
        return report_at(why, x, u, dt);
      }
    }
    return true;  // unreachable: the sum is NaN only with an entry not finite
  }

  // The spec's parameter Jacobian over every entry of p into `every` (n x
  // p_.size(), row-major), zeroed first: a spec writes only the entries that
  // can be nonzero (function_model.h). With `read`, only those positions are
  // zeroed, the only ones the caller reads (the entries its
  // parameter_jacobian_may_move() allows: a filter with parameter
  // uncertainty asks for them at every step, a few dozen of a few hundred).
  // False, with the reason, if it threw.
  bool spec_parameter_jacobian(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u,
                               double dt, double* every, const std::vector<int>* read = nullptr) const noexcept {
    if (read != nullptr) {
      for (int at : *read) every[at] = 0.0;
    } else {
      std::fill(every, every + state_dim() * static_cast<int>(p_.size()), 0.0);
    }
    try {
      Spec::parameter_jacobian(layout_, x.data(), input_data(u), p_.data(), dt, every);
    } catch (const std::exception& e) {
      return internal::caught("the parameter Jacobian threw: ", e.what());
    } catch (...) {
      return internal::caught("the parameter Jacobian threw an exception that is not a std::exception", nullptr);
    }
    return true;
  }

  // Reports the parameter Jacobian's entry (row, column) = value, which is
  // not finite, with the operating point; false.
  bool report_not_finite_parameter_jacobian(int row, int column, double value,
                                            const Eigen::Ref<const Eigen::VectorXd>& x,
                                            const Eigen::Ref<const Eigen::VectorXd>& u, double dt) const noexcept {
    FailureText why;
    why << "parameter_jacobian() is not finite: entry (row " << row << " '" << state_name(row) << "', column " << column
        << " '" << info_[static_cast<std::size_t>(column)].name.c_str() << "') = " << value;
    return report_at(why, x, u, dt);
  }

  // Reports `why` with the operating point; false.
  bool report_at(FailureText& why, const Eigen::Ref<const Eigen::VectorXd>& x,
                 const Eigen::Ref<const Eigen::VectorXd>& u, double dt) const noexcept {
    return internal::report_at(why, x.data(), state_dim(), u.data(), input_dim(), dt);
  }

  const double* input_data(const Eigen::Ref<const Eigen::VectorXd>& u) const noexcept {
    return input_dim() > 0 ? u.data() : nullptr;
  }

  Layout layout_;
  std::vector<double> p_;  // every numeric entry, table order, fixed ones included
  std::vector<int> free_;  // where each of the model's parameters is in p_
  std::vector<ParameterInfo> info_;
  std::vector<std::vector<int>> jacobian_rows_;  // parameter_jacobian_rows()
  std::vector<int> jacobian_sources_;            // where each entry they name is in the spec's dense Jacobian
};

}  // namespace sdk
}  // namespace skidimm

#endif  // SKIDIMM_SDK_BANK_SHAPED_FUNCTION_MODEL_H_
