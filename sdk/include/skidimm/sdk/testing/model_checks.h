// The checks of the conformance kit, without GoogleTest: what conformance.h
// asserts in a plugin author's tests, and what `skidimm validate --check LOG`
// runs on each mode of a bank at operating points taken from a log.
//
// motion_model_failures(model, x, u, dt) lists every way the model breaks the
// contract of motion_model.h at one operating point (empty: none):
//  * dimensions and names agree and names are unique and non-empty;
//  * predict(x, u, 0) == x and jacobian(x, u, 0) == I;
//  * predict(x, u, dt) is finite, with angle components in [-pi, pi);
//  * the parameters round-trip through get/set, with unique names, valid
//    bounds and current values inside them;
//  * process_noise(I, x, u, dt) is finite, symmetric positive semidefinite;
//  * predict() right after jacobian() at the same point gives the same state;
//  * a model whose Jacobian and process noise depend on dt only (its
//    jacobian_and_noise_depend_only_on_dt()) gives the same ones at another
//    state and input;
//  * the Jacobian is finite and matches central differences of predict(),
//    and so does the parameter Jacobian if the model provides one;
//  * outputs, if the model has any, are uniquely named and finite, and their
//    parameter Jacobian, if provided, matches central differences.
// A call that fails is reported with the reason the model gave
// (failure_reason(), failure.h); a non-finite or wrong entry is named by row
// and column. The model is left with the parameters it had.
#ifndef SKIDIMM_SDK_TESTING_MODEL_CHECKS_H_
#define SKIDIMM_SDK_TESTING_MODEL_CHECKS_H_

#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "skidimm/sdk/angles.h"
#include "skidimm/sdk/motion_model.h"
#include "skidimm/sdk/numeric_jacobian.h"
#include "skidimm/sdk/parameter_jacobian_rows.h"

