// LinearFeatures: the spec of `linear_features`, a motion model defined by
// the bank file alone (docs/bank-format.md, "A model from YAML alone"),
// written in the one-function form with its shapes from the bank
// (skidimm/sdk/function_model.h, bank_layout.h). In a header so tests can
// run it in-process as LinearFeaturesModel; the plugin .cc only exports it.
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
//
// The functions below see p as every entry the bank gives, A, B, then c,
// each row-major, fixed keys included (the SDK leaves those out of the
// model's parameters); the Layout says A's form (a list: diagonal), whether
// there is a c and which keys are fixed.
#ifndef SKIDIMM_PLUGINS_LINEAR_FEATURES_LINEAR_FEATURES_MODEL_H_
#define SKIDIMM_PLUGINS_LINEAR_FEATURES_LINEAR_FEATURES_MODEL_H_

#include <Eigen/Core>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "linear_features/zero_order_hold.h"
#include "skidimm/sdk/function_model.h"

namespace skidimm {
namespace plugins {

struct LinearFeatures {
  static constexpr const char* kName = "linear_features";
  static constexpr const char* kVersion = "1.1.0";
  static constexpr const char* kDescription =
      "Linear model dx/dt = A x + B u + c over the bank's own states and inputs, exact zero-order-hold step";
  static constexpr int kMaxStates = kMaxZohStates;
  static constexpr int kMaxInputs = 16;
  static constexpr int kMaxParameters = kMaxStates * (kMaxStates + kMaxInputs + 1);
  static constexpr sdk::ParameterSpec kParameters[] = {
      {"A", "state matrix (1/s): a matrix (full A) or a list (its diagonal); n = bank states",
       sdk::BankShape{"n x n or n"}},
      {"B", "input matrix: one row per bank state, one column per bank input", sdk::BankShape{"n x m"}},
      {"c", "constant term of dx/dt; absent: zero and not fitted", sdk::BankShape{"n, optional"}},
      {"fixed", "keys among A, B, c held at their given values and not fitted, e.g. [A]",
       sdk::TextList{"text list, optional"}},
  };
  enum Row { kA, kB, kC, kFixed };

  using Vector = ZohVector;
  using Matrix = ZohMatrix;
  using InputMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxStates, kMaxInputs>;
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

  // A's form from its shape, B and c against the bank's names, `fixed:`.
  static bool layout(const sdk::ParameterSet& params, sdk::Layout* layout, std::string* error) {
    auto fail = [error](const std::string& message) {
      if (error != nullptr) *error = message;
      return false;
    };
    const std::vector<std::string>& states = layout->states;
    const int n = layout->num_states();
    const int m = layout->num_inputs();
    sdk::ParameterLayout& a_row = (*layout)[kA];
    sdk::ParameterLayout& b_row = (*layout)[kB];
    sdk::ParameterLayout& c_row = (*layout)[kC];
    if (params.contains("fixed")) {
      const std::vector<std::string>* keys = params.find_text("fixed");
      if (keys == nullptr) return fail("parameter 'fixed' must be a list of keys among A, B, c");
      for (const std::string& key : *keys) {
        if (key == "A") {
          a_row.fixed = true;
        } else if (key == "B") {
          b_row.fixed = true;
        } else if (key == "c") {
          c_row.fixed = true;
        } else {
          return fail("parameter 'fixed': '" + key + "' is not a key of linear_features (A, B, c)");
        }
      }
      if (c_row.fixed && !params.contains("c")) return fail("parameter 'fixed' names c, but the bank gives no c");
    }

    // Shapes in the bank's own terms, for the messages below.
    const std::string b_shape = std::to_string(n) + "x" + std::to_string(m) + " (states " + join(states) +
                                " x inputs " + join(layout->inputs) + ")";
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
    if (a->rows() == n && a->cols() == 1) {
      a_row.shape = sdk::Shape{n, 1};
      a_row.is_list = true;
      for (const std::string& s : states) {
        a_row.descriptions.push_back("rate of " + s + ": d(" + s + ")/dt per unit of " + s +
                                     " (1/s; -1/A is a time constant)");
      }
    } else if (a->rows() == n && a->cols() == n) {
      a_row.shape = sdk::Shape{n, n};
      for (int r = 0; r < n; ++r) {
        for (int c = 0; c < n; ++c) a_row.descriptions.push_back("d(" + states[r] + ")/dt per unit of " + states[c]);
      }
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
    } else {
      b_row.shape = sdk::Shape{n, m};
      for (int r = 0; r < n; ++r) {
        for (int j = 0; j < m; ++j) {
          b_row.descriptions.push_back("d(" + states[r] + ")/dt per unit of input " + layout->inputs[j]);
        }
      }
    }

    // c: optional n-vector.
    const Eigen::MatrixXd* c = params.find("c");
    if (c == nullptr && params.contains("c")) {
      return fail("parameter 'c' must be numbers, not text; expected " + c_shape);
    }
    if (c != nullptr) {
      if (c->rows() != n || c->cols() != 1) return fail("parameter 'c' must be " + c_shape + ", got " + shape(*c));
      c_row.shape = sdk::Shape{n, 1};
      c_row.is_list = true;
      for (const std::string& s : states) {
        c_row.descriptions.push_back("constant term of d(" + s + ")/dt (units of " + s + " per s)");
      }
    }
    return true;
  }

