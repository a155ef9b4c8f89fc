// Parses bank files (docs/bank-format.md) and instantiates their models.
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <iomanip>
#include <map>
#include <set>
#include <sstream>

#include "covariance.h"
#include "skidimm/config/bank.h"
#include "skidimm/config/expression.h"
#include "skidimm/engine/parameter_uncertainty.h"
#include "skidimm/errors.h"
#include "skidimm/printable.h"
#include "yaml_fields.h"

namespace skidimm {

namespace fs = std::filesystem;
using internal::YamlFields;

namespace {

std::string join(const std::vector<std::string>& items) {
  std::string out;
  for (const std::string& s : items) out += (out.empty() ? "" : ", ") + s;
  return out;
}

int index_of(const std::vector<std::string>& names, const std::string& name) {
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (names[i] == name) return static_cast<int>(i);
  }
  return -1;
}

void check_name(const YamlFields& y, const YAML::Node& node, const std::string& name, const std::string& field) {
  const std::string problem = name_problem(name);
  if (!problem.empty()) y.fail(node, field, problem);
}

void check_unique(const YamlFields& y, const YAML::Node& node, const std::vector<std::string>& names,
                  const std::string& field) {
  std::set<std::string> seen;
  for (const std::string& name : names) {
    if (name.empty()) y.fail(node, field, "names cannot be empty");
    if (!seen.insert(name).second) y.fail(node, field, "'" + name + "' appears twice");
  }
}

// The largest magnitude a matrix entry of the bank (Q, R, H, the prior) may
// have. One filter step multiplies a handful of these together (F P F' + Q dt,
// H P H' + R, the gain, the Joseph form, the mixing's y y'), so entries of at
// most 1e15 keep every intermediate below about 1e90 even with dt in the
// millions of seconds, far from double's 1.8e308, and a variance of 1e15
// next to one of 1e-15 is already at the end of double's 16 digits: larger
// values are not a tighter or looser model but a mistake (1e300 gave negative
// variances in the output).
constexpr double kMaxBankEntry = 1e15;

void check_magnitude(const YamlFields& y, const YAML::Node& node, const Eigen::MatrixXd& m, const std::string& field) {
  for (Eigen::Index j = 0; j < m.cols(); ++j) {
    for (Eigen::Index i = 0; i < m.rows(); ++i) {
      if (std::abs(m(i, j)) > kMaxBankEntry) {
        std::ostringstream out;
        out << "entry (" << i << ", " << j << ") = " << m(i, j) << " is larger in magnitude than " << kMaxBankEntry
            << ", which a filter step cannot carry without overflow or a total loss of precision";
        y.fail(node, field, out.str());
      }
    }
  }
}

void check_cov(const YamlFields& y, const YAML::Node& node, const Eigen::MatrixXd& m, bool strict,
               const std::string& field) {
  check_magnitude(y, node, m, field);
  std::string why;
  if (!check_covariance(m, strict, &why)) y.fail(node, field, "must be a covariance: " + why);
}

// `columns.<section>`: a map from a bank name to a CSV column; names left out
// read the column of the same name.
// `lines` gets the file's line of each name's text (0: not in the file).
std::vector<std::string> column_map(const YamlFields& y, const YAML::Node& node, const std::vector<std::string>& names,
                                    const std::string& field, std::vector<int>* lines) {
  std::vector<std::string> columns = names;
  lines->assign(names.size(), 0);
  if (!node || node.IsNull()) return columns;  // absent: every name reads the column of the same name
  if (!node.IsMap()) y.fail(node, field, "expected a mapping from name to CSV column");
  for (const auto& entry : node) {
    const std::string key = y.key(entry.first, field);
    const int i = index_of(names, key);
    if (i < 0) y.fail(entry.first, field + "." + key, "not one of the names [" + join(names) + "]");
    columns[i] = y.string(entry.second, field + "." + key);
    (*lines)[static_cast<std::size_t>(i)] = YamlFields::line_of(entry.second);
  }
  return columns;
}

void parse_measurement(const YamlFields& y, const YAML::Node& root, BankConfig* bank) {
  const YAML::Node node = y.required(root, "measurement", "");
  y.check_keys(node, {"observe", "H", "names", "outputs", "R"}, "measurement");
  const int n = bank->state_dim();
  MeasurementConfig& mc = bank->measurement;
  if (node["observe"] && node["H"]) y.fail(node, "measurement", "give either 'observe' or 'H', not both");
  if (node["observe"]) {
    if (node["names"]) y.fail(node["names"], "measurement.names", "only with H: 'observe' uses the state names");
    mc.names = y.string_list(node["observe"], "measurement.observe");
    check_unique(y, node["observe"], mc.names, "measurement.observe");
    mc.h = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(mc.names.size()), n);
    for (std::size_t r = 0; r < mc.names.size(); ++r) {
      const int s = index_of(bank->state_names, mc.names[r]);
      if (s < 0) {
        y.fail(node["observe"], "measurement.observe",
               "'" + mc.names[r] + "' is not a state (states: " + join(bank->state_names) + ")");
      }
      mc.h(static_cast<Eigen::Index>(r), s) = 1.0;
    }
  } else if (node["H"]) {
    const Eigen::MatrixXd h = y.matrix(node["H"], "measurement.H");
    if (h.cols() != n) {
      y.fail(node["H"], "measurement.H",
             "expected " + std::to_string(n) + " columns (one per state), got " + std::to_string(h.cols()));
    }
    mc.h = h;
    mc.names = y.string_list(y.required(node, "names", "measurement"), "measurement.names");
    if (static_cast<Eigen::Index>(mc.names.size()) != h.rows()) {
      y.fail(node["names"], "measurement.names", "expected one name per row of H (" + std::to_string(h.rows()) + ")");
    }
    check_unique(y, node["names"], mc.names, "measurement.names");
  } else {
    y.fail(node, "measurement", "give 'observe: [state names]' or 'H' with 'names'");
  }
  if (!mc.h.allFinite()) y.fail(node, "measurement.H", "must be finite");
  check_magnitude(y, node["H"] ? node["H"] : node, mc.h, "measurement.H");
  if (node["outputs"]) {
    // Rows after the states' with zero H: each is the model's prediction
    // (Bank::instantiate checks every mode's model has it).
    mc.outputs = y.string_list(node["outputs"], "measurement.outputs");
    if (mc.outputs.empty()) y.fail(node["outputs"], "measurement.outputs", "lists no output (leave it out)");
    std::vector<std::string> all = mc.names;
    all.insert(all.end(), mc.outputs.begin(), mc.outputs.end());
    check_unique(y, node["outputs"], all, "measurement.outputs");
    mc.names = all;
    const Eigen::Index states_rows = mc.h.rows();
    mc.h.conservativeResize(static_cast<Eigen::Index>(all.size()), Eigen::NoChange);
    mc.h.bottomRows(mc.h.rows() - states_rows).setZero();
  }
  const int m = static_cast<int>(mc.h.rows());
  if (m == 0) y.fail(node, "measurement", "measures nothing");
  const YAML::Node r = y.required(node, "R", "measurement");
  mc.r = y.covariance(r, m, "measurement.R");
  check_cov(y, r, mc.r, /*strict=*/true, "measurement.R");
  // A row that picks one angle state (a 1 there, 0 elsewhere) measures an angle.
  mc.is_angle.assign(m, false);
  for (int row = 0; row < m; ++row) {
    for (int s = 0; s < n; ++s) {
      if (bank->angle_mask[s] && mc.h(row, s) == 1.0 && mc.h.row(row).cwiseAbs().sum() == 1.0) {
        mc.is_angle[row] = true;
      }
    }
  }
}

