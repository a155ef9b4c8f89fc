// LinearFeaturesModel: the plugin class behind `linear_features`, a motion
// model defined by the bank file alone (docs/bank-format.md, "A model from
// YAML alone"). In a header so tests can run it in-process; the plugin .cc
// only exports it.
//
// Per mode, in continuous time,
//
//   dx/dt = A x + B u + c
//
// over the bank's own `states` (n of them, at most kMaxStates) and `inputs`
// (m, at most kMaxInputs); the inputs are whatever the bank computes from its
// log columns, e.g. `abs_dv: "abs(velR - velL)"`, so "features" are simply
// the bank's inputs. Parameters (all per mode):
//   A  n x n matrix (full, flat names "A[r,c]") or a list of n numbers
//      (diagonal, "A[i]"); the names are those the bank writer regroups into
//      the same shape, so a fitted bank keeps its form;
//   B  n x m matrix ("B[r,c]");
//   c  optional list of n numbers ("c[i]"); absent, it is zero and not a
//      parameter.
//   fixed  optional text list of the keys held at their given values and not
//      offered for fitting, e.g. [A]: at a low filter rate a fast state
//      settles within a step and only B/a shows in a log, so a and B cannot
//      both be fitted; fix A at a time constant you choose.
// The flat parameter vector is A, then B, then c, each row-major, without
// the fixed keys.
//
// Step (zero_order_hold.h): exact over dt with the input held,
//   x+ = Phi x + Gamma (B u + c),  Phi = expm(A dt),  Gamma = int_0^dt expm(A s) ds,
// so it is stable and correct at any filter rate, e.g. a 0.05 s time
// constant at 2 Hz. The state Jacobian is Phi, exactly. Angle states (the
// bank's `angles:`) are wrapped to [-pi, pi) on output.
//
// Process noise: not the default Q dt but the exact discretisation of white
// noise of intensity Q (the bank's Q) through these dynamics,
//   Qd = int_0^dt expm(A s) Q expm(A s)' ds.
// For a slow state it is Q dt; for a fast stable one (a < 0, |a| dt >> 1) it
// saturates at the stationary variance Q / (2|a|) instead of growing with dt.
// That is what makes the model usable at low filter rates: with Q dt, a 0.5 s
// step of a state with a = -20 /s would add 20 times the variance it can ever
// have.
//
// parameter_jacobian() is exact. Diagonal A: closed forms. Full A: one
// Fréchet derivative of the matrix exponential per state (n block
// exponentials of size 2 (n + 1), zoh_step_derivatives()); measured, that is
// a third of the cost of central differences (2 predictions per parameter)
// at n = 3 and a tenth at n = 12, so fitting never needs to fall back.
//
// Limits: n <= 12 and m <= 16, so that every matrix is fixed-maximum-size on
// the stack and the hot path (predict, jacobian, process_noise,
// parameter_jacobian) never allocates. Larger banks are rejected by Create().
#ifndef SKIDIMM_PLUGINS_LINEAR_FEATURES_LINEAR_FEATURES_MODEL_H_
#define SKIDIMM_PLUGINS_LINEAR_FEATURES_LINEAR_FEATURES_MODEL_H_

#include <Eigen/Core>
#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "linear_features/zero_order_hold.h"
#include "skidimm/sdk/angles.h"
#include "skidimm/sdk/motion_model.h"
#include "skidimm/sdk/parameters.h"

namespace skidimm {
namespace plugins {

class LinearFeaturesModel final : public sdk::MotionModel {
 public:
  static constexpr int kMaxStates = kMaxZohStates;
  static constexpr int kMaxInputs = 16;

  // How the bank gives A.
  enum class StateMatrixForm { kDiagonal, kFull };

  using Vector = ZohVector;
  using Matrix = ZohMatrix;
  using InputMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxStates, kMaxInputs>;

