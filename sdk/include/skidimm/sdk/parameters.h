// Parameters: how a model is configured and how generic tools see it.
//
// Two views of the same numbers:
//  * ParameterSet: what a bank file gives a mode (`params:` and the bank's
//    `shared:` block): named matrices and named lists of text (names,
//    expressions), plus the bank's declared state, input and angle names for
//    models whose dimensions come from the bank. The core fills it from YAML,
//    so plugins never see yaml-cpp. A scalar is a 1x1 matrix, a vector an
//    n x 1 matrix, a string a one-entry text list.
//  * ParameterInfo: the model's parameters as a flat vector of scalars, each
//    with a name, bounds and scope, so that tools such as the fitter work on
//    any plugin without plugin-specific code.
#ifndef SKIDIMM_SDK_PARAMETERS_H_
#define SKIDIMM_SDK_PARAMETERS_H_

#include <Eigen/Core>
#include <algorithm>
#include <initializer_list>
#include <limits>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace skidimm {
namespace sdk {

// Where a parameter's value lives in a bank.
enum class ParameterScope {
  kMode,  // each mode has its own value (`modes[i].params`)
  kBank,  // one value shared by every mode of the bank (`shared:`)
};

// One scalar entry of a model's flat parameter vector.
struct ParameterInfo {
  std::string name;  // flat name, unique within the model: "k", "A[0,1]"
  std::string key;   // the ParameterSet key it comes from: "k", "A"
  std::string description;
  double lower_bound = -std::numeric_limits<double>::infinity();
  double upper_bound = std::numeric_limits<double>::infinity();
  ParameterScope scope = ParameterScope::kMode;
};

// Named matrices handed to a plugin's factory.
class ParameterSet {
 public:
  void set(const std::string& key, Eigen::MatrixXd value) {
    texts_.erase(key);
    values_[key] = std::move(value);
  }
  void set_scalar(const std::string& key, double value) { set(key, Eigen::MatrixXd::Constant(1, 1, value)); }
  void set_text(const std::string& key, std::vector<std::string> value) {
    values_.erase(key);
    texts_[key] = std::move(value);
  }

  bool contains(const std::string& key) const { return values_.count(key) != 0 || texts_.count(key) != 0; }
  // The numeric value of `key`; nullptr if absent or text.
  const Eigen::MatrixXd* find(const std::string& key) const {
    const auto it = values_.find(key);
    return it == values_.end() ? nullptr : &it->second;
  }
  // The text value of `key`; nullptr if absent or numeric.
  const std::vector<std::string>* find_text(const std::string& key) const {
    const auto it = texts_.find(key);
    return it == texts_.end() ? nullptr : &it->second;
  }
  // Every key, numeric and text, sorted.
  std::vector<std::string> keys() const {
    std::vector<std::string> out;
    for (const auto& entry : values_) out.push_back(entry.first);
    for (const auto& entry : texts_) out.push_back(entry.first);
    std::sort(out.begin(), out.end());
    return out;
  }
  bool empty() const { return values_.empty() && texts_.empty(); }

  // The bank's `states`, `angles` (one flag per state) and `inputs`. Set by
  // the bank loader for every model; empty when a model is created outside a
  // bank. Models with fixed names ignore them; a model whose dimensions come
  // from the bank (linear_features) takes its names from here.
  void set_bank_names(std::vector<std::string> states, std::vector<bool> angles, std::vector<std::string> inputs) {
    bank_states_ = std::move(states);
    bank_angles_ = std::move(angles);
    bank_inputs_ = std::move(inputs);
  }
  const std::vector<std::string>& bank_states() const { return bank_states_; }
  const std::vector<bool>& bank_angles() const { return bank_angles_; }
  const std::vector<std::string>& bank_inputs() const { return bank_inputs_; }

  // Reads a required scalar. On failure returns false and explains in *error.
  bool get_scalar(const std::string& key, double* value, std::string* error) const {
    const Eigen::MatrixXd* m = find(key);
    if (m == nullptr) return fail(error, "missing parameter '" + key + "' (a number)");
    if (m->size() != 1) {
      return fail(error, "parameter '" + key + "' must be a number, got a " + shape(*m) + " matrix");
    }
    *value = (*m)(0, 0);
    return true;
  }

  // Reads a required rows x cols matrix.
  bool get_matrix(const std::string& key, int rows, int cols, Eigen::MatrixXd* value, std::string* error) const {
    const Eigen::MatrixXd* m = find(key);
    if (m == nullptr) {
      return fail(error, "missing parameter '" + key + "' (a " + std::to_string(rows) + "x" + std::to_string(cols) +
                             " matrix)");
    }
    if (m->rows() != rows || m->cols() != cols) {
      return fail(error, "parameter '" + key + "' must be " + std::to_string(rows) + "x" + std::to_string(cols) +
                             ", got " + shape(*m));
    }
    *value = *m;
    return true;
  }