void parse_transition(const YamlFields& y, const YAML::Node& root, BankConfig* bank) {
  const YAML::Node node = y.required(root, "transition", "");
  y.check_keys(node, {"stay", "matrix", "mean_dwell_time"}, "transition");
  if (node.size() != 1) y.fail(node, "transition", "give exactly one of 'stay', 'matrix', 'mean_dwell_time'");
  const int num_modes = bank->num_modes();
  TransitionConfig& t = bank->transition;
  if (node["stay"]) {
    t.kind = TransitionConfig::Kind::kStay;
    t.stay = y.number(node["stay"], "transition.stay");
    if (!(t.stay >= 0.0 && t.stay <= 1.0)) y.fail(node["stay"], "transition.stay", "must be a probability in [0, 1]");
  } else if (node["matrix"]) {
    t.kind = TransitionConfig::Kind::kMatrix;
    t.matrix = y.matrix(node["matrix"], num_modes, num_modes, "transition.matrix");
    for (int i = 0; i < num_modes; ++i) {
      const std::string row_field = "transition.matrix[" + std::to_string(i) + "]";
      if ((t.matrix.row(i).array() < 0.0).any() || !t.matrix.row(i).allFinite()) {
        y.fail(node["matrix"][i], row_field, "probabilities must be finite and >= 0");
      }
      const double sum = t.matrix.row(i).sum();
      if (std::abs(sum - 1.0) > 1e-9) {
        std::ostringstream out;
        // Digits enough to show how far from 1: 1.0000001 printed as 1.
        out << "row " << i << " (from mode '" << bank->modes[i].name << "') sums to " << std::setprecision(12) << sum
            << " (within 1e-9 of 1 is taken as 1); rows are 'from', columns 'to', and each must sum to 1";
        y.fail(node["matrix"][i], row_field, out.str());
      }
      t.matrix.row(i) /= sum;
    }
  } else {
    t.kind = TransitionConfig::Kind::kDwellTimes;
    const YAML::Node d = node["mean_dwell_time"];
    t.dwell_seconds.resize(num_modes);
    if (d.IsScalar()) {
      t.dwell_seconds.setConstant(y.number(d, "transition.mean_dwell_time"));
    } else if (d.IsMap()) {
      t.dwell_seconds.setConstant(std::nan(""));
      for (const auto& entry : d) {
        const std::string mode = y.key(entry.first, "transition.mean_dwell_time");
        const int j = bank->mode_index(mode);
        if (j < 0) y.fail(entry.first, "transition.mean_dwell_time." + mode, "no mode of that name");
        t.dwell_seconds[j] = y.number(entry.second, "transition.mean_dwell_time." + mode);
      }
      for (int j = 0; j < num_modes; ++j) {
        if (std::isnan(t.dwell_seconds[j])) {
          y.fail(d, "transition.mean_dwell_time", "no dwell time for mode '" + bank->modes[j].name + "'");
        }
      }
    } else {
      y.fail(d, "transition.mean_dwell_time", "expected seconds, or a mapping from mode name to seconds");
    }
    if (!(t.dwell_seconds.array() > 0.0).all() || !t.dwell_seconds.allFinite()) {
      y.fail(d, "transition.mean_dwell_time", "dwell times must be finite and > 0 seconds");
    }
  }
}