namespace skidimm {
namespace sdk {
namespace testing {

struct ConformanceOptions {
  double identity_tolerance = 1e-12;  // predict(x, u, 0) vs x, relative to max(1, |x|)
  double jacobian_tolerance = 1e-6;   // analytic vs numeric, relative to max(1, |J|)
};

namespace internal {

inline std::string vector_text(const Eigen::VectorXd& v) {
  std::ostringstream out;
  out.precision(6);
  out << "[";
  for (Eigen::Index i = 0; i < v.size(); ++i) out << (i ? ", " : "") << v[i];
  out << "]";
  return out.str();
}

inline std::string point_text(const Eigen::VectorXd& x, const Eigen::VectorXd& u, double dt) {
  std::ostringstream out;
  out << "x = " << vector_text(x) << ", u = " << vector_text(u) << ", dt = " << dt;
  return out.str();
}

// `what` failed, with the reason the model gave, if any.
inline std::string failed(const MotionModel& model, const std::string& what) {
  const char* reason = model.failure_reason();
  return what + " failed" + (reason != nullptr && reason[0] != '\0' ? ": " + std::string(reason) : std::string());
}

inline std::string name_of(const std::vector<std::string>& names, Eigen::Index i) {
  return i < static_cast<Eigen::Index>(names.size()) ? names[static_cast<std::size_t>(i)] : "?";
}

// The first entry of m that is not finite, named by row and column; "" if none.
inline std::string first_non_finite(const Eigen::MatrixXd& m, const std::vector<std::string>& row_names,
                                    const std::vector<std::string>& column_names) {
  for (Eigen::Index r = 0; r < m.rows(); ++r) {
    for (Eigen::Index c = 0; c < m.cols(); ++c) {
      if (std::isfinite(m(r, c))) continue;
      std::ostringstream out;
      out << "entry (row " << r << " '" << name_of(row_names, r) << "', column " << c << " '"
          << name_of(column_names, c) << "') = " << m(r, c);
      return out.str();
    }
  }
  return "";
}

// Central differences over set_parameters() of evaluate(out), a function of
// `rows` values (predict() or outputs()), into *numeric (rows x parameters);
// rows where is_angle(i) are differenced modulo 2 pi. The model gets
// `values` back. False if a perturbed evaluation fails.
template <typename Evaluate, typename IsAngle>
bool numeric_parameter_jacobian(MotionModel& model, const Eigen::VectorXd& values, Eigen::Index rows,
                                const Evaluate& evaluate, const IsAngle& is_angle, Eigen::MatrixXd* numeric) {
  Eigen::VectorXd plus(rows), minus(rows), perturbed = values;
  bool evaluated = true;
  for (Eigen::Index j = 0; j < values.size() && evaluated; ++j) {
    const double h = central_difference_step(values[j]);
    perturbed[j] = values[j] + h;
    evaluated = model.set_parameters(perturbed, nullptr) && evaluate(plus);
    perturbed[j] = values[j] - h;
    evaluated = evaluated && model.set_parameters(perturbed, nullptr) && evaluate(minus);
    perturbed[j] = values[j];
    for (Eigen::Index i = 0; i < rows; ++i) {
      double difference = plus[i] - minus[i];
      if (is_angle(i)) difference = wrap_angle(difference);
      (*numeric)(i, j) = difference / (2.0 * h);
    }
  }
  model.set_parameters(values, nullptr);
  return evaluated;
}

// Where `analytic` and `numeric` (central differences of `value`, stepping
// the arguments `at`) disagree, and whether rounding can explain it.
struct Comparison {
  Eigen::MatrixXd analytic, numeric;
  Eigen::VectorXd value, at;
  double tolerance = 0.0;  // allowed |analytic - numeric|, already scaled
  // An entry's rounding: up to eps |value_i| / h_j (central_difference_step).
  double rounding(int r, int c) const {
    return std::numeric_limits<double>::epsilon() * std::abs(value[r]) / central_difference_step(at[c]);
  }
  double difference(int r, int c) const { return std::abs(analytic(r, c) - numeric(r, c)); }
  // Beyond the tolerance; unresolved if within it plus the entry's
  // rounding (a value too large for differences to check), else wrong.
  bool differs(int r, int c) const { return !(difference(r, c) <= tolerance); }
  bool unresolved(int r, int c) const { return difference(r, c) <= tolerance + rounding(r, c); }
};

// The entries that differ and are `unresolved` (or not), worst first (at
// most five), each named by row and column with both values.
inline std::string listed_entries(const Comparison& cmp, bool unresolved, const std::vector<std::string>& row_names,
                                  const std::vector<std::string>& column_names) {
  std::vector<std::pair<double, std::pair<int, int>>> entries;
  for (int r = 0; r < cmp.analytic.rows(); ++r) {
    for (int c = 0; c < cmp.analytic.cols(); ++c) {
      if (!cmp.differs(r, c) || cmp.unresolved(r, c) != unresolved) continue;
      const double difference = cmp.difference(r, c);
      entries.push_back({std::isnan(difference) ? HUGE_VAL : difference, {r, c}});
    }
  }
  std::sort(entries.begin(), entries.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  std::ostringstream out;
  out.precision(10);
  for (std::size_t k = 0; k < entries.size() && k < 5; ++k) {
    const int r = entries[k].second.first, c = entries[k].second.second;
    out << "\n    entry (row " << r << " '" << name_of(row_names, r) << "', column " << c << " '"
        << name_of(column_names, c) << "'): analytic " << cmp.analytic(r, c) << ", numeric " << cmp.numeric(r, c);
    if (unresolved) out << ", rounding up to " << cmp.rounding(r, c);
  }
  if (entries.size() > 5) out << "\n    and " << entries.size() - 5 << " more entries";
  return out.str();
}

// The entries of `analytic` that differ from `numeric` by more than
// `tolerance`, worst first (at most five), each named by row and column:
// two derivatives compared exactly (no rounding of differences).
inline std::string differing_entries(const Eigen::MatrixXd& analytic, const Eigen::MatrixXd& numeric, double tolerance,
                                     const std::vector<std::string>& row_names,
                                     const std::vector<std::string>& column_names) {
  const Comparison exact{analytic, numeric, Eigen::VectorXd::Zero(analytic.rows()),
                         Eigen::VectorXd::Zero(analytic.cols()), tolerance};
  return listed_entries(exact, false, row_names, column_names);
}

// "what differs from central differences by E at <point><entries>" for the
// entries rounding cannot explain; else, for entries it can, "what cannot be
// checked at <point>: ..." with why(row) of the largest one's row (what
// makes that row's value large); "" when every entry is within tolerance.
// A wrong entry is reported whatever the size of the others.
template <typename Why>
std::string compare_with_differences(const std::string& what, const Eigen::MatrixXd& reported,
                                     const Eigen::MatrixXd& numeric, const Eigen::VectorXd& value,
                                     const Eigen::VectorXd& at, double tolerance, const std::string& point,
                                     const std::vector<std::string>& row_names,
                                     const std::vector<std::string>& column_names, const Why& why) {
  const double scale = std::max(1.0, numeric.cwiseAbs().maxCoeff());
  const Comparison cmp{reported, numeric, value, at, tolerance * scale};
  bool wrong = false, unresolved = false;
  int worst_row = -1;
  double worst_rounding = 0.0, worst_difference = 0.0;  // of the wrong entries alone
  for (int r = 0; r < reported.rows(); ++r) {
    for (int c = 0; c < reported.cols(); ++c) {
      if (!cmp.differs(r, c)) continue;
      if (!cmp.unresolved(r, c)) {
        wrong = true;
        const double difference = cmp.difference(r, c);
        worst_difference = std::isnan(difference) ? difference : std::max(worst_difference, difference);
      } else if (!unresolved || cmp.rounding(r, c) > worst_rounding) {
        unresolved = true;
        worst_row = r;
        worst_rounding = cmp.rounding(r, c);
      }
    }
  }
  std::ostringstream out;
  if (wrong) {
    out << what << " differs from central differences by " << worst_difference << " at " << point
        << listed_entries(cmp, false, row_names, column_names) << "\n    reported:\n"
        << reported << "\n    numeric:\n"
        << numeric;
  } else if (unresolved) {
    out.precision(6);
    out << what << " cannot be checked at " << point << ": '" << name_of(row_names, worst_row)
        << "' = " << value[worst_row] << " there, too large for central differences to resolve the entries below "
        << "within the " << cmp.tolerance << " allowed" << why(worst_row)
        << listed_entries(cmp, true, row_names, column_names);
  }
  return out.str();
}

// What makes row `row` of a model's value large, from the parameter Jacobian
// (exact for a model linear in its parameters): the parameter whose term
// |d f_row / d theta_k| |theta_k| is at least half of |f_row|, named with
// its value ("; the largest term of 'V' is parameter 'A[0,0]' = 1e+300
// (about 1.5e+297): a parameter out of scale?"), or the state or input.
inline std::string largest_term(const Eigen::MatrixXd& parameter_jacobian, const Eigen::VectorXd& values,
                                const Eigen::VectorXd& value, Eigen::Index row,
                                const std::vector<std::string>& row_names,
                                const std::vector<std::string>& parameter_names) {
  const std::string state_or_input = "; its size comes from the state or the input, not from one parameter";
  if (values.size() == 0 || row < 0 || row >= parameter_jacobian.rows()) return state_or_input;
  Eigen::Index k = 0;
  const double term = parameter_jacobian.row(row).transpose().cwiseAbs().cwiseProduct(values.cwiseAbs()).maxCoeff(&k);
  if (!(term >= 0.5 * std::abs(value[row]))) return state_or_input;
  std::ostringstream out;
  out.precision(6);
  out << "; the largest term of '" << name_of(row_names, row) << "' is parameter '" << name_of(parameter_names, k)
      << "' = " << values[k] << " (about " << term << "): a parameter out of scale?";
  return out.str();
}

}  // namespace internal

inline std::vector<std::string> motion_model_failures(MotionModel& model, const Eigen::VectorXd& x,
                                                      const Eigen::VectorXd& u, double dt,
                                                      const ConformanceOptions& options = {}) {
  std::vector<std::string> failures;
  const int n = model.state_dim();
  const int p = model.input_dim();
  auto fail = [&failures](const std::string& what) { failures.push_back(what); };
  const std::vector<std::string>& states = model.state_names();
  const std::string point = internal::point_text(x, u, dt);

  if (n <= 0) fail("state_dim() must be positive");
  if (p < 0) fail("input_dim() cannot be negative");
  if (static_cast<int>(states.size()) != n) fail("state_names().size() differs from state_dim()");
  if (static_cast<int>(model.input_names().size()) != p) fail("input_names().size() differs from input_dim()");
  std::set<std::string> names;
  for (const auto& name : states) {
    if (name.empty() || !names.insert(name).second) fail("state name '" + name + "' is empty or repeated");
  }
  names.clear();
  for (const auto& name : model.input_names()) {
    if (name.empty() || !names.insert(name).second) fail("input name '" + name + "' is empty or repeated");
  }
  if (x.size() != n || u.size() != p) {
    fail("the test's x or u has the wrong size for this model");
    return failures;
  }

  Eigen::VectorXd next(n);
  if (!model.predict(x, u, 0.0, next)) {
    fail(internal::failed(model, "predict(x, u, 0)"));
  } else {
    for (int i = 0; i < n; ++i) {
      double difference = next[i] - x[i];
      if (model.is_angle(i)) difference = wrap_angle(difference);
      if (!(std::abs(difference) <= options.identity_tolerance * std::max(1.0, std::abs(x[i])))) {
        std::ostringstream out;
        out << "predict(x, u, 0) changed component " << i << " '" << internal::name_of(states, i) << "' from " << x[i]
            << " to " << next[i];
        fail(out.str());
      }
    }
  }
  Eigen::MatrixXd jacobian(n, n);
  if (!model.jacobian(x, u, 0.0, jacobian)) {
    fail(internal::failed(model, "jacobian(x, u, 0)"));
  } else if (!jacobian.isApprox(Eigen::MatrixXd::Identity(n, n), 1e-9) &&
             !((jacobian - Eigen::MatrixXd::Identity(n, n)).norm() <= 1e-9)) {
    fail("jacobian(x, u, 0) is not the identity");
  }

  if (!model.predict(x, u, dt, next)) {
    fail(internal::failed(model, "predict(x, u, dt)") + " at " + point);
  } else if (!next.allFinite()) {
    fail("predict(x, u, dt) is not finite: " + internal::first_non_finite(next, states, {"x_next"}) + " at " + point);
  } else {
    for (int i = 0; i < n; ++i) {
      if (model.is_angle(i) && !(next[i] >= -kPi && next[i] < kPi)) {
        fail("predict() left the angle '" + internal::name_of(states, i) + "' outside [-pi, pi)");
      }
    }
  }

  // Parameters.
  const auto& info = model.parameter_info();
  const Eigen::Index num_parameters = static_cast<Eigen::Index>(info.size());
  std::vector<std::string> parameter_names;
  for (const auto& entry : info) parameter_names.push_back(entry.name);
  names.clear();
  for (const auto& entry : info) {
    if (entry.name.empty() || !names.insert(entry.name).second)
      fail("parameter name '" + entry.name + "' is empty or repeated");
    if (!(entry.lower_bound <= entry.upper_bound)) fail("parameter '" + entry.name + "' has lower bound > upper bound");
  }
  Eigen::VectorXd values(num_parameters);
  model.get_parameters(values);
  for (Eigen::Index i = 0; i < num_parameters; ++i) {
    if (!(values[i] >= info[i].lower_bound && values[i] <= info[i].upper_bound)) {
      fail("parameter '" + info[i].name + "' is outside its own bounds");
    }
  }
  std::string error;
  if (!model.set_parameters(values, &error)) {
    fail("set_parameters(get_parameters()) was rejected: " + error);
  } else {
    Eigen::VectorXd again(num_parameters);
    model.get_parameters(again);
    if (again != values) fail("parameters do not round-trip through set/get");
  }
  if (num_parameters > 0) {
    Eigen::VectorXd wrong_size(num_parameters + 1);
    wrong_size.setZero();
    if (model.set_parameters(wrong_size, &error)) fail("set_parameters() accepted a vector of the wrong size");
    Eigen::VectorXd restored(num_parameters);
    model.get_parameters(restored);
    if (restored != values) fail("a rejected set_parameters() changed the model");
    model.set_parameters(values, &error);
  }

  // Process noise.
  Eigen::MatrixXd noise(n, n);
  if (!model.process_noise(Eigen::MatrixXd::Identity(n, n), x, u, dt, noise)) {
    fail(internal::failed(model, "process_noise()") + " at " + point);
  } else if (!noise.allFinite()) {
    fail("process_noise() is not finite: " + internal::first_non_finite(noise, states, states) + " at " + point);
  } else if (!noise.isApprox(noise.transpose(), 1e-12)) {
    fail("process_noise() is not symmetric");
  } else if (Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(noise).eigenvalues().minCoeff() <
             -1e-12 * std::max(1.0, noise.norm())) {
    fail("process_noise() is not positive semidefinite");
  }

  // A model that says its Jacobian and process noise depend on dt only gives
  // the same ones, to the bit, at another state and input: the engine reuses
  // them across steps.
  if (model.jacobian_and_noise_depend_only_on_dt()) {
    Eigen::VectorXd x_other = x;
    for (int i = 0; i < n; ++i) {
      x_other[i] += 0.375 * (1.0 + std::abs(x[i]));
      if (model.is_angle(i)) x_other[i] = wrap_angle(x_other[i]);
    }
    const Eigen::VectorXd u_other = (1.25 * u.array() + 0.5).matrix();
    Eigen::MatrixXd here(n, n);
    Eigen::MatrixXd there(n, n);
    const std::string other = internal::point_text(x_other, u_other, dt);
    if (model.jacobian(x, u, dt, here) && model.jacobian(x_other, u_other, dt, there) &&
        !(here.array() == there.array()).all()) {
      fail("jacobian_and_noise_depend_only_on_dt() is true, but jacobian() differs between " + point + " and " + other);
    }
    const Eigen::MatrixXd intensity = Eigen::MatrixXd::Identity(n, n);
    if (model.process_noise(intensity, x, u, dt, here) && model.process_noise(intensity, x_other, u_other, dt, there) &&
        !(here.array() == there.array()).all()) {
      fail("jacobian_and_noise_depend_only_on_dt() is true, but process_noise() differs between " + point + " and " +
           other);
    }
    model.failure_reason();  // a failed call is reported by the checks below
  }

  // predict() is a function of its arguments: after jacobian() at the same
  // point it gives the same state (to the last bits a model that computes
  // both in one evaluation may round differently, function_model.h).
  if (model.jacobian(x, u, dt, jacobian)) {
    Eigen::VectorXd again(n);
    if (model.predict(x, u, dt, again) && next.allFinite() && again.allFinite()) {
      for (int i = 0; i < n; ++i) {
        double difference = again[i] - next[i];
        if (model.is_angle(i)) difference = wrap_angle(difference);
        if (!(std::abs(difference) <= 1e-12 * std::max(1.0, std::abs(next[i])))) {
          std::ostringstream out;
          out.precision(17);
          out << "predict(x, u, dt) gave " << internal::name_of(states, i) << " = " << next[i] << " alone but "
              << again[i] << " right after jacobian(x, u, dt) at " << point
              << ": a prediction must depend on its arguments only";
          fail(out.str());
          break;
        }
      }
    }
  } else {
    model.failure_reason();  // reported below
  }

  // Jacobian against central differences of predict().
  if (!model.jacobian(x, u, dt, jacobian)) {
    fail(internal::failed(model, "jacobian(x, u, dt)") + " at " + point);
  } else if (!jacobian.allFinite()) {
    fail("jacobian() is not finite: " + internal::first_non_finite(jacobian, states, states) + " at " + point);
  } else {
    Eigen::MatrixXd numeric(n, n);
    auto step = [&](const Eigen::VectorXd& xp, Eigen::VectorXd& out) { return model.predict(xp, u, dt, out); };
    auto angle = [&model](int i) { return model.is_angle(i); };
    if (!numeric_state_jacobian(step, angle, x, numeric)) {
      fail(internal::failed(model, "numeric differentiation of predict()") + " at " + point);
    } else {
      const auto why = [&](Eigen::Index row) {
        Eigen::MatrixXd terms(n, num_parameters);
        if (num_parameters > 0 && model.parameter_jacobian(x, u, dt, terms) && terms.allFinite()) {
          return internal::largest_term(terms, values, next, row, states, parameter_names);
        }
        model.failure_reason();  // a failed parameter_jacobian() is reported below
        return std::string("; a parameter out of scale, or the state?");
      };
      const std::string differs = internal::compare_with_differences(
          "jacobian()", jacobian, numeric, next, x, options.jacobian_tolerance, point, states, states, why);
      if (!differs.empty()) fail(differs);
    }
  }

  // Parameter Jacobian, if provided, against differences over set_parameters().
  Eigen::MatrixXd parameter_jacobian(n, num_parameters);
  if (num_parameters > 0 && model.parameter_jacobian(x, u, dt, parameter_jacobian)) {
    Eigen::MatrixXd numeric(n, num_parameters);
    const bool evaluated = internal::numeric_parameter_jacobian(
        model, values, n, [&](Eigen::VectorXd& out) { return model.predict(x, u, dt, out); },
        [&](Eigen::Index i) { return model.is_angle(static_cast<int>(i)); }, &numeric);
    if (!parameter_jacobian.allFinite()) {
      fail("parameter_jacobian() is not finite: " +
           internal::first_non_finite(parameter_jacobian, states, parameter_names) + " at " + point);
    } else if (!evaluated) {
      fail("could not perturb the parameters to check parameter_jacobian() (a parameter on its bound?)");
    } else {
      const auto why = [&](Eigen::Index row) {
        return internal::largest_term(parameter_jacobian, values, next, row, states, parameter_names);
      };
      const std::string differs =
          internal::compare_with_differences("parameter_jacobian()", parameter_jacobian, numeric, next, values,
                                             options.jacobian_tolerance, point, states, parameter_names, why);
      if (!differs.empty()) fail(differs);
    }
  } else if (num_parameters > 0) {
    // false means "not provided" (the fitter then differences), unless the
    // model said why it failed.
    const char* reason = model.failure_reason();
    if (reason != nullptr && reason[0] != '\0') fail("parameter_jacobian() failed: " + std::string(reason));
  }

  // Declared rows of the parameter Jacobian, if any: one increasing list of
  // rows per parameter, every entry outside them zero here, and
  // parameter_jacobian_entries() giving the entries inside them, to the bit.
  const std::vector<std::vector<int>>& declared = model.parameter_jacobian_rows();
  if (!declared.empty()) {
    const std::string problem =
        parameter_jacobian_rows_problem(declared, static_cast<int>(num_parameters), static_cast<int>(n));
    const bool valid = problem.empty();
    if (!valid) fail("parameter_jacobian_rows() " + problem);
    int count = 0;
    for (const std::vector<int>& rows : declared) count += static_cast<int>(rows.size());
    Eigen::MatrixXd dense(n, num_parameters);
    Eigen::VectorXd entries(count);
    if (valid && model.parameter_jacobian(x, u, dt, dense)) {
      if (!model.parameter_jacobian_entries(x, u, dt, entries)) {
        fail(internal::failed(model, "parameter_jacobian_entries(x, u, dt)") + " at " + point);
      } else {
        int at = 0;
        for (Eigen::Index k = 0; k < num_parameters; ++k) {
          const std::vector<int>& rows = declared[static_cast<std::size_t>(k)];
          const auto entry = [&](int r) {
            return "(row " + std::to_string(r) + " '" + states[static_cast<std::size_t>(r)] + "', column " +
                   std::to_string(k) + " '" + parameter_names[static_cast<std::size_t>(k)] + "')";
          };
          for (int r = 0; r < n; ++r) {
            const bool listed = std::find(rows.begin(), rows.end(), r) != rows.end();
            if (!listed && dense(r, k) != 0.0) {
              fail("parameter_jacobian() entry " + entry(r) +
                   " is not zero but parameter_jacobian_rows() leaves it out, at " + point);
            } else if (listed && std::memcmp(&entries[at++], &dense(r, k), sizeof(double)) != 0) {
              fail("parameter_jacobian_entries() differs from parameter_jacobian() at entry " + entry(r) + ", at " +
                   point);
            }
          }
        }
      }
    }
    model.failure_reason();  // a failed parameter_jacobian() is reported above
  }

  // Outputs, if any: unique names, finite values, and their parameter
  // Jacobian, if provided, against differences over set_parameters().
  const std::vector<std::string>& outputs = model.output_names();
  const Eigen::Index num_outputs = static_cast<Eigen::Index>(outputs.size());
  for (std::size_t i = 0; i < outputs.size(); ++i) {
    if (outputs[i].empty()) fail("output_names()[" + std::to_string(i) + "] is empty");
    for (std::size_t j = 0; j < i; ++j) {
      if (outputs[i] == outputs[j]) fail("output name '" + outputs[i] + "' appears twice");
    }
  }
  Eigen::VectorXd y(num_outputs);
  if (num_outputs > 0) {
    if (!model.outputs(u, y)) {
      fail(internal::failed(model, "outputs(u)") + " at u = " + internal::vector_text(u));
    } else if (!y.allFinite()) {
      fail("outputs(u) is not finite: " + internal::first_non_finite(y, outputs, {"y"}) +
           " at u = " + internal::vector_text(u));
    }
  }
  Eigen::MatrixXd output_jacobian(num_outputs, num_parameters);
  const bool has_output_jacobian =
      num_outputs > 0 && num_parameters > 0 && model.output_parameter_jacobian(u, output_jacobian);
  if (num_outputs > 0 && num_parameters > 0 && !has_output_jacobian) {
    const char* reason = model.failure_reason();
    if (reason != nullptr && reason[0] != '\0') fail("output_parameter_jacobian() failed: " + std::string(reason));
  }
  if (has_output_jacobian) {
    Eigen::MatrixXd numeric(num_outputs, num_parameters);
    const bool evaluated = internal::numeric_parameter_jacobian(
        model, values, num_outputs, [&](Eigen::VectorXd& out) { return model.outputs(u, out); },
        [](Eigen::Index) { return false; }, &numeric);
    if (!evaluated) {
      fail("could not perturb the parameters to check output_parameter_jacobian() (a parameter on its bound?)");
    } else {
      const auto why = [&](Eigen::Index row) {
        return internal::largest_term(output_jacobian, values, y, row, outputs, parameter_names);
      };
      const std::string differs = internal::compare_with_differences(
          "output_parameter_jacobian()", output_jacobian, numeric, y, values, options.jacobian_tolerance,
          "u = " + internal::vector_text(u), outputs, parameter_names, why);
      if (!differs.empty()) fail(differs);
    }
  }
  return failures;
}

// Where a model is used: each state and input between its bounds, dt between
// its bounds. A single operating point misses what only happens elsewhere (a
// NaN or a throw above some speed, a Jacobian entry wrong only when a state
// is negative); the kit checks the region at many points.
struct OperatingRegion {
  Eigen::VectorXd x_min, x_max;
  Eigen::VectorXd u_min, u_max;
  double dt_min = 0.01;
  double dt_max = 0.1;
  int samples = 64;         // points drawn uniformly, besides the centre and the two extreme corners
  std::uint64_t seed = 13;  // the same points on every run and platform
};

// One operating point.
struct OperatingPoint {
  Eigen::VectorXd x, u;
  double dt = 0.0;
};

// The region's centre, its all-minimum and all-maximum corners and
// `samples` uniformly drawn points (splitmix64: the same on every platform).
inline std::vector<OperatingPoint> operating_points(const OperatingRegion& region) {
  std::uint64_t state = region.seed;
  auto uniform = [&state](double lo, double hi) {
    state += 0x9E3779B97F4A7C15ull;
    std::uint64_t z = state;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    z ^= z >> 31;
    return lo + (hi - lo) * (static_cast<double>(z >> 11) * 0x1.0p-53);
  };
  std::vector<OperatingPoint> points;
  const int count = 3 + std::max(0, region.samples);
  for (int k = 0; k < count; ++k) {
    OperatingPoint point;
    if (k < 3) {
      const double w = k == 0 ? 0.5 : (k == 1 ? 0.0 : 1.0);  // centre, then the two extreme corners
      point.x = region.x_min + w * (region.x_max - region.x_min);
      point.u = region.u_min + w * (region.u_max - region.u_min);
      point.dt = region.dt_min + w * (region.dt_max - region.dt_min);
    } else {
      point.x.resize(region.x_min.size());
      point.u.resize(region.u_min.size());
      for (Eigen::Index i = 0; i < point.x.size(); ++i) point.x[i] = uniform(region.x_min[i], region.x_max[i]);
      for (Eigen::Index i = 0; i < point.u.size(); ++i) point.u[i] = uniform(region.u_min[i], region.u_max[i]);
      point.dt = uniform(region.dt_min, region.dt_max);
    }
    points.push_back(std::move(point));
  }
  return points;
}

}  // namespace testing
}  // namespace sdk
}  // namespace skidimm

#endif  // SKIDIMM_SDK_TESTING_MODEL_CHECKS_H_