  // Reads a required list of text (a YAML string or list of strings).
  bool get_text(const std::string& key, std::vector<std::string>* value, std::string* error) const {
    const std::vector<std::string>* t = find_text(key);
    if (t == nullptr) {
      return fail(error, values_.count(key) ? "parameter '" + key + "' must be text (a string or a list of strings)"
                                            : "missing parameter '" + key + "' (text)");
    }
    *value = *t;
    return true;
  }

  // Fails on any key outside `allowed`, so a typo in a bank is an error
  // instead of a silently ignored value.
  bool check_only(std::initializer_list<const char*> allowed, std::string* error) const {
    return check_only(std::vector<std::string>(allowed.begin(), allowed.end()), error);
  }
  bool check_only(const std::vector<std::string>& allowed, std::string* error) const {
    for (const std::string& key : keys()) {
      bool known = false;
      for (const std::string& a : allowed) known = known || key == a;
      if (!known) {
        std::string list;
        for (const std::string& a : allowed) list += (list.empty() ? "" : ", ") + a;
        return fail(error, "unknown parameter '" + key + "' (this model takes: " + list + ")");
      }
    }
    return true;
  }

 private:
  static bool fail(std::string* error, const std::string& message) {
    if (error != nullptr) *error = message;
    return false;
  }
  static std::string shape(const Eigen::MatrixXd& m) {
    return std::to_string(m.rows()) + "x" + std::to_string(m.cols());
  }

  std::map<std::string, Eigen::MatrixXd> values_;
  std::map<std::string, std::vector<std::string>> texts_;
  std::vector<std::string> bank_states_;
  std::vector<bool> bank_angles_;
  std::vector<std::string> bank_inputs_;
};

// Checks a flat parameter vector against a model's parameter_info(): its
// size, finiteness and every entry's bounds. The usual first line of
// set_parameters(); on failure *error names the parameter and its bounds.
inline bool check_parameter_values(const std::vector<ParameterInfo>& info,
                                   const Eigen::Ref<const Eigen::VectorXd>& values, std::string* error) {
  auto fail = [error](const std::string& message) {
    if (error != nullptr) *error = message;
    return false;
  };
  if (values.size() != static_cast<Eigen::Index>(info.size())) {
    std::string names;
    for (const ParameterInfo& p : info) names += (names.empty() ? "" : ", ") + p.name;
    return fail("expected " + std::to_string(info.size()) + " values (" + names + "), got " +
                std::to_string(values.size()));
  }
  for (std::size_t i = 0; i < info.size(); ++i) {
    const double v = values[static_cast<Eigen::Index>(i)];
    if (!(v == v) || v == std::numeric_limits<double>::infinity() || v == -std::numeric_limits<double>::infinity()) {
      return fail("parameter '" + info[i].name + "' is not finite");
    }
    if (v < info[i].lower_bound || v > info[i].upper_bound) {
      return fail("parameter '" + info[i].name + "' = " + std::to_string(v) + " is outside [" +
                  std::to_string(info[i].lower_bound) + ", " + std::to_string(info[i].upper_bound) + "]");
    }
  }
  return true;
}

// The entry of a scalar parameter (its name is its ParameterSet key).
inline ParameterInfo scalar_parameter_info(const std::string& name, const std::string& description, double lower_bound,
                                           double upper_bound, ParameterScope scope = ParameterScope::kMode) {
  ParameterInfo info;
  info.name = info.key = name;
  info.description = description;
  info.lower_bound = lower_bound;
  info.upper_bound = upper_bound;
  info.scope = scope;
  return info;
}

// Builds the flat entries for a rows x cols matrix parameter, row-major
// ("A[0,0]", "A[0,1]", ...), which is the order plugins use in get/set.
inline void append_matrix_parameter_info(const std::string& key, int rows, int cols, const std::string& description,
                                         ParameterScope scope, std::vector<ParameterInfo>* info) {
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      ParameterInfo p;
      p.name = key + "[" + std::to_string(r) + "," + std::to_string(c) + "]";
      p.key = key;
      p.description = description;
      p.scope = scope;
      info->push_back(std::move(p));
    }
  }
}

}  // namespace sdk
}  // namespace skidimm

#endif  // SKIDIMM_SDK_PARAMETERS_H_