void parse_initial(const YamlFields& y, const YAML::Node& root, BankConfig* bank) {
  const YAML::Node node = y.required(root, "initial", "");
  y.check_keys(node, {"state", "covariance", "mode_probabilities"}, "initial");
  const int n = bank->state_dim();
  bank->initial_state = Eigen::VectorXd::Zero(n);
  if (node["state"]) {
    bank->initial_state = y.vector(node["state"], "initial.state");
    if (bank->initial_state.size() != n) {
      y.fail(node["state"], "initial.state",
             "expected " + std::to_string(n) + " values (" + join(bank->state_names) + ")");
    }
    if (!bank->initial_state.allFinite()) y.fail(node["state"], "initial.state", "must be finite");
    check_magnitude(y, node["state"], bank->initial_state, "initial.state");
  }
  const YAML::Node cov = y.required(node, "covariance", "initial");
  bank->initial_covariance = y.covariance(cov, n, "initial.covariance");
  check_cov(y, cov, bank->initial_covariance, /*strict=*/false, "initial.covariance");

  const int num_modes = bank->num_modes();
  bank->initial_mode_probabilities = Eigen::VectorXd::Constant(num_modes, 1.0 / num_modes);
  if (const YAML::Node p = node["mode_probabilities"]) {
    if (!p.IsMap()) y.fail(p, "initial.mode_probabilities", "expected a mapping from mode name to probability");
    bank->initial_mode_probabilities.setZero();
    for (const auto& entry : p) {
      const std::string mode = y.key(entry.first, "initial.mode_probabilities");
      const std::string field = "initial.mode_probabilities." + mode;
      const int j = bank->mode_index(mode);
      if (j < 0) y.fail(entry.first, field, "no mode of that name");
      const double value = y.number(entry.second, field);
      if (!(value >= 0.0 && value <= 1.0)) y.fail(entry.second, field, "must be a probability in [0, 1]");
      bank->initial_mode_probabilities[j] = value;
    }
    const double sum = bank->initial_mode_probabilities.sum();
    if (std::abs(sum - 1.0) > 1e-6) {
      y.fail(p, "initial.mode_probabilities", "must sum to 1 (modes left out count as 0), got " + std::to_string(sum));
    }
    bank->initial_mode_probabilities /= sum;
  }
}

// `fitted_inputs: {speed: [0.05, 0.31], ...}`: an input's range as [lowest, highest].
void parse_fitted_inputs(const YamlFields& y, const YAML::Node& node, const BankConfig& bank, const std::string& field,
                         ModeConfig* mode) {
  const std::string ranges_field = field + ".fitted_inputs";
  if (!node.IsMap()) y.fail(node, ranges_field, "expected a mapping from input name to [lowest, highest]");
  for (const auto& entry : node) {
    const std::string input = y.key(entry.first, ranges_field);
    const std::string input_field = ranges_field + "." + input;
    if (index_of(bank.input_names, input) < 0) {
      y.fail(entry.first, input_field, "'" + input + "' is not an input (inputs: " + join(bank.input_names) + ")");
    }
    const YAML::Node range = entry.second;
    if (!range.IsSequence() || range.size() != 2) {
      y.fail(range, input_field, "expected [lowest, highest], the input's range over the steps the mode was fitted on");
    }
    InputRange r{y.number(range[0], input_field + "[0]"), y.number(range[1], input_field + "[1]")};
    if (!std::isfinite(r.lowest) || !std::isfinite(r.highest) || r.lowest > r.highest) {
      y.fail(range, input_field,
             "expected finite numbers, the lowest first, got [" + printable(range[0].Scalar()) + ", " +
                 printable(range[1].Scalar()) + "]");
    }
    mode->fitted_inputs[input] = r;
  }
  mode->fitted_inputs_line = YamlFields::line_of(node);
}

void parse_modes(const YamlFields& y, const YAML::Node& root, BankConfig* bank) {
  const YAML::Node node = y.required(root, "modes", "");
  if (!node.IsSequence() || node.size() == 0) y.fail(node, "modes", "expected a non-empty list of modes");
  for (std::size_t i = 0; i < node.size(); ++i) {
    const YAML::Node m = node[i];
    const std::string field = "modes[" + std::to_string(i) + "]";
    y.check_keys(m,
                 {"name", "model", "params", "Q", "R", "description", "fit_when", "parameter_covariance",
                  "residual_correlation", "fitted_inputs"},
                 field);
    ModeConfig mode;
    mode.line = YamlFields::line_of(m);
    mode.name = y.string(y.required(m, "name", field), field + ".name");
    check_name(y, m["name"], mode.name, field + ".name");
    if (bank->mode_index(mode.name) >= 0) y.fail(m["name"], field + ".name", "mode '" + mode.name + "' appears twice");
    mode.model = y.string(y.required(m, "model", field), field + ".model");
    if (const YAML::Node params = m["params"]) {
      if (!params.IsMap()) y.fail(params, field + ".params", "expected a mapping from parameter name to value");
      for (const auto& entry : params) {
        const std::string key = y.key(entry.first, field + ".params");
        y.parameter(entry.second, key, field + ".params." + key, &mode.params);
        mode.param_lines[key] = YamlFields::line_of(entry.first);
      }
    }
    if (const YAML::Node when = m["fit_when"]) {
      mode.fit_when = y.string(when, field + ".fit_when");
      try {
        const Expression condition(mode.fit_when);
        for (const std::string& v : condition.variables()) {
          if (index_of(bank->input_names, v) < 0) {
            y.fail(when, field + ".fit_when", "'" + v + "' is not an input (inputs: " + join(bank->input_names) + ")");
          }
        }
      } catch (const ExpressionError& e) {
        y.fail(when, field + ".fit_when", e.what());
      }
    }
    const YAML::Node q = y.required(m, "Q", field);
    mode.q_intensity = y.covariance(q, bank->state_dim(), field + ".Q");
    check_cov(y, q, mode.q_intensity, /*strict=*/false, field + ".Q (mode '" + mode.name + "')");
    if (const YAML::Node c = m["parameter_covariance"]) {
      // Its size is the model's parameter count, checked when the model is created.
      const std::string c_field = field + ".parameter_covariance";
      int p = 0;
      if (c.IsMap()) {
        const YAML::Node values = c["diagonal"] ? c["diagonal"] : c["std"];
        if (values && values.IsSequence()) p = static_cast<int>(values.size());
      } else {
        p = static_cast<int>(y.matrix(c, c_field).rows());
      }
      // An empty one would read as no covariance at all, silently.
      if (p == 0) y.fail(c, c_field, "is empty: expected one value per parameter of the model (or no key at all)");
      mode.parameter_covariance = c.IsMap() ? y.covariance(c, p, c_field) : y.matrix(c, p, p, c_field);
      check_magnitude(y, c, mode.parameter_covariance, c_field);
      std::string why;
      if (!check_parameter_covariance(mode.parameter_covariance, &why)) {
        y.fail(c, c_field, "must be a covariance (mode '" + mode.name + "'): " + why);
      }
      mode.parameter_covariance_line = YamlFields::line_of(c);
    }
    if (const YAML::Node rho = m["residual_correlation"]) {
      const std::string rho_field = field + ".residual_correlation";
      mode.residual_correlation = y.number(rho, rho_field);
      if (!(mode.residual_correlation > -1.0 && mode.residual_correlation < 1.0)) {
        y.fail(rho, rho_field,
               "must be in (-1, 1) (mode '" + mode.name +
                   "'): the lag-1 correlation of the mode's whitened innovations (0: independent steps)");
      }
    }
    if (const YAML::Node ranges = m["fitted_inputs"]) parse_fitted_inputs(y, ranges, *bank, field, &mode);
    bank->modes.push_back(std::move(mode));
  }
}