  static std::unique_ptr<LinearFeaturesModel> Create(const sdk::ParameterSet& params, std::string* error) {
    auto fail = [error](const std::string& message) {
      if (error != nullptr) *error = message;
      return std::unique_ptr<LinearFeaturesModel>();
    };
    const std::vector<std::string>& states = params.bank_states();
    const std::vector<std::string>& inputs = params.bank_inputs();
    if (states.empty()) {
      return fail(
          "linear_features takes its states and inputs from the bank (its 'states:' and 'inputs:'), but none were "
          "given: create it from a bank file");
    }
    const int n = static_cast<int>(states.size());
    const int m = static_cast<int>(inputs.size());
    if (n > kMaxStates) {
      return fail("linear_features supports at most " + std::to_string(kMaxStates) + " states, the bank has " +
                  std::to_string(n) + " (" + join(states) + ")");
    }
    if (m > kMaxInputs) {
      return fail("linear_features supports at most " + std::to_string(kMaxInputs) + " inputs, the bank has " +
                  std::to_string(m) + " (" + join(inputs) + ")");
    }
    std::vector<bool> angles = params.bank_angles();
    if (angles.empty()) angles.assign(states.size(), false);
    if (angles.size() != states.size()) return fail("the bank's angle flags do not match its states");
    if (!params.check_only({"A", "B", "c", "fixed"}, error)) return nullptr;
    bool fixed[3] = {false, false, false};  // A, B, c
    if (params.contains("fixed")) {
      const std::vector<std::string>* keys = params.find_text("fixed");
      if (keys == nullptr) return fail("parameter 'fixed' must be a list of keys among A, B, c");
      for (const std::string& key : *keys) {
        if (key == "A") {
          fixed[0] = true;
        } else if (key == "B") {
          fixed[1] = true;
        } else if (key == "c") {
          fixed[2] = true;
        } else {
          return fail("parameter 'fixed': '" + key + "' is not a key of linear_features (A, B, c)");
        }
      }
      if (fixed[2] && !params.contains("c")) return fail("parameter 'fixed' names c, but the bank gives no c");
    }

    // Shapes in the bank's own terms, for the messages below.
    const std::string b_shape =
        std::to_string(n) + "x" + std::to_string(m) + " (states " + join(states) + " x inputs " + join(inputs) + ")";
    const std::string a_shape = n == 1 ? "a number (state " + states[0] + ")"
                                       : "a " + std::to_string(n) + "x" + std::to_string(n) +
                                             " matrix for a full A, or a list of " + std::to_string(n) +
                                             " numbers for a diagonal A (states " + join(states) + ")";
    const std::string c_shape =
        n == 1 ? "a number (state " + states[0] + ")"
               : "a list of " + std::to_string(n) + " numbers, one per state (" + join(states) + ")";

    // A: its shape chooses the form. With one state both forms coincide; it is diagonal.
    const Eigen::MatrixXd* a = params.find("A");
    if (a == nullptr) {
      return fail(params.contains("A") ? "parameter 'A' must be numbers, not text; expected " + a_shape
                                       : "missing parameter 'A': expected " + a_shape);
    }
    StateMatrixForm form;
    if (a->rows() == n && a->cols() == 1) {
      form = StateMatrixForm::kDiagonal;
    } else if (a->rows() == n && a->cols() == n) {
      form = StateMatrixForm::kFull;
    } else {
      return fail("parameter 'A' must be " + a_shape + ", got " + shape(*a));
    }

    // B: n x m; a bank without inputs has no B.
    const Eigen::MatrixXd* b = params.find("B");
    if (m == 0) {
      if (params.contains("B")) return fail("the bank has no inputs, so linear_features takes no 'B'");
    } else if (b == nullptr) {
      return fail(params.contains("B") ? "parameter 'B' must be numbers, not text; expected " + b_shape
                                       : "missing parameter 'B': expected " + b_shape);
    } else if (b->rows() != n || b->cols() != m) {
      return fail("parameter 'B' must be " + b_shape + ", got " + shape(*b));
    }

    // c: optional n-vector.
    const Eigen::MatrixXd* c = params.find("c");
    if (c == nullptr && params.contains("c")) {
      return fail("parameter 'c' must be numbers, not text; expected " + c_shape);
    }
    if (c != nullptr && (c->rows() != n || c->cols() != 1)) {
      return fail("parameter 'c' must be " + c_shape + ", got " + shape(*c));
    }

    // Finiteness, through the flat view of every entry so the message names
    // it ("parameter 'B[1,0]' is not finite"), fixed or not.
    std::unique_ptr<LinearFeaturesModel> all(new LinearFeaturesModel(states, angles, inputs, form, *a, b, c, {}));
    Eigen::VectorXd values(static_cast<Eigen::Index>(all->parameter_info_.size()));
    all->get_parameters(values);
    if (!sdk::check_parameter_values(all->parameter_info_, values, error)) return nullptr;
    return std::unique_ptr<LinearFeaturesModel>(
        new LinearFeaturesModel(states, angles, inputs, form, *a, b, c, {fixed[0], fixed[1], fixed[2]}));
  }