  // x+ = Phi x + Gamma (B u + c); the identity at dt = 0, as the contract asks.
  static void predict(const sdk::Layout& layout, const double* x, const double* u, const double* p, double dt,
                      double* x_next) {
    const int n = layout.num_states();
    if (dt == 0.0) {
      for (int i = 0; i < n; ++i) x_next[i] = x[i];
      return;
    }
    const Vector w = drive(layout, u, p);
    if (is_diagonal(layout)) {
      const double* a = p + layout[kA].offset;
      RowsZoh zoh(dt);
      for (int i = 0; i < n; ++i) x_next[i] = zoh(a[i]).template step<double>(x[i], w[i]);
      return;
    }
    Vector next(n);
    if (!zoh_step(full_a(layout, p), Eigen::Map<const Vector>(x, n), w, dt, &next)) next.setConstant(kNotANumber);
    Eigen::Map<Vector>(x_next, n) = next;
  }

  // F and Qd below depend on A and dt alone: the engine computes them once
  // per mode and dt, not at every step.
  static constexpr bool kJacobianAndNoiseDependOnlyOnDt = true;

  // F = Phi = expm(A dt): predict() is affine in x.
  static void jacobian(const sdk::Layout& layout, const double* /*x*/, const double* /*u*/, const double* p, double dt,
                       double* jacobian) {
    const int n = layout.num_states();
    Eigen::Map<RowMajor> f(jacobian, n, n);
    if (dt == 0.0) {
      f.setIdentity();
    } else if (is_diagonal(layout)) {
      const double* a = p + layout[kA].offset;
      f.setZero();
      SameArgumentOnce phi([dt](double rate) { return std::exp(rate * dt); });
      for (int i = 0; i < n; ++i) f(i, i) = phi(a[i]);
    } else {
      Matrix phi;
      if (!zoh_transition(full_a(layout, p), dt, &phi)) phi.setConstant(n, n, kNotANumber);
      f = phi;
    }
  }

  // Qd = int_0^dt expm(A s) Q expm(A s)' ds (see the header comment).
  // Diagonal A: Qd_ij = Q_ij (e^{(a_i + a_j) dt} - 1) / (a_i + a_j).
  static void process_noise(const sdk::Layout& layout, const double* intensity, const double* /*x*/,
                            const double* /*u*/, const double* p, double dt, double* noise) {
    const int n = layout.num_states();
    const Eigen::Map<const RowMajor> q(intensity, n, n);
    Eigen::Map<RowMajor> qd(noise, n, n);
    if (is_diagonal(layout)) {
      const double* a = p + layout[kA].offset;
      // The integral of e^{(a_i + a_j) s}, once per run of equal sums.
      SameArgumentOnce integral([dt](double sum) { return exp_integral(sum, dt); });
      for (int i = 0; i < n; ++i) {
        for (int j = 0; j <= i; ++j) qd(i, j) = qd(j, i) = 0.5 * (q(i, j) + q(j, i)) * integral(a[i] + a[j]);
      }
      return;
    }
    Matrix discrete;
    if (!zoh_process_noise(full_a(layout, p), Matrix(q), dt, &discrete)) discrete.setConstant(n, n, kNotANumber);
    qd = discrete;
  }

  // Which states entry `entry` of p can move: with a diagonal A, each row's
  // parameters (a_r, B(r, :), c_r) move state r alone; with a full A, any.
  static bool parameter_jacobian_may_move(const sdk::Layout& layout, int entry, int row) {
    if (!is_diagonal(layout)) return true;
    const int m = layout.num_inputs();
    for (const int key : {kA, kB, kC}) {
      const sdk::ParameterLayout& keyed = layout[key];
      if (entry < keyed.offset || entry >= keyed.offset + keyed.size()) continue;
      const int at = entry - keyed.offset;
      return row == (key == kB ? at / m : at);  // B is row-major, n x m
    }
    return true;
  }