// A mode's own `R:`, over the measurement rows (read after measurement:).
void parse_mode_measurement_noise(const YamlFields& y, const YAML::Node& root, BankConfig* bank) {
  const int m = static_cast<int>(bank->measurement.h.rows());
  for (std::size_t i = 0; i < bank->modes.size(); ++i) {
    const YAML::Node r = root["modes"][i]["R"];
    if (!r) continue;
    ModeConfig& mode = bank->modes[i];
    const std::string field = "modes[" + std::to_string(i) + "].R";
    mode.r = y.covariance(r, m, field);  // sized by every measurement row, outputs included
    check_cov(y, r, mode.r, /*strict=*/true, field + " (mode '" + mode.name + "')");
  }
}

}  // namespace

std::string BankConfig::shown_file() const {
  std::error_code error;
  const fs::path here = fs::current_path(error);
  if (!error) {
    const std::string relative = file.lexically_normal().lexically_relative(here).string();
    if (!relative.empty() && relative.size() <= file.lexically_normal().string().size()) return relative;
  }
  return file.lexically_normal().string();
}

std::string BankConfig::estimates_modes_problem(const std::vector<std::string>& estimated) const {
  bool same = estimated.size() == modes.size();
  for (std::size_t j = 0; same && j < modes.size(); ++j) same = estimated[j] == modes[j].name;
  return same ? std::string() : "its modes differ from bank '" + name + "': it was run with another bank";
}

int BankConfig::mode_index(const std::string& mode_name) const {
  for (std::size_t j = 0; j < modes.size(); ++j) {
    if (modes[j].name == mode_name) return static_cast<int>(j);
  }
  return -1;
}

std::vector<std::string> BankConfig::class_names() const {
  std::vector<std::string> names;
  for (const ClassConfig& c : classes) names.push_back(c.name);
  const std::vector<int> of = class_of_modes();
  for (std::size_t j = 0; j < modes.size(); ++j) {
    if (of[j] >= static_cast<int>(classes.size())) names.push_back(modes[j].name);
  }
  return names;
}

std::vector<int> BankConfig::class_of_modes() const {
  std::vector<int> of(modes.size(), -1);
  for (std::size_t c = 0; c < classes.size(); ++c) {
    for (int j : classes[c].modes) of[static_cast<std::size_t>(j)] = static_cast<int>(c);
  }
  int next = static_cast<int>(classes.size());
  for (int& c : of) {
    if (c < 0) c = next++;
  }
  return of;
}

int BankConfig::class_index(const std::string& label) const {
  for (std::size_t c = 0; c < classes.size(); ++c) {
    if (classes[c].name == label) return static_cast<int>(c);
  }
  const int j = mode_index(label);
  return j < 0 ? -1 : class_of_modes()[static_cast<std::size_t>(j)];
}

std::string BankConfig::unknown_label(const std::string& label) const {
  const auto folded = [](std::string text) {
    for (char& c : text) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return text;
  };
  std::string listed, modes_listed, same_but_case;
  const auto add = [&](std::string* list, const std::string& name) {
    *list += (list->empty() ? "" : ", ") + printable(name);
    if (same_but_case.empty() && name != label && folded(name) == folded(label)) same_but_case = name;
  };
  for (const ClassConfig& c : classes) add(&listed, c.name);
  for (const ModeConfig& m : modes) add(&modes_listed, m.name);
  std::string text =
      "'" + printable(label) + "' is neither a mode nor a class of bank '" + printable(name) + "'; " +
      (classes.empty() ? "its modes: " + modes_listed : "its classes: " + listed + "; its modes: " + modes_listed);
  if (!same_but_case.empty()) text += "; names are case-sensitive: '" + printable(same_but_case) + "'?";
  return text;
}