  int state_dim() const noexcept override { return n_; }
  int input_dim() const noexcept override { return m_; }
  const std::vector<std::string>& state_names() const noexcept override { return state_names_; }
  const std::vector<std::string>& input_names() const noexcept override { return input_names_; }
  bool is_angle(int state_index) const noexcept override {
    return state_index >= 0 && state_index < n_ && angles_[static_cast<std::size_t>(state_index)];
  }

  StateMatrixForm state_matrix_form() const noexcept { return form_; }
  bool has_offset() const noexcept { return has_offset_; }

  const std::vector<sdk::ParameterInfo>& parameter_info() const noexcept override { return parameter_info_; }

  void get_parameters(Eigen::Ref<Eigen::VectorXd> values) const noexcept override {
    Eigen::Index at = 0;
    if (!fixed_.a) {
      if (form_ == StateMatrixForm::kDiagonal) {
        for (int i = 0; i < n_; ++i) values[at++] = a_diagonal_[i];
      } else {
        for (int r = 0; r < n_; ++r) {
          for (int c = 0; c < n_; ++c) values[at++] = a_(r, c);
        }
      }
    }
    if (!fixed_.b) {
      for (int r = 0; r < n_; ++r) {
        for (int c = 0; c < m_; ++c) values[at++] = b_(r, c);
      }
    }
    if (has_offset_ && !fixed_.c) {
      for (int i = 0; i < n_; ++i) values[at++] = c_[i];
    }
  }

  bool set_parameters(const Eigen::Ref<const Eigen::VectorXd>& values, std::string* error) noexcept override {
    if (!sdk::check_parameter_values(parameter_info_, values, error)) return false;
    Eigen::Index at = 0;
    if (!fixed_.a) {
      if (form_ == StateMatrixForm::kDiagonal) {
        for (int i = 0; i < n_; ++i) a_diagonal_[i] = values[at++];
      } else {
        for (int r = 0; r < n_; ++r) {
          for (int c = 0; c < n_; ++c) a_(r, c) = values[at++];
        }
      }
    }
    if (!fixed_.b) {
      for (int r = 0; r < n_; ++r) {
        for (int c = 0; c < m_; ++c) b_(r, c) = values[at++];
      }
    }
    if (has_offset_ && !fixed_.c) {
      for (int i = 0; i < n_; ++i) c_[i] = values[at++];
    }
    return true;
  }

  bool predict(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
               Eigen::Ref<Eigen::VectorXd> x_next) const noexcept override {
    if (!valid_step(x, u, dt) || x_next.size() != n_) return false;
    if (dt == 0.0) {  // exactly the identity, as the contract asks
      x_next = x;
      return true;
    }
    const Vector w = drive(u);
    Vector next(n_);
    if (form_ == StateMatrixForm::kDiagonal) {
      for (int i = 0; i < n_; ++i) {
        next[i] = diagonal_zoh_step(x[i], a_diagonal_[i], w[i], dt);
      }
    } else if (!zoh_step(a_, Vector(x), w, dt, &next)) {
      return false;
    }
    for (int i = 0; i < n_; ++i) {
      x_next[i] = angles_[static_cast<std::size_t>(i)] ? sdk::wrap_angle(next[i]) : next[i];
    }
    return x_next.allFinite();
  }

  // F = Phi = expm(A dt): predict() is affine in x.
  bool jacobian(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
                Eigen::Ref<Eigen::MatrixXd> jacobian) const noexcept override {
    if (!valid_step(x, u, dt) || jacobian.rows() != n_ || jacobian.cols() != n_) return false;
    if (dt == 0.0) {
      jacobian.setIdentity();
      return true;
    }
    if (form_ == StateMatrixForm::kDiagonal) {
      jacobian.setZero();
      for (int i = 0; i < n_; ++i) jacobian(i, i) = std::exp(a_diagonal_[i] * dt);
      return jacobian.allFinite();
    }
    Matrix phi;
    if (!zoh_transition(a_, dt, &phi)) return false;
    jacobian = phi;
    return true;
  }
  bool has_analytic_jacobian() const noexcept override { return true; }

