#include "skidimm/fitting/bank_writer.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <map>
#include <regex>
#include <sstream>

#include "skidimm/engine/parameter_uncertainty.h"
#include "skidimm/errors.h"
#include "skidimm/io/csv.h"
#include "skidimm/io/output_file.h"

namespace skidimm {
namespace fitting {

namespace fs = std::filesystem;

namespace {

// `text` on one comment line: a control character (a newline in a path of
// the command line) written as an escape, so that nothing after it can
// become a key of the bank.
std::string comment_text(const std::string& text) {
  std::string out;
  for (const char c : text) {
    const auto byte = static_cast<unsigned char>(c);
    if (c == '\n') {
      out += "\\n";
    } else if (c == '\r') {
      out += "\\r";
    } else if (byte < 0x20 || byte == 0x7f) {
      char escape[8];
      std::snprintf(escape, sizeof escape, "\\x%02x", byte);
      out += escape;
    } else {
      out += c;
    }
  }
  return out;
}

// Seven significant digits: what a bank file holds of a fitted value. A name of
// its own, so that a unity build, which joins this file's anonymous namespace
// with the fitters', cannot hand them this format for their messages.
std::string bank_number(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.7g", v);
  return buffer;
}

// A bound of a range to bank_number()'s digits, rounded outward (down for
// the lowest value, up for the highest), so that the range written still
// holds every value it was found from.
std::string bank_bound(double v, bool highest) {
  const std::string text = bank_number(v);
  const double back = std::strtod(text.c_str(), nullptr);
  if (highest ? back >= v : back <= v) return text;
  const double unit = std::pow(10.0, std::floor(std::log10(std::abs(v))) - 6.0);  // of the 7th significant digit
  return bank_number(highest ? back + unit : back - unit);
}

std::string read_text(const fs::path& file) {
  errno = 0;
  std::ifstream in(file, std::ios::binary);
  if (!in) throw ConfigError(file.string(), 0, "", std::string("cannot read: ") + std::strerror(errno));
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// A complaint about a text to be written, said of the file it is written
// to, after `lead`: by default at the text's own line.
using ComplaintAbout = std::function<ConfigError(const ConfigError& complaint, const std::string& lead)>;

// Writes text to <file>.tmp, checks it loads as a bank, then renames
// (output_file.h: a full disk or a failed close is an error with its reason,
// and the .tmp file is removed).
void write_validated(const fs::path& file, const std::string& text, const ComplaintAbout& complaint = {}) {
  write_file_atomically(
      file, text,
      [&](const fs::path& temporary) {
        try {
          load_bank_config(temporary);
        } catch (const ConfigError& e) {
          const std::string lead = "the result would not be a valid bank, nothing was written: ";
          if (complaint) throw complaint(e, lead);
          throw ConfigError(file.string(), e.line(), e.field(), lead + e.message());
        }
      },
      ".tmp");
}

bool is_top_level_key(const std::string& line) {
  return !line.empty() && line[0] != ' ' && line[0] != '#' && line[0] != '-' && line.find(':') != std::string::npos;
}

std::vector<std::string> split_lines(const std::string& text) {
  std::vector<std::string> lines;
  std::stringstream in(text);
  std::string line;
  while (std::getline(in, line)) lines.push_back(line);
  return lines;
}

// [begin, end) lines of a top-level key's block; begin == end == size if absent.
std::pair<std::size_t, std::size_t> block_of(const std::vector<std::string>& lines, const std::string& key) {
  for (std::size_t i = 0; i < lines.size(); ++i) {
    if (lines[i].rfind(key + ":", 0) == 0) {
      std::size_t end = i + 1;
      while (end < lines.size() && !is_top_level_key(lines[end])) ++end;
      // Comment lines right before the next key belong to that key.
      while (end > i + 1 && (lines[end - 1].empty() || lines[end - 1][0] == '#') && end < lines.size()) --end;
      return {i, end};
    }
  }
  return {lines.size(), lines.size()};
}

std::string join_lines(const std::vector<std::string>& lines) {
  std::string out;
  for (const std::string& l : lines) out += l + "\n";
  return out;
}

}  // namespace

std::string format_matrix(const Eigen::MatrixXd& m) {
  if (m.size() == 1) return bank_number(m(0, 0));
  std::string out = "[";
  if (m.cols() == 1) {  // a vector: a flat list, as banks write them
    for (Eigen::Index r = 0; r < m.rows(); ++r) out += (r ? ", " : "") + bank_number(m(r, 0));
    return out + "]";
  }
  for (Eigen::Index r = 0; r < m.rows(); ++r) {
    out += (r ? ", [" : "[");
    for (Eigen::Index c = 0; c < m.cols(); ++c) out += (c ? ", " : "") + bank_number(m(r, c));
    out += "]";
  }
  return out + "]";
}

namespace {

// A covariance as a bank writes it: {diagonal: [...]} when it is diagonal.
std::string format_covariance(const Eigen::MatrixXd& m) {
  const Eigen::MatrixXd off = m - Eigen::MatrixXd(m.diagonal().asDiagonal());
  if (off.cwiseAbs().maxCoeff() == 0.0) {
    Eigen::VectorXd d = m.diagonal();
    return "{diagonal: " + format_matrix(d) + "}";
  }
  return format_matrix(m);
}

// A parameter covariance (parameter_uncertainty.h): one row per line, 10
// significant digits, so it reads back positive semi-definite to the
// loader's tolerance (entries spanning many orders of magnitude lose their
// small eigenvalues at 7).
std::string format_parameter_covariance(const Eigen::MatrixXd& m) {
  const Eigen::MatrixXd off = m - Eigen::MatrixXd(m.diagonal().asDiagonal());
  auto precise = [](double v) {
    char buffer[32];
    std::snprintf(buffer, sizeof(buffer), "%.10g", v);
    return std::string(buffer);
  };
  std::string out;
  if (off.cwiseAbs().maxCoeff() == 0.0) {
    for (Eigen::Index i = 0; i < m.rows(); ++i) out += (i ? ", " : "") + precise(m(i, i));
    return "{diagonal: [" + out + "]}";
  }
  for (Eigen::Index r = 0; r < m.rows(); ++r) {
    out += r ? ",\n        [" : "\n        [";
    for (Eigen::Index c = 0; c < m.cols(); ++c) out += (c ? ", " : "") + precise(m(r, c));
    out += "]";
  }
  return "[" + out + "]";
}

}  // namespace

std::string format_text(const std::vector<std::string>& values) {
  std::string out = "[";
  for (std::size_t i = 0; i < values.size(); ++i) {
    out += (i ? ", \"" : "\"");
    for (char c : values[i]) {
      if (c == '"' || c == '\\') out += '\\';
      out += c;
    }
    out += "\"";
  }
  return out + "]";
}

std::string format_parameters(const sdk::MotionModel& model, sdk::ParameterScope scope,
                              const sdk::ParameterSet& original, const std::vector<std::string>& table) {
  const auto& info = model.parameter_info();
  Eigen::VectorXd values(static_cast<Eigen::Index>(info.size()));
  model.get_parameters(values);
  // Group the flat entries by key; "A[r,c]" entries form a matrix, "a[i]" a column.
  static const std::regex element(R"(^.*\[(\d+),(\d+)\]$)");
  static const std::regex vector_element(R"(^.*\[(\d+)\]$)");
  // The plugin's documented table first (a parameter it holds fixed keeps its
  // place there), then the model's other parameters in their order, then what
  // else the bank gave (text), by name.
  std::vector<std::string> keys;
  auto is_scoped = [&](const std::string& key) {
    for (const sdk::ParameterInfo& p : info) {
      if (p.key == key) return p.scope == scope;
    }
    return original.contains(key);  // held fixed by the model, or not one of its parameters
  };
  for (const std::string& key : table) {
    if (std::find(keys.begin(), keys.end(), key) == keys.end() && is_scoped(key)) keys.push_back(key);
  }
  std::map<std::string, std::vector<std::tuple<int, int, double>>> entries;
  for (std::size_t i = 0; i < info.size(); ++i) {
    if (info[i].scope != scope) continue;
    if (std::find(keys.begin(), keys.end(), info[i].key) == keys.end()) keys.push_back(info[i].key);
    std::smatch match;
    int r = 0, c = 0;
    if (std::regex_match(info[i].name, match, element)) {
      r = std::stoi(match[1]);
      c = std::stoi(match[2]);
    } else if (std::regex_match(info[i].name, match, vector_element)) {
      r = std::stoi(match[1]);
    }
    entries[info[i].key].emplace_back(r, c, values[static_cast<Eigen::Index>(i)]);
  }
  for (const std::string& key : original.keys()) {
    if (std::find(keys.begin(), keys.end(), key) == keys.end()) keys.push_back(key);
  }
  std::string out;
  for (const std::string& key : keys) {
    std::string value;
    const auto fitted = entries.find(key);
    if (fitted != entries.end()) {
      int rows = 0, cols = 0;
      for (const auto& [r, c, v] : fitted->second) rows = std::max(rows, r + 1), cols = std::max(cols, c + 1);
      // Start from the bank's value so entries the model holds fixed survive.
      const Eigen::MatrixXd* given = original.find(key);
      Eigen::MatrixXd m = given != nullptr && given->rows() >= rows && given->cols() >= cols
                              ? *given
                              : Eigen::MatrixXd::Zero(rows, cols);
      for (const auto& [r, c, v] : fitted->second) m(r, c) = v;
      value = format_matrix(m);
    } else if (const Eigen::MatrixXd* given = original.find(key)) {
      value = format_matrix(*given);
    } else if (const std::vector<std::string>* text = original.find_text(key)) {
      value = format_text(*text);
    }
    out += (out.empty() ? "" : ", ") + key + ": " + value;
  }
  return "{" + out + "}";
}

namespace {

// A name as a YAML scalar that reads back as the same string: plain when it
// is a simple identifier, else double-quoted. Names come from the command line
// (--name), so they must not be able to add keys to the bank.
std::string yaml_scalar(const std::string& text) {
  static const std::regex plain(R"(^[A-Za-z_][A-Za-z0-9_.+-]*$)");
  static const std::regex reserved(R"(^(true|false|yes|no|on|off|null|True|False|Yes|No|On|Off|Null|TRUE|FALSE|NULL|YES|NO|ON|OFF)$)");
  if (std::regex_match(text, plain) && !std::regex_match(text, reserved)) return text;
  std::string out = "\"";
  for (char c : text) {
    if (c == '"' || c == '\\') out += '\\';
    if (c == '\n') {
      out += "\\n";
      continue;
    }
    out += c;
  }
  return out + "\"";
}

}  // namespace

std::string format_mode_entry(const ModeConfig& mode, const sdk::MotionModel& model,
                              const std::vector<std::string>& comments, const std::vector<std::string>& table,
                              const std::vector<std::string>& input_names) {
  std::string out;
  for (const std::string& c : comments) out += "  # " + c + "\n";
  out += "  - name: " + yaml_scalar(mode.name) + "\n";
  out += "    model: " + yaml_scalar(mode.model) + "\n";
  if (!mode.fit_when.empty()) out += "    fit_when: " + yaml_scalar(mode.fit_when) + "\n";
  const std::string params = format_parameters(model, sdk::ParameterScope::kMode, mode.params, table);
  if (params != "{}") out += "    params: " + params + "\n";
  out += "    Q: " + format_matrix(mode.q_intensity) + "\n";
  if (mode.r.size() > 0) out += "    R: " + format_covariance(mode.r) + "\n";
  const Eigen::MatrixXd& parameter_covariance = parameter_covariance_of(model);
  if (parameter_covariance.size() > 0) {
    out += "    parameter_covariance: " + format_parameter_covariance(parameter_covariance) + "\n";
  }
  if (mode.residual_correlation != 0.0) {
    out += "    residual_correlation: " + bank_number(mode.residual_correlation) + "\n";
  }
  if (!mode.fitted_inputs.empty()) {
    // In the bank's input order, then any other (a caller without the order).
    std::vector<std::string> order;
    for (const std::string& input : input_names) {
      if (mode.fitted_inputs.count(input) > 0) order.push_back(input);
    }
    for (const auto& [input, range] : mode.fitted_inputs) {
      if (std::find(order.begin(), order.end(), input) == order.end()) order.push_back(input);
    }
    std::string ranges;
    for (const std::string& input : order) {
      const InputRange& range = mode.fitted_inputs.at(input);
      ranges += (ranges.empty() ? "" : ", ") + yaml_scalar(input) + ": [" + bank_bound(range.lowest, false) + ", " +
                bank_bound(range.highest, true) + "]";
    }
    out += "    fitted_inputs: {" + ranges + "}\n";
  }
  return out;
}

namespace {

// The text of `bank_file` with `entry` at the end of its `modes:` list, and
// where the entry went: lines [at, at + count) of the text (0-based).
struct AppendedBank {
  std::string text;
  std::size_t at = 0, count = 0;