namespace {

void parse_sampling(const YamlFields& y, const YAML::Node& root, BankConfig* bank) {
  const YAML::Node node = root["sampling"];
  if (!node) return;
  y.check_keys(node, {"join", "rate", "max_gap", "skip_gaps", "skip_out_of_order"}, "sampling");
  if (const YAML::Node join = node["join"]) {
    const std::string value = y.string(join, "sampling.join");
    if (value == "time") {
      bank->sampling.join = SamplingConfig::Join::kTime;
    } else if (value == "rows") {
      bank->sampling.join = SamplingConfig::Join::kRows;
    } else {
      y.fail(join, "sampling.join",
             "expected 'time' (files merged on their own time columns) or 'rows' (files matched row for row), got '" +
                 value + "'");
    }
  }
  if (const YAML::Node rate = node["rate"]) {
    bank->sampling.rate = y.number(rate, "sampling.rate");
    if (!(bank->sampling.rate > 0.0 && bank->sampling.rate <= 1e6)) {
      y.fail(rate, "sampling.rate", "must be a rate in Hz, > 0 and at most 1e6");
    }
  }
  if (const YAML::Node gap = node["max_gap"]) {
    bank->sampling.max_gap = y.number(gap, "sampling.max_gap");
    if (!(bank->sampling.max_gap > 0.0 && bank->sampling.max_gap <= 1e9)) {
      y.fail(gap, "sampling.max_gap", "must be a time in seconds, > 0 and at most 1e9");
    }
  }
  const auto flag = [&](const char* key, bool* value) {
    const YAML::Node given = node[key];
    if (!given) return;
    const std::string field = std::string("sampling.") + key;
    const std::string text = y.string(given, field);
    if (text != "true" && text != "false") y.fail(given, field, "expected true or false, got '" + text + "'");
    *value = text == "true";
  };
  flag("skip_gaps", &bank->sampling.skip_gaps);
  flag("skip_out_of_order", &bank->sampling.skip_out_of_order);
}

void parse_decision(const YamlFields& y, const YAML::Node& root, BankConfig* bank) {
  const YAML::Node node = root["decision"];
  if (!node) return;
  y.check_keys(node, {"enter", "leave", "min_hold", "stale_after"}, "decision");
  DecisionConfig& d = bank->decision;
  if (node["enter"]) d.enter = y.number(node["enter"], "decision.enter");
  if (node["leave"]) d.leave = y.number(node["leave"], "decision.leave");
  if (node["min_hold"]) d.min_hold = y.number(node["min_hold"], "decision.min_hold");
  if (!(d.enter > 0.0 && d.enter <= 1.0)) y.fail(node, "decision.enter", "must be a probability in (0, 1]");
  if (!(d.leave >= 0.0 && d.leave < d.enter)) {
    y.fail(node, "decision.leave", "must be a probability in [0, decision.enter)");
  }
  if (!(d.min_hold >= 0.0 && d.min_hold < kLongestDecisionHold)) {
    y.fail(node, "decision.min_hold", "must be seconds, >= 0 and under 1e9");
  }
  if (node["stale_after"]) {
    d.stale_after = y.number(node["stale_after"], "decision.stale_after");
    if (!(d.stale_after >= 0.0 && d.stale_after < kLongestDecisionHold)) {
      y.fail(node, "decision.stale_after", "must be seconds, >= 0 (0: never) and under 1e9");
    }
  }
}

void parse_classes(const YamlFields& y, const YAML::Node& root, BankConfig* bank) {
  const YAML::Node node = root["classes"];
  if (!node) return;
  if (!node.IsMap()) y.fail(node, "classes", "expected a mapping from class name to a list of modes");
  std::set<int> used;
  for (const auto& entry : node) {
    ClassConfig c;
    c.name = y.string(entry.first, "classes");
    const std::string field = "classes." + printable(c.name);
    check_name(y, entry.first, c.name, field);
    for (const ClassConfig& other : bank->classes) {
      if (other.name == c.name) y.fail(entry.first, field, "class '" + c.name + "' appears twice");
    }
    const int mode = bank->mode_index(c.name);
    for (const std::string& m : y.string_list(entry.second, field)) {
      const int j = bank->mode_index(m);
      if (j < 0) y.fail(entry.second, field, "'" + m + "' is not a mode");
      if (!used.insert(j).second) y.fail(entry.second, field, "mode '" + m + "' is in two classes");
      c.modes.push_back(j);
    }
    if (c.modes.empty()) y.fail(entry.second, field, "a class needs at least one mode");
    if (mode >= 0 && (c.modes.size() != 1 || c.modes[0] != mode)) {
      y.fail(entry.first, field, "'" + c.name + "' is also a mode's name: a class may share a name only with its one mode");
    }
    bank->classes.push_back(std::move(c));
  }
}

}  // namespace

std::string name_problem(const std::string& name) {
  if (name.empty()) return "cannot be empty";
  if (printable(name) != name || name.find_first_of("\t\n") != std::string::npos) {
    return "'" + printable(name) + "' has control characters or invalid UTF-8";
  }
  if (name == "unknown") return "'unknown' is the decision's answer when no mode is confident: pick another";
  return "";
}