  // Qd = int_0^dt expm(A s) Q expm(A s)' ds (see the header comment).
  // Diagonal A: Qd_ij = Q_ij (e^{(a_i + a_j) dt} - 1) / (a_i + a_j).
  bool process_noise(const Eigen::Ref<const Eigen::MatrixXd>& intensity, const Eigen::Ref<const Eigen::VectorXd>& x,
                     const Eigen::Ref<const Eigen::VectorXd>& u, double dt,
                     Eigen::Ref<Eigen::MatrixXd> noise) const noexcept override {
    if (!valid_step(x, u, dt) || intensity.rows() != n_ || intensity.cols() != n_ || noise.rows() != n_ ||
        noise.cols() != n_) {
      return false;
    }
    if (form_ == StateMatrixForm::kDiagonal) {
      // Banks usually give every feature the same rate (a held-fixed A), so
      // most pairs share a_i + a_j: its integral is computed once per run of
      // equal sums instead of n (n + 1) / 2 times (expm1 was 8% of
      // `skidimm tune`'s profile). Same arguments, same values.
      double last_sum = std::numeric_limits<double>::quiet_NaN();
      double last_integral = 0.0;
      for (int i = 0; i < n_; ++i) {
        for (int j = 0; j <= i; ++j) {
          const double sum = a_diagonal_[i] + a_diagonal_[j];
          if (!(sum == last_sum)) {
            last_sum = sum;
            last_integral = exp_integral(sum, dt);
          }
          const double q = 0.5 * (intensity(i, j) + intensity(j, i));
          noise(i, j) = noise(j, i) = q * last_integral;
        }
      }
      return noise.allFinite();
    }
    Matrix qd;
    if (!zoh_process_noise(a_, Matrix(intensity), dt, &qd)) return false;
    noise = qd;
    return true;
  }

  // d x+ / d [A, B, c] in the flat order of parameter_info(), exactly:
  //   d x+ / d B(r, j) = Gamma(:, r) u_j,   d x+ / d c(r) = Gamma(:, r),
  //   diagonal A: d x+_i / d a_i = dt e^{a_i dt} x_i + (int_0^dt s e^{a_i s} ds) w_i,
  //   full A: zoh_step_derivatives() (Fréchet derivatives of expm).
  bool parameter_jacobian(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u,
                          double dt, Eigen::Ref<Eigen::MatrixXd> jacobian) const noexcept override {
    const Eigen::Index num_parameters = static_cast<Eigen::Index>(parameter_info_.size());
    if (!valid_step(x, u, dt) || jacobian.rows() != n_ || jacobian.cols() != num_parameters) return false;
    jacobian.setZero();
    if (dt == 0.0) return true;  // x+ = x whatever the parameters
    const Vector w = drive(u);
    // The blocks of the fitted keys, in order (fixed ones take no columns).
    const Eigen::Index a_count = fixed_.a ? 0 : num_a_parameters();
    const Eigen::Index b_offset = a_count;
    const Eigen::Index c_offset = b_offset + (fixed_.b ? 0 : n_ * m_);
    Matrix gamma = Matrix::Zero(n_, n_);
    if (form_ == StateMatrixForm::kDiagonal) {
      for (int i = 0; i < n_; ++i) {
        const double a = a_diagonal_[i];
        if (!fixed_.a) jacobian(i, i) = dt * std::exp(a * dt) * x[i] + exp_integral_derivative(a, dt) * w[i];
        gamma(i, i) = exp_integral(a, dt);
      }
    } else if (!fixed_.a) {
      if (!zoh_step_derivatives(a_, Vector(x), w, dt, jacobian.leftCols(n_ * n_), &gamma)) return false;
    } else if (!zoh_gamma(a_, dt, &gamma)) {
      return false;
    }
    for (int r = 0; r < n_; ++r) {
      if (!fixed_.b) {
        for (int j = 0; j < m_; ++j) jacobian.col(b_offset + r * m_ + j) = gamma.col(r) * u[j];
      }
      if (has_offset_ && !fixed_.c) jacobian.col(c_offset + r) = gamma.col(r);
    }
    return jacobian.allFinite();
  }

 private:
  // Keys held at their given values (`fixed:`), not parameters.
  struct Fixed {
    bool a = false, b = false, c = false;
  };