  // A complaint about the appended text, made about `bank_file` at the line
  // of the bank it comes from: lines after the entry move up by its length,
  // and a complaint inside the entry names the end of the modes: list.
  ConfigError at_bank_line(const fs::path& bank_file, const ConfigError& e, const std::string& lead) const {
    const std::size_t line = static_cast<std::size_t>(std::max(0, e.line()));
    if (line > at && line <= at + count) {
      return ConfigError(bank_file.string(), static_cast<int>(at), e.field(),
                         lead + "(the appended entry) " + e.message());
    }
    return ConfigError(bank_file.string(), static_cast<int>(line > at ? line - count : line), e.field(),
                       lead + e.message());
  }
};

AppendedBank with_mode_appended(const fs::path& bank_file, const std::string& entry) {
  std::vector<std::string> lines = split_lines(read_text(bank_file));
  const auto [begin, end] = block_of(lines, "modes");
  if (begin == lines.size()) throw ConfigError(bank_file.string(), 0, "modes", "the bank has no modes: list");
  // Insert after the last non-blank line of the modes block.
  AppendedBank appended;
  appended.at = end;
  while (appended.at > begin + 1 && lines[appended.at - 1].find_first_not_of(' ') == std::string::npos) --appended.at;
  std::vector<std::string> entry_lines = split_lines(entry);
  appended.count = entry_lines.size();
  lines.insert(lines.begin() + static_cast<std::ptrdiff_t>(appended.at), entry_lines.begin(), entry_lines.end());
  appended.text = join_lines(lines);
  return appended;
}

}  // namespace

void append_mode_to_bank(const fs::path& bank_file, const std::string& entry) {
  const AppendedBank appended = with_mode_appended(bank_file, entry);
  write_validated(bank_file, appended.text, [&](const ConfigError& e, const std::string& lead) {
    return appended.at_bank_line(bank_file, e, lead);
  });
}

void check_mode_appends(const fs::path& bank_file, const std::string& entry) {
  const AppendedBank appended = with_mode_appended(bank_file, entry);
  // Beside the bank, as append_mode_to_bank() checks it (the paths a bank
  // names are relative to its own file), in a file of its own (OutputFile
  // never takes an existing name) that is never committed, so removed.
  OutputFile probe(bank_file, ".check");
  probe.write(appended.text);
  probe.seek_end();  // a seek hands the buffered bytes to the file
  try {
    load_bank_config(probe.written_path());
  } catch (const ConfigError& e) {
    throw appended.at_bank_line(bank_file, e, "");
  }
}

void write_bank_from_template(const fs::path& template_file, const fs::path& output,
                              const std::vector<std::string>& header,
                              const std::vector<std::pair<std::string, std::string>>& blocks) {
  std::vector<std::string> lines = split_lines(read_text(template_file));
  std::size_t first = 0;
  while (first < lines.size() && (lines[first].empty() || lines[first][0] == '#')) ++first;
  lines.erase(lines.begin(), lines.begin() + static_cast<std::ptrdiff_t>(first));
  for (const auto& [key, block] : blocks) {
    const auto [begin, end] = block_of(lines, key);
    const std::vector<std::string> replacement = block.empty() ? std::vector<std::string>{} : split_lines(block);
    if (begin == lines.size()) {
      // A new block goes before modes: (or at the end).
      const std::size_t at = key == "modes" ? lines.size() : block_of(lines, "modes").first;
      lines.insert(lines.begin() + static_cast<std::ptrdiff_t>(at), replacement.begin(), replacement.end());
    } else {
      lines.erase(lines.begin() + static_cast<std::ptrdiff_t>(begin), lines.begin() + static_cast<std::ptrdiff_t>(end));
      lines.insert(lines.begin() + static_cast<std::ptrdiff_t>(begin), replacement.begin(), replacement.end());
    }
  }
  std::string text;
  for (const std::string& h : header) text += "# " + comment_text(h) + "\n";
  write_validated(output, text + join_lines(lines));
}

namespace {

std::string join_names(const std::vector<std::string>& names) {
  std::string out;
  for (const std::string& n : names) out += (out.empty() ? "" : ", ") + n;
  return "[" + out + "]";
}

}  // namespace

std::string format_columns_block(const BankConfig& config) {
  std::string out = "columns:\n  time: " + yaml_scalar(config.columns.time) + "\n";
  // The unit the log's stamps are in (a copy that dropped it would read stamps in ms as seconds).
  if (config.columns.time_unit_name != "s") out += "  time_unit: " + config.columns.time_unit_name + "\n";
  out += "  inputs:\n";
  for (std::size_t i = 0; i < config.columns.inputs.size() && i < config.input_names.size(); ++i) {
    out += "    " + yaml_scalar(config.input_names[i]) + ": " + yaml_scalar(config.columns.inputs[i]) + "\n";
  }
  out += "  measurements:\n";
  for (std::size_t i = 0; i < config.columns.measurements.size() && i < config.measurement.names.size(); ++i) {
    out +=
        "    " + yaml_scalar(config.measurement.names[i]) + ": " + yaml_scalar(config.columns.measurements[i]) + "\n";
  }
  if (!config.columns.truth_mode.empty()) out += "  truth_mode: " + yaml_scalar(config.columns.truth_mode) + "\n";
  if (config.columns.carry_truth) out += "  truth_blank: carry\n";
  return out;
}

std::string format_sampling_block(const SamplingConfig& sampling) {
  const SamplingConfig defaults;
  std::string out;
  if (sampling.join == SamplingConfig::Join::kRows) out += "  join: rows\n";
  // Exactly the value stepped at: a rate that read back as another would
  // put the grid elsewhere.
  if (sampling.rate > 0.0) out += "  rate: " + CsvWriter::format(sampling.rate) + "\n";
  if (sampling.max_gap != defaults.max_gap) out += "  max_gap: " + CsvWriter::format(sampling.max_gap) + "\n";
  if (sampling.skip_gaps) out += "  skip_gaps: true\n";
  if (sampling.skip_out_of_order) out += "  skip_out_of_order: true\n";
  return out.empty() ? out : "sampling:\n" + out;
}

std::string format_measurement_block(const BankConfig& config) {
  const MeasurementConfig& m = config.measurement;
  // The state rows; the measured outputs follow them (`outputs:`).
  const Eigen::Index state_rows = m.first_output_row();
  const std::vector<std::string> state_names(m.names.begin(), m.names.begin() + state_rows);
  // `observe:` when every row picks one state by name, as the loader builds it.
  bool observe = true;
  for (Eigen::Index r = 0; r < state_rows && observe; ++r) {
    int picked = -1;
    for (Eigen::Index c = 0; c < m.h.cols(); ++c) {
      if (m.h(r, c) == 1.0 && picked < 0) {
        picked = static_cast<int>(c);
      } else if (m.h(r, c) != 0.0) {
        observe = false;
      }
    }
    observe = observe && picked >= 0 && config.state_names[static_cast<std::size_t>(picked)] == m.names[static_cast<std::size_t>(r)];
  }
  std::string out = "measurement:\n";
  if (observe) {
    out += "  observe: " + join_names(state_names) + "\n";
  } else {
    out += "  H: " + format_matrix(m.h.topRows(state_rows)) + "\n  names: " + join_names(state_names) + "\n";
  }
  if (!m.outputs.empty()) out += "  outputs: " + join_names(m.outputs) + "\n";
  Eigen::MatrixXd r = m.r;
  if (r.size() == 1) return out + "  R: {diagonal: [" + bank_number(r(0, 0)) + "]}\n";
  return out + "  R: " + format_covariance(r) + "\n";
}

std::string format_transition_block(const BankConfig& config) {
  const TransitionConfig& t = config.transition;
  switch (t.kind) {
    case TransitionConfig::Kind::kStay:
      return "transition:\n  stay: " + bank_number(t.stay) + "\n";
    case TransitionConfig::Kind::kMatrix:
      return "transition:\n  matrix: " + format_matrix(t.matrix) + "\n";
    case TransitionConfig::Kind::kDwellTimes:
      if ((t.dwell_seconds.array() == t.dwell_seconds[0]).all()) {
        return "transition:\n  mean_dwell_time: " + bank_number(t.dwell_seconds[0]) + "\n";
      }
      std::string out = "transition:\n  mean_dwell_time: {";
      for (int j = 0; j < config.num_modes(); ++j) {
        out += (j ? ", " : "") + config.modes[static_cast<std::size_t>(j)].name + ": " +
               bank_number(t.dwell_seconds[j]);
      }
      return out + "}\n";
  }
  return "";
}

std::string format_floor_block(const BankConfig& config) {
  return "mode_probability_floor: " + bank_number(config.mode_probability_floor) + "\n";
}

std::string format_likelihood_weight_block(const BankConfig& config) {
  if (config.likelihood_weight == 1.0) return "";
  return "likelihood_weight: " + bank_number(config.likelihood_weight) + "\n";
}

std::string format_likelihood_dof_block(const BankConfig& config) {
  if (config.likelihood_dof <= 0.0) return "";
  return "likelihood_dof: " + bank_number(config.likelihood_dof) + "\n";
}

std::string format_extrapolation_scale_block(const BankConfig& config) {
  if (config.extrapolation_scale <= 0.0) return "";
  return "extrapolation_scale: " + bank_number(config.extrapolation_scale) + "\n";
}

std::string format_unknown_block(const BankConfig& config) {
  if (!config.unknown.enabled()) return "";
  return "unknown: {inflation: " + bank_number(config.unknown.inflation) +
         ", enter: " + bank_number(config.unknown.enter) + ", leave: " + bank_number(config.unknown.leave) + "}\n";
}

}  // namespace fitting
}  // namespace skidimm