BankConfig load_bank_config(const fs::path& file) {
  const YamlFields y(file.string());
  const YAML::Node root = y.load_mapping("bank");

  y.check_keys(root,
               {"name", "description", "states", "angles", "inputs", "columns", "sampling", "measurement", "transition",
                "initial", "mode_probability_floor", "likelihood_weight", "likelihood_dof", "extrapolation_scale",
                "innovation_gate", "unknown", "plugin_paths", "shared", "modes", "classes", "decision"},
               "");
  BankConfig bank;
  bank.file = fs::absolute(file);
  bank.name = y.string(y.required(root, "name", ""), "name");
  if (root["description"]) bank.description = y.string(root["description"], "description");

  bank.state_names = y.string_list(y.required(root, "states", ""), "states");
  if (bank.state_names.empty()) y.fail(root["states"], "states", "a bank needs at least one state");
  check_unique(y, root["states"], bank.state_names, "states");
  bank.angle_mask.assign(bank.state_names.size(), false);
  if (root["angles"]) {
    for (const std::string& a : y.string_list(root["angles"], "angles")) {
      const int s = index_of(bank.state_names, a);
      if (s < 0)
        y.fail(root["angles"], "angles", "'" + a + "' is not a state (states: " + join(bank.state_names) + ")");
      bank.angle_mask[s] = true;
    }
  }
  bank.input_names = y.string_list(y.required(root, "inputs", ""), "inputs");
  check_unique(y, root["inputs"], bank.input_names, "inputs");

  // Modes first: the transition and initial blocks refer to them by name.
  parse_modes(y, root, &bank);
  parse_measurement(y, root, &bank);
  parse_mode_measurement_noise(y, root, &bank);
  parse_transition(y, root, &bank);
  parse_initial(y, root, &bank);
  parse_sampling(y, root, &bank);
  parse_classes(y, root, &bank);
  parse_decision(y, root, &bank);
  for (std::size_t j = 0; j < bank.modes.size(); ++j) {
    if (bank.modes[j].fit_when.empty()) continue;
    bool shared_class = false;
    for (const ClassConfig& c : bank.classes) {
      shared_class = shared_class ||
                     (c.modes.size() > 1 && std::find(c.modes.begin(), c.modes.end(), static_cast<int>(j)) != c.modes.end());
    }
    if (!shared_class) {
      y.fail(root["modes"][j]["fit_when"], "modes[" + std::to_string(j) + "].fit_when",
             "only modes of a class of several modes (classes:) split that class's logs; mode '" + bank.modes[j].name +
                 "' is in none");
    }
  }

  const YAML::Node columns = root["columns"];
  if (columns) {
    y.check_keys(columns, {"time", "time_unit", "inputs", "measurements", "truth_mode", "truth_blank"}, "columns");
  }
  bank.columns.time = columns && columns["time"] ? y.string(columns["time"], "columns.time") : "t";
  if (columns && columns["time_unit"]) {
    const std::string unit = y.string(columns["time_unit"], "columns.time_unit");
    const std::map<std::string, double> per_second{{"s", 1.0}, {"ms", 1e3}, {"us", 1e6}, {"ns", 1e9}};
    const auto found = per_second.find(unit);
    if (found == per_second.end()) {
      y.fail(columns["time_unit"], "columns.time_unit",
             "must be s, ms, us or ns (the unit of the time column), got '" + unit + "'");
    }
    bank.columns.time_units_per_second = found->second;
    bank.columns.time_unit_name = unit;
  }
  bank.columns.inputs = column_map(y, columns ? columns["inputs"] : YAML::Node(), bank.input_names, "columns.inputs",
                                   &bank.columns.input_lines);
  bank.columns.measurements = column_map(y, columns ? columns["measurements"] : YAML::Node(), bank.measurement.names,
                                         "columns.measurements", &bank.columns.measurement_lines);
  if (columns && columns["truth_mode"]) bank.columns.truth_mode = y.string(columns["truth_mode"], "columns.truth_mode");
  if (columns && columns["truth_blank"]) {
    const std::string blank = y.string(columns["truth_blank"], "columns.truth_blank");
    if (blank != "unlabelled" && blank != "carry") {
      y.fail(columns["truth_blank"], "columns.truth_blank",
             "expected 'unlabelled' (a blank truth cell is not scored) or 'carry' (it repeats the last label), got '" +
                 blank + "'");
    }
    bank.columns.carry_truth = blank == "carry";
  }

  if (const YAML::Node floor = root["mode_probability_floor"]) {
    bank.mode_probability_floor = y.number(floor, "mode_probability_floor");
    if (!(bank.mode_probability_floor >= 0.0 && bank.mode_probability_floor * bank.num_modes() < 1.0)) {
      y.fail(floor, "mode_probability_floor", "must be >= 0 and below 1/(number of modes)");
    }
  }
  if (const YAML::Node weight = root["likelihood_weight"]) {
    bank.likelihood_weight = y.number(weight, "likelihood_weight");
    if (!(bank.likelihood_weight > 0.0 && bank.likelihood_weight <= 1.0)) {
      y.fail(weight, "likelihood_weight", "must be in (0, 1]: the weight of each step's evidence (1: the plain IMM)");
    }
  }
  if (const YAML::Node dof = root["likelihood_dof"]) {
    bank.likelihood_dof = y.number(dof, "likelihood_dof");
    if (!(bank.likelihood_dof > 0.0 && std::isfinite(bank.likelihood_dof))) {
      y.fail(dof, "likelihood_dof",
             "must be a finite number > 0: the degrees of freedom of the Student-t likelihood (omit it for the "
             "Gaussian one)");
    }
  }
  if (const YAML::Node scale = root["extrapolation_scale"]) {
    bank.extrapolation_scale = y.number(scale, "extrapolation_scale");
    if (!(bank.extrapolation_scale > 0.0 && std::isfinite(bank.extrapolation_scale))) {
      y.fail(scale, "extrapolation_scale",
             "must be a finite number > 0: how many widths of a class's fitted input range outside it its "
             "evidence keeps 1/e of its weight (omit it for no extrapolation discount)");
    }
  }
  if (const YAML::Node gate = root["innovation_gate"]) {
    bank.innovation_gate = y.number(gate, "innovation_gate");
    if (!(bank.innovation_gate == 0.0 || (bank.innovation_gate > 0.0 && bank.innovation_gate < 1.0))) {
      y.fail(gate, "innovation_gate",
             "must be the probability that a consistent measurement passes, in (0, 1) (e.g. 0.9999), or 0 for no gate");
    }
  }
  if (const YAML::Node unknown = root["unknown"]) {
    y.check_keys(unknown, {"inflation", "enter", "leave"}, "unknown");
    UnknownHypothesisConfig& u = bank.unknown;
    u.inflation = y.number(y.required(unknown, "inflation", "unknown"), "unknown.inflation");
    if (!(u.inflation > 1.0 && std::isfinite(u.inflation))) {
      y.fail(unknown["inflation"], "unknown.inflation",
             "must be a finite number > 1: the factor on the best mode's innovation covariance that gives the "
             "unknown hypothesis its likelihood");
    }
    u.enter = y.number(y.required(unknown, "enter", "unknown"), "unknown.enter");
    if (!(u.enter >= 0.0 && u.enter < 1.0)) {
      y.fail(unknown["enter"], "unknown.enter", "must be a probability per step in [0, 1)");
    }
    u.leave = y.number(y.required(unknown, "leave", "unknown"), "unknown.leave");
    if (!(u.leave > 0.0 && u.leave <= 1.0)) {
      y.fail(unknown["leave"], "unknown.leave", "must be a probability per step in (0, 1]");
    }
    if (!(bank.mode_probability_floor * (bank.num_modes() + 1) < 1.0)) {
      y.fail(unknown, "unknown",
             "with mode_probability_floor " + std::to_string(bank.mode_probability_floor) +
                 " the floors of the modes and the unknown hypothesis reach 1: lower the floor below 1/(modes + 1)");
    }
  }
  if (const YAML::Node paths = root["plugin_paths"]) {
    for (const std::string& p : y.string_list(paths, "plugin_paths")) {
      fs::path path(p);
      path = path.is_absolute() ? path : (bank.file.parent_path() / path).lexically_normal();
      std::error_code ec;
      if (!fs::exists(path, ec)) {
        y.fail(paths, "plugin_paths",
               "'" + p + "' does not exist (resolved to " + path.string() +
                   "; relative paths are relative to the bank file)");
      }
      bank.plugin_paths.push_back(path);
    }
  }
  if (const YAML::Node shared = root["shared"]) {
    if (!shared.IsMap()) y.fail(shared, "shared", "expected a mapping from parameter name to value");
    for (const auto& entry : shared) {
      const std::string key = y.key(entry.first, "shared");
      y.parameter(entry.second, key, "shared." + key, &bank.shared);
      bank.shared_lines[key] = YamlFields::line_of(entry.first);
    }
  }
  return bank;
}