  // `b` may be null only without inputs, `c` when the bank gives no c.
  LinearFeaturesModel(std::vector<std::string> states, std::vector<bool> angles, std::vector<std::string> inputs,
                      StateMatrixForm form, const Eigen::MatrixXd& a, const Eigen::MatrixXd* b,
                      const Eigen::MatrixXd* c, Fixed fixed)
      : n_(static_cast<int>(states.size())),
        m_(static_cast<int>(inputs.size())),
        form_(form),
        has_offset_(c != nullptr),
        fixed_(fixed),
        a_(Matrix::Zero(n_, n_)),
        a_diagonal_(Vector::Zero(n_)),
        b_(InputMatrix::Zero(n_, m_)),
        c_(Vector::Zero(n_)),
        state_names_(std::move(states)),
        input_names_(std::move(inputs)),
        angles_(std::move(angles)) {
    if (form_ == StateMatrixForm::kDiagonal) {
      a_diagonal_ = a.col(0);
    } else {
      a_ = a;
    }
    if (b != nullptr && m_ > 0) b_ = *b;
    if (c != nullptr) c_ = c->col(0);
    const std::vector<std::string>& s = state_names_;
    if (fixed_.a) {
      // held at its given values: no parameters
    } else if (form_ == StateMatrixForm::kDiagonal) {
      for (int i = 0; i < n_; ++i) {
        add_parameter(
            "A[" + std::to_string(i) + "]", "A",
            "rate of " + s[i] + ": d(" + s[i] + ")/dt per unit of " + s[i] + " (1/s; -1/A is a time constant)");
      }
    } else {
      for (int r = 0; r < n_; ++r) {
        for (int col = 0; col < n_; ++col) {
          add_parameter(index_name("A", r, col), "A", "d(" + s[r] + ")/dt per unit of " + s[col]);
        }
      }
    }
    for (int r = 0; r < n_ && !fixed_.b; ++r) {
      for (int col = 0; col < m_; ++col) {
        add_parameter(index_name("B", r, col), "B", "d(" + s[r] + ")/dt per unit of input " + input_names_[col]);
      }
    }
    if (has_offset_ && !fixed_.c) {
      for (int i = 0; i < n_; ++i) {
        add_parameter("c[" + std::to_string(i) + "]", "c",
                      "constant term of d(" + s[i] + ")/dt (units of " + s[i] + " per s)");
      }
    }
  }

  static std::string join(const std::vector<std::string>& names) {
    std::string out;
    for (const std::string& name : names) out += (out.empty() ? "" : ", ") + name;
    return out;
  }
  static std::string shape(const Eigen::MatrixXd& m) {
    return std::to_string(m.rows()) + "x" + std::to_string(m.cols());
  }
  static std::string index_name(const char* key, int r, int c) {
    return std::string(key) + "[" + std::to_string(r) + "," + std::to_string(c) + "]";
  }

  void add_parameter(std::string name, const char* key, std::string description) {
    sdk::ParameterInfo info;
    info.name = std::move(name);
    info.key = key;
    info.description = std::move(description);
    parameter_info_.push_back(std::move(info));
  }

  Eigen::Index num_a_parameters() const noexcept { return form_ == StateMatrixForm::kDiagonal ? n_ : n_ * n_; }

  bool valid_step(const Eigen::Ref<const Eigen::VectorXd>& x, const Eigen::Ref<const Eigen::VectorXd>& u,
                  double dt) const noexcept {
    return x.size() == n_ && u.size() == m_ && dt >= 0.0 && std::isfinite(dt);
  }

  // w = B u + c, the constant forcing over the step.
  Vector drive(const Eigen::Ref<const Eigen::VectorXd>& u) const noexcept {
    Vector w = c_;
    if (m_ > 0) w.noalias() += b_ * u;
    return w;
  }

  int n_;
  int m_;
  StateMatrixForm form_;
  bool has_offset_;
  Fixed fixed_;
  Matrix a_;           // full form
  Vector a_diagonal_;  // diagonal form
  InputMatrix b_;
  Vector c_;  // zero when the bank gives no c
  std::vector<std::string> state_names_;
  std::vector<std::string> input_names_;
  std::vector<bool> angles_;
  std::vector<sdk::ParameterInfo> parameter_info_;
};

}  // namespace plugins
}  // namespace skidimm

#endif  // SKIDIMM_PLUGINS_LINEAR_FEATURES_LINEAR_FEATURES_MODEL_H_