  // d x+ / d [A, B, c], every entry of p (the SDK drops the fixed keys'
  // columns, so theirs are skipped; it hands `jacobian` over zeroed, so only
  // the entries that can be nonzero are written), exactly:
  //   d x+ / d B(r, j) = Gamma(:, r) u_j,   d x+ / d c(r) = Gamma(:, r),
  //   diagonal A: d x+_i / d a_i = dt e^{a_i dt} x_i + (int_0^dt s e^{a_i s} ds) w_i,
  //   full A: zoh_step_derivatives() (Fréchet derivatives of expm).
  static void parameter_jacobian(const sdk::Layout& layout, const double* x, const double* u, const double* p,
                                 double dt, double* jacobian) {
    const int n = layout.num_states();
    const int m = layout.num_inputs();
    Eigen::Map<RowMajor> d(jacobian, n, layout.num_entries());
    if (dt == 0.0) return;  // x+ = x whatever the parameters
    const sdk::ParameterLayout &a_row = layout[kA], &b_row = layout[kB], &c_row = layout[kC];
    // The forcing enters only the derivatives in A: none when A is held.
    const Vector w = a_row.fixed ? Vector() : drive(layout, u, p);
    if (is_diagonal(layout)) {
      // Each parameter of row r moves state r alone: d x+_r / d B(r, j) =
      // gamma_r u_j and d x+_r / d c(r) = gamma_r are written straight into
      // row r, and the rest are the zeros d holds. (A filter with parameter
      // uncertainty asks for this at every step.)
      const double* a = p + a_row.offset;
      RowsZoh zoh(dt);
      for (int r = 0; r < n; ++r) {
        const double gamma = zoh(a[r]).gamma;
        if (!a_row.fixed) {
          d(r, a_row.offset + r) = dt * std::exp(a[r] * dt) * x[r] + exp_integral_derivative(a[r], dt) * w[r];
        }
        if (b_row.present() && !b_row.fixed) {
          for (int j = 0; j < m; ++j) d(r, b_row.offset + r * m + j) = gamma * u[j];
        }
        if (c_row.present() && !c_row.fixed) d(r, c_row.offset + r) = gamma;
      }
      return;
    }
    Matrix gamma = Matrix::Zero(n, n);
    bool evaluated = true;
    if (!a_row.fixed) {
      Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxStates, kMaxStates * kMaxStates> d_a(n, n * n);
      evaluated = zoh_step_derivatives(full_a(layout, p), Eigen::Map<const Vector>(x, n), w, dt, d_a, &gamma);
      d.middleCols(a_row.offset, n * n) = d_a;
    } else {
      evaluated = zoh_gamma(full_a(layout, p), dt, &gamma);
    }
    if (!evaluated) {
      d.setConstant(kNotANumber);
      return;
    }
    for (int r = 0; r < n; ++r) {
      if (b_row.present() && !b_row.fixed) {
        for (int j = 0; j < m; ++j) d.col(b_row.offset + r * m + j) = gamma.col(r) * u[j];
      }
      if (c_row.present() && !c_row.fixed) d.col(c_row.offset + r) = gamma.col(r);
    }
  }

 private:
  static constexpr double kNotANumber = std::numeric_limits<double>::quiet_NaN();

  static bool is_diagonal(const sdk::Layout& layout) { return layout[kA].is_list; }

  static Matrix full_a(const sdk::Layout& layout, const double* p) {
    const int n = layout.num_states();
    return Eigen::Map<const RowMajor>(p + layout[kA].offset, n, n);
  }

  // w = B u + c, the constant forcing over the step.
  static Vector drive(const sdk::Layout& layout, const double* u, const double* p) {
    const int n = layout.num_states();
    const int m = layout.num_inputs();
    Vector w = Vector::Zero(n);
    if (layout[kC].present()) w = Eigen::Map<const Vector>(p + layout[kC].offset, n);
    if (m > 0) {
      const InputMatrix b = Eigen::Map<const RowMajor>(p + layout[kB].offset, n, m);
      w.noalias() += b * Eigen::Map<const Eigen::VectorXd>(u, m);
    }
    return w;
  }

  static std::string join(const std::vector<std::string>& names) {
    std::string out;
    for (const std::string& name : names) out += (out.empty() ? "" : ", ") + name;
    return out;
  }
  static std::string shape(const Eigen::MatrixXd& m) {
    return std::to_string(m.rows()) + "x" + std::to_string(m.cols());
  }
};

// The generated plugin class, for tests that create it in-process.
using LinearFeaturesModel = sdk::FunctionModel<LinearFeatures>;

}  // namespace plugins
}  // namespace skidimm

#endif  // SKIDIMM_PLUGINS_LINEAR_FEATURES_LINEAR_FEATURES_MODEL_H_