std::string ModelSource::describe() const {
  return origin + " " + plugin + (version.empty() ? "" : " " + version) +
         (file.empty() ? "" : " (" + file.string() + ")");
}

namespace {

// Where a model's complaint about its parameters points: the one key of
// `keys` it names in quotes ('r' in "parameter 'r' = -1 is outside ..."),
// at the line that gave it, the mode's own params or else the bank's
// shared:; the mode's line when it names none, or several (a list of what
// it was given says nothing of which one is wrong).
struct ComplaintPlace {
  int line = 0;
  std::string field;
};

ComplaintPlace place_of_complaint(const std::string& complaint, const BankConfig& config, const ModeConfig& mode,
                                  const std::string& mode_field, const std::vector<std::string>& keys) {
  const ComplaintPlace the_mode{mode.line, mode_field + ".params"};
  const std::string* named = nullptr;
  for (const std::string& key : keys) {
    if (complaint.find("'" + key + "'") == std::string::npos) continue;
    if (named != nullptr) return the_mode;
    named = &key;
  }
  if (named == nullptr) return the_mode;
  if (const auto own = mode.param_lines.find(*named); own != mode.param_lines.end()) {
    return {own->second, mode_field + ".params." + *named};
  }
  if (const auto shared = config.shared_lines.find(*named); shared != config.shared_lines.end()) {
    return {shared->second, "shared." + *named};
  }
  return the_mode;
}

}  // namespace

Bank Bank::instantiate(BankConfig config, PluginRegistry& registry, const ModelProvider* provider) {
  const std::string file = config.shown_file();
  Bank bank;
  std::set<std::string> shared_keys_used;
  for (std::size_t i = 0; i < config.modes.size(); ++i) {
    const ModeConfig& mode = config.modes[i];
    const std::string field = "modes[" + std::to_string(i) + "]";
    const std::string who = "mode '" + mode.name + "' (model " + mode.model + ")";
    const bool provided = provider != nullptr && provider->provides(mode.model);

    const PluginDescriptor* descriptor = nullptr;
    if (!provided) {
      try {
        descriptor = &registry.find(mode.model);
      } catch (const PluginError& e) {
        throw ConfigError(file, mode.line, field + ".model",
                          std::string(e.what()) + (provider != nullptr ? " (" + provider->describe() + ")" : ""));
      }
    }
    // The bank's shared parameters the model takes, overridden by the mode's own.
    sdk::ParameterSet params;
    params.set_bank_names(config.state_names, config.angle_mask, config.input_names);
    auto copy = [&params](const sdk::ParameterSet& from, const std::string& key) {
      if (const Eigen::MatrixXd* value = from.find(key)) params.set(key, *value);
      if (const std::vector<std::string>* text = from.find_text(key)) params.set_text(key, *text);
    };
    std::vector<std::string> given;  // the keys the model is given, its own last
    for (const std::string& key :
         provided ? provider->shared_parameter_keys(mode.model) : descriptor->parameter_keys) {
      if (config.shared.contains(key)) {
        copy(config.shared, key);
        shared_keys_used.insert(key);
        if (!mode.params.contains(key)) given.push_back(key);
      }
    }
    for (const std::string& key : mode.params.keys()) {
      copy(mode.params, key);
      given.push_back(key);
    }

    ModelHandle model;
    try {
      model = provided ? provider->create(mode.model, params) : registry.create(mode.model, params);
    } catch (const PluginError& e) {
      // A bank-level parameter written nowhere is the likelier cause, and a
      // model's own "missing parameter" cannot say where it belongs.
      std::vector<std::string> unset;
      for (const std::string& key :
           provided ? provider->shared_parameter_keys(mode.model) : descriptor->shared_parameter_keys) {
        if (!config.shared.contains(key) && !mode.params.contains(key)) unset.push_back("'" + key + "'");
      }
      if (!unset.empty()) {
        throw ConfigError(file, mode.line, field + ".params",
                          who + ": the bank gives no " + join(unset) + ", which model " + mode.model +
                              " declares bank-level (one value for every mode): give " +
                              (unset.size() == 1 ? "it" : "them") +
                              " once under 'shared:' (the model said: " + e.what() + ")");
      }
      const ComplaintPlace place = place_of_complaint(e.what(), config, mode, field, given);
      const bool from_shared = place.field.rfind("shared.", 0) == 0;
      throw ConfigError(
          file, place.line, place.field,
          from_shared ? "mode '" + mode.name + "' (model " + mode.model + ", its value from 'shared:'): " + e.what()
                      : who + ": " + e.what());
    } catch (const Error& e) {
      if (!provided) throw;
      throw ConfigError(file, mode.line, field + ".model", who + ": " + e.what());
    }
    for (const sdk::ParameterInfo& info : model->parameter_info()) {
      if (info.scope == sdk::ParameterScope::kBank && mode.params.contains(info.key)) {
        const auto line = mode.param_lines.find(info.key);
        throw ConfigError(file, line == mode.param_lines.end() ? mode.line : line->second,
                          field + ".params." + info.key,
                          "'" + info.key + "' is one value for the whole bank in model " + mode.model +
                              ": give it once under 'shared:', not per mode");
      }
    }
    if (model->state_dim() != config.state_dim() || model->state_names() != config.state_names) {
      throw ConfigError(file, mode.line, field + ".model",
                        who + " has states [" + join(model->state_names()) + "] but the bank declares [" +
                            join(config.state_names) + "]");
    }
    for (int s = 0; s < config.state_dim(); ++s) {
      if (model->is_angle(s) != config.angle_mask[s]) {
        throw ConfigError(file, mode.line, field + ".model",
                          who + ": state '" + config.state_names[s] + "' is " + (model->is_angle(s) ? "" : "not ") +
                              "an angle in the model but " + (config.angle_mask[s] ? "" : "not ") +
                              "listed under 'angles:' in the bank");
      }
    }
    if (model->input_dim() != config.input_dim() || model->input_names() != config.input_names) {
      throw ConfigError(file, mode.line, field + ".model",
                        who + " takes inputs [" + join(model->input_names()) + "] but the bank declares [" +
                            join(config.input_names) + "]");
    }
    for (const std::string& output : config.measurement.outputs) {
      if (index_of(model->output_names(), output) < 0) {
        throw ConfigError(file, mode.line, field + ".model",
                          who + " has no output '" + output + "' (measurement.outputs); its outputs are [" +
                              join(model->output_names()) + "]");
      }
    }
    if (mode.parameter_covariance.size() > 0) {
      const double dt = config.sampling.rate > 0.0 ? 1.0 / config.sampling.rate : 0.1;
      try {
        model = with_parameter_uncertainty(std::move(model), mode.parameter_covariance, dt);
      } catch (const Error& e) {
        throw ConfigError(file, mode.parameter_covariance_line, field + ".parameter_covariance",
                          who + ": " + e.what());
      }
    }
    bank.models.push_back(std::move(model));
    if (provided) {
      bank.model_sources.push_back(provider->source(mode.model));
    } else {
      ModelSource source;
      source.file = descriptor->path;
      source.plugin = descriptor->name;
      source.version = descriptor->version;
      source.parameter_keys = descriptor->parameter_keys;
      bank.model_sources.push_back(std::move(source));
    }
  }
  for (const std::string& key : config.shared.keys()) {
    if (shared_keys_used.count(key) == 0) {
      throw ConfigError(file, config.shared_lines[key], "shared." + key,
                        "not a parameter of any mode's model (a typo?)");
    }
  }
  bank.config = std::move(config);
  return bank;
}

namespace {

// When a bank file does not parse, a mismatch of its `states` with a mode's
// model is the likelier cause of what did not (a Q or R of the bank's size
// but not the model's, an `observe` of a state the model lacks), and the
// one to fix first: throws it, naming the mode, if the plugin declares its
// states. Reads the file leniently and only what it needs; any trouble here
// leaves the first error to be reported.
void check_states_against_models(const fs::path& file, const std::vector<fs::path>& plugin_paths) {
  std::vector<std::string> states;
  std::vector<std::pair<std::string, int>> models;  // model name, line
  std::vector<fs::path> bank_paths;
  try {
    const YAML::Node root = YAML::LoadFile(file.string());
    if (!root.IsMap() || !root["states"] || !root["modes"] || !root["modes"].IsSequence()) return;
    states = root["states"].as<std::vector<std::string>>();
    for (const YAML::Node& mode : root["modes"]) {
      if (mode.IsMap() && mode["model"]) {
        models.emplace_back(mode["model"].as<std::string>(), YamlFields::line_of(mode["model"]));
      }
    }
    if (const YAML::Node paths = root["plugin_paths"]) {
      for (const std::string& p : paths.as<std::vector<std::string>>()) {
        const fs::path path(p);
        bank_paths.push_back(path.is_absolute() ? path : (fs::absolute(file).parent_path() / path).lexically_normal());
      }
    }
  } catch (const std::exception&) {
    return;
  }
  PluginRegistry registry(PluginRegistry::standard_search_path(plugin_paths, bank_paths));
  for (std::size_t i = 0; i < models.size(); ++i) {
    std::vector<std::string> declared;
    try {
      for (const PluginVariable& v : registry.find(models[i].first).states) declared.push_back(v.name);
    } catch (const std::exception&) {
      continue;  // not a plugin (a Python model, a typo): reported in its turn
    }
    if (declared.empty() || declared == states) continue;
    throw ConfigError(file.string(), models[i].second, "modes[" + std::to_string(i) + "].model",
                      "model " + models[i].first + " has states [" + join(declared) + "] but the bank declares [" +
                          join(states) + "]; the bank's states, and so its matrices, must be the model's");
  }
}

}  // namespace

Bank Bank::load(const fs::path& file, const std::vector<fs::path>& plugin_paths) {
  BankConfig config;
  try {
    config = load_bank_config(file);
  } catch (const ConfigError&) {
    check_states_against_models(file, plugin_paths);
    throw;
  }
  PluginRegistry registry(PluginRegistry::standard_search_path(plugin_paths, config.plugin_paths));
  return instantiate(std::move(config), registry, nullptr);
}

}  // namespace skidimm
