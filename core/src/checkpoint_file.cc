#include "skidimm/io/checkpoint_file.h"

#include <yaml-cpp/yaml.h>

#include <array>
#include <charconv>
#include <climits>
#include <cmath>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "number_text.h"
#include "skidimm/errors.h"
#include "skidimm/io/output_file.h"
#include "yaml_fields.h"

namespace skidimm {

namespace {

constexpr int kFormatVersion = 1;

constexpr std::array<StepStatus, 8> kStatuses = {
    StepStatus::kUpdated,       StepStatus::kPredictOnly, StepStatus::kAllModesRejected, StepStatus::kRejectedTime,
    StepStatus::kRejectedInput, StepStatus::kGated,       StepStatus::kModeGated,        StepStatus::kModeReset};

// ModeFailure in the file: short names, not to_string()'s sentences.
constexpr std::array<std::pair<ModeFailure, const char*>, kNumModeFailures> kFailures = {{
    {ModeFailure::kNone, "none"},
    {ModeFailure::kModel, "model"},
    {ModeFailure::kNotFinite, "not_finite"},
    {ModeFailure::kUpdate, "update"},
    {ModeFailure::kDiverged, "diverged"},
    {ModeFailure::kGated, "gated"},
}};

const char* failure_name(ModeFailure failure) {
  for (const auto& [value, name] : kFailures) {
    if (value == failure) return name;
  }
  return "none";
}

// The shortest text that reads back to `value`; YAML's names for the others.
std::string number(double value) {
  if (std::isnan(value)) return ".nan";
  if (std::isinf(value)) return value > 0 ? ".inf" : "-.inf";
  char text[64];
  char* end = number_text::shortest_to_chars(text, text + sizeof text, value);
  return std::string(text, end);
}

YAML::Emitter& numbers(YAML::Emitter& out, const double* values, Eigen::Index count) {
  out << YAML::Flow << YAML::BeginSeq;
  for (Eigen::Index i = 0; i < count; ++i) out << number(values[i]);
  out << YAML::EndSeq;
  return out;
}

void vector(YAML::Emitter& out, const Eigen::VectorXd& v) { numbers(out, v.data(), v.size()); }

void matrix(YAML::Emitter& out, const Eigen::MatrixXd& m) {
  out << YAML::BeginSeq;
  for (Eigen::Index i = 0; i < m.rows(); ++i) {
    const Eigen::VectorXd row = m.row(i).transpose();
    vector(out, row);
  }
  out << YAML::EndSeq;
}

void names(YAML::Emitter& out, const std::vector<std::string>& list) {
  out << YAML::Flow << YAML::BeginSeq;
  for (const std::string& name : list) out << YAML::DoubleQuoted << name;
  out << YAML::EndSeq;
}

// Reading, over YamlFields' errors (file, line, field).
class Reader {
 public:
  explicit Reader(const std::string& name) : fields_(name) {}

  const internal::YamlFields& fields() const { return fields_; }

  YAML::Node child(const YAML::Node& map, const std::string& key, const std::string& field) const {
    return fields_.required(map, key, field);
  }

  double number(const YAML::Node& node, const std::string& field) const {
    if (!node.IsScalar()) fields_.fail(node, field, "expected a number");
    const std::string& text = node.Scalar();
    if (text == ".nan" || text == ".NaN" || text == ".NAN") return std::numeric_limits<double>::quiet_NaN();
    if (text == ".inf" || text == "+.inf" || text == ".Inf") return std::numeric_limits<double>::infinity();
    if (text == "-.inf" || text == "-.Inf") return -std::numeric_limits<double>::infinity();
    double value = 0.0;
    const char* first = text.data();
    const char* last = first + text.size();
    if (first != last && *first == '+') ++first;
    const auto [end, error] = std::from_chars(first, last, value);
    if (error != std::errc() || end != last || first == last) {
      fields_.fail(node, field, "expected a number, got '" + text + "'");
    }
    return value;
  }

  // A whole number in [lowest, highest] (an int's range unless told).
  long integer(const YAML::Node& node, const std::string& field, double lowest = INT_MIN,
               double highest = INT_MAX) const {
    const double value = number(node, field);
    if (!(value >= lowest && value <= highest) || value != std::floor(value)) {
      fields_.fail(node, field,
                   "expected a whole number from " + number_text_of(lowest) + " to " + number_text_of(highest) +
                       ", got '" + node.Scalar() + "'");
    }
    return static_cast<long>(value);
  }

  static std::string number_text_of(double value) { return std::to_string(static_cast<long long>(value)); }

  bool boolean(const YAML::Node& node, const std::string& field) const {
    if (node.IsScalar() && node.Scalar() == "true") return true;
    if (node.IsScalar() && node.Scalar() == "false") return false;
    fields_.fail(node, field, "expected true or false");
  }

  std::string string(const YAML::Node& node, const std::string& field) const { return fields_.string(node, field); }

  YAML::Node sequence(const YAML::Node& node, const std::string& field, std::size_t size = kAnySize) const {
    if (!node.IsSequence()) fields_.fail(node, field, "expected a list");
    if (size != kAnySize && node.size() != size) {
      fields_.fail(node, field, "expected " + std::to_string(size) + " entries, got " + std::to_string(node.size()));
    }
    return node;
  }

  Eigen::VectorXd vector(const YAML::Node& node, const std::string& field, std::size_t size = kAnySize) const {
    sequence(node, field, size);
    Eigen::VectorXd v(static_cast<Eigen::Index>(node.size()));
    for (std::size_t i = 0; i < node.size(); ++i) v[static_cast<Eigen::Index>(i)] = number(node[i], item(field, i));
    return v;
  }

  Eigen::MatrixXd matrix(const YAML::Node& node, const std::string& field, std::size_t size) const {
    sequence(node, field, size);
    Eigen::MatrixXd m(static_cast<Eigen::Index>(size), static_cast<Eigen::Index>(size));
    for (std::size_t i = 0; i < size; ++i) m.row(static_cast<Eigen::Index>(i)) = vector(node[i], item(field, i), size);
    return m;
  }

  std::vector<std::string> names(const YAML::Node& node, const std::string& field) const {
    return fields_.string_list(node, field);
  }

  static std::string item(const std::string& field, std::size_t i) { return field + "[" + std::to_string(i) + "]"; }

  static constexpr std::size_t kAnySize = static_cast<std::size_t>(-1);

 private:
  internal::YamlFields fields_;
};

ModeDecision::Memory read_decision(const Reader& in, const YAML::Node& node, const std::string& field) {
  in.fields().check_keys(node,
                         {"decision", "decided_at", "below_leave", "below_leave_since", "measured_once",
                          "last_measured_t", "class_probabilities"},
                         field);
  ModeDecision::Memory memory;
  memory.decision = in.string(in.child(node, "decision", field), field + ".decision");
  memory.decided_at = in.number(in.child(node, "decided_at", field), field + ".decided_at");
  memory.below_leave = in.boolean(in.child(node, "below_leave", field), field + ".below_leave");
  memory.below_leave_since = in.number(in.child(node, "below_leave_since", field), field + ".below_leave_since");
  memory.measured_once = in.boolean(in.child(node, "measured_once", field), field + ".measured_once");
  memory.last_measured_t = in.number(in.child(node, "last_measured_t", field), field + ".last_measured_t");
  memory.class_probabilities = in.vector(in.child(node, "class_probabilities", field), field + ".class_probabilities");
  return memory;
}

}  // namespace

std::string checkpoint_text(const ImmCheckpoint& c) {
  const ImmEstimate& e = c.estimate;
  YAML::Emitter out;
  out << YAML::Comment("skidimm checkpoint: a filter's state after its last step (docs/engine.md, Checkpoints)");
  out << YAML::BeginMap;
  out << YAML::Key << "skidimm_checkpoint" << YAML::Value << kFormatVersion;
  out << YAML::Key << "bank" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "modes" << YAML::Value;
  names(out, c.mode_names);
  out << YAML::Key << "states" << YAML::Value;
  names(out, c.state_names);
  out << YAML::Key << "inputs" << YAML::Value;
  names(out, c.input_names);
  out << YAML::Key << "measurement_rows" << YAML::Value << c.measurement_rows;
  out << YAML::EndMap;
  out << YAML::Key << "started" << YAML::Value << c.started;
  out << YAML::Key << "t" << YAML::Value << number(c.t);
  out << YAML::Key << "held_input" << YAML::Value;
  vector(out, c.held_input);

  out << YAML::Key << "estimate" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "t" << YAML::Value << number(e.t);
  out << YAML::Key << "status" << YAML::Value << to_string(e.status);
  out << YAML::Key << "num_measured" << YAML::Value << e.num_measured;
  out << YAML::Key << "num_rejected_modes" << YAML::Value << e.num_rejected_modes;
  out << YAML::Key << "num_gated_modes" << YAML::Value << e.num_gated_modes;
  out << YAML::Key << "mode_probabilities" << YAML::Value;
  vector(out, e.mode_probabilities);
  out << YAML::Key << "unknown_probability" << YAML::Value << number(e.unknown_probability);
  out << YAML::Key << "most_likely_mode" << YAML::Value << e.most_likely_mode;
  out << YAML::Key << "log_likelihoods" << YAML::Value;
  vector(out, e.log_likelihoods);
  out << YAML::Key << "nis" << YAML::Value;
  vector(out, e.nis);
  out << YAML::Key << "mode_failures" << YAML::Value << YAML::Flow << YAML::BeginSeq;
  for (ModeFailure failure : e.mode_failures) out << failure_name(failure);
  out << YAML::EndSeq;
  out << YAML::Key << "failure_reasons" << YAML::Value;
  names(out, e.failure_reasons);
  out << YAML::Key << "mode_states" << YAML::Value << YAML::BeginSeq;
  for (const Eigen::VectorXd& x : e.mode_states) vector(out, x);
  out << YAML::EndSeq;
  out << YAML::Key << "mode_covariances" << YAML::Value << YAML::BeginSeq;
  for (const Eigen::MatrixXd& p : e.mode_covariances) matrix(out, p);
  out << YAML::EndSeq;
  out << YAML::Key << "state" << YAML::Value;
  vector(out, e.state);
  out << YAML::Key << "covariance" << YAML::Value;
  matrix(out, e.covariance);
  out << YAML::EndMap;

  out << YAML::Key << "innovations" << YAML::Value << YAML::BeginSeq;
  for (const InnovationMemory& memory : c.innovations) {
    out << YAML::Flow << YAML::BeginMap;
    out << YAML::Key << "remembers" << YAML::Value << memory.remembers;
    out << YAML::Key << "steps_since" << YAML::Value << memory.steps_since;
    out << YAML::Key << "rows" << YAML::Value << YAML::Flow << YAML::BeginSeq;
    for (int row : memory.rows) out << row;
    out << YAML::EndSeq;
    out << YAML::Key << "whitened" << YAML::Value;
    numbers(out, memory.whitened.data(), static_cast<Eigen::Index>(memory.whitened.size()));
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
  const ModeTransition::AnchorMemory& anchors = c.transition_anchors;
  out << YAML::Key << "transition_anchors" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "dt" << YAML::Value;
  numbers(out, anchors.dt.data(), static_cast<Eigen::Index>(anchors.dt.size()));
  out << YAML::Key << "used" << YAML::Value << YAML::Flow << YAML::BeginSeq;
  for (long used : anchors.used) out << used;
  out << YAML::EndSeq;
  out << YAML::Key << "uses" << YAML::Value << anchors.uses;
  out << YAML::EndMap;

  if (c.decision) {
    const ModeDecision::Memory& d = *c.decision;
    out << YAML::Key << "decision" << YAML::Value << YAML::BeginMap;
    out << YAML::Key << "decision" << YAML::Value << YAML::DoubleQuoted << d.decision;
    out << YAML::Key << "decided_at" << YAML::Value << number(d.decided_at);
    out << YAML::Key << "below_leave" << YAML::Value << d.below_leave;
    out << YAML::Key << "below_leave_since" << YAML::Value << number(d.below_leave_since);
    out << YAML::Key << "measured_once" << YAML::Value << d.measured_once;
    out << YAML::Key << "last_measured_t" << YAML::Value << number(d.last_measured_t);
    out << YAML::Key << "class_probabilities" << YAML::Value;
    vector(out, d.class_probabilities);
    out << YAML::EndMap;
  }
  out << YAML::EndMap;
  if (!out.good()) throw Error(std::string("cannot write the checkpoint: ") + out.GetLastError());
  return std::string(out.c_str()) + "\n";
}

void save_checkpoint(const std::filesystem::path& path, const ImmCheckpoint& checkpoint) {
  const std::string text = checkpoint_text(checkpoint);
  OutputFile file(path);
  file.write(text);
  file.commit();
}

ImmCheckpoint parse_checkpoint(const std::string& text, const std::string& name) {
  const Reader in(name);
  const internal::YamlFields& fields = in.fields();
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::ParserException& e) {
    throw ConfigError(name, e.mark.line + 1, "", "malformed YAML: " + e.msg);
  } catch (const YAML::Exception& e) {
    throw ConfigError(name, 0, "", std::string("cannot read YAML: ") + e.what());
  }
  if (!root.IsMap()) throw ConfigError(name, 1, "", "a checkpoint file must be a YAML mapping");
  std::set<int> visited;
  fields.reject_duplicate_keys(root, "", &visited);
  const YAML::Node version = root["skidimm_checkpoint"];
  if (!version) {
    throw ConfigError(name, 1, "skidimm_checkpoint",
                      "missing: not a checkpoint written by skidimm (run --save-checkpoint, Imm.checkpoint())");
  }
  if (in.integer(version, "skidimm_checkpoint") != kFormatVersion) {
    fields.fail(
        version, "skidimm_checkpoint",
        "version " + version.Scalar() + " is not one this skidimm reads (" + std::to_string(kFormatVersion) + ")");
  }
  fields.check_keys(root,
                    {"skidimm_checkpoint", "bank", "started", "t", "held_input", "estimate", "innovations",
                     "transition_anchors", "decision"},
                    "");
  ImmCheckpoint c;
  const YAML::Node bank = in.child(root, "bank", "");
  fields.check_keys(bank, {"modes", "states", "inputs", "measurement_rows"}, "bank");
  c.mode_names = in.names(in.child(bank, "modes", "bank"), "bank.modes");
  c.state_names = in.names(in.child(bank, "states", "bank"), "bank.states");
  c.input_names = in.names(in.child(bank, "inputs", "bank"), "bank.inputs");
  c.measurement_rows =
      static_cast<int>(in.integer(in.child(bank, "measurement_rows", "bank"), "bank.measurement_rows"));
  const std::size_t modes = c.mode_names.size(), n = c.state_names.size();
  c.started = in.boolean(in.child(root, "started", ""), "started");
  c.t = in.number(in.child(root, "t", ""), "t");
  c.held_input = in.vector(in.child(root, "held_input", ""), "held_input", c.input_names.size());

  const YAML::Node estimate = in.child(root, "estimate", "");
  fields.check_keys(estimate,
                    {"t", "status", "num_measured", "num_rejected_modes", "num_gated_modes", "mode_probabilities",
                     "unknown_probability", "most_likely_mode", "log_likelihoods", "nis", "mode_failures",
                     "failure_reasons", "mode_states", "mode_covariances", "state", "covariance"},
                    "estimate");
  ImmEstimate& e = c.estimate;
  const auto field = [&](const char* key) { return in.child(estimate, key, "estimate"); };
  const auto name_of = [](const char* key) { return std::string("estimate.") + key; };
  e.t = in.number(field("t"), name_of("t"));
  {
    const std::string status = in.string(field("status"), name_of("status"));
    bool known = false;
    for (StepStatus s : kStatuses) {
      if (status == to_string(s)) {
        e.status = s;
        known = true;
      }
    }
    if (!known) fields.fail(field("status"), name_of("status"), "not a step status: '" + status + "'");
  }
  e.num_measured = static_cast<int>(in.integer(field("num_measured"), name_of("num_measured")));
  e.num_rejected_modes = static_cast<int>(in.integer(field("num_rejected_modes"), name_of("num_rejected_modes")));
  e.num_gated_modes = static_cast<int>(in.integer(field("num_gated_modes"), name_of("num_gated_modes")));
  e.mode_probabilities = in.vector(field("mode_probabilities"), name_of("mode_probabilities"), modes);
  e.unknown_probability = in.number(field("unknown_probability"), name_of("unknown_probability"));
  e.most_likely_mode = static_cast<int>(in.integer(field("most_likely_mode"), name_of("most_likely_mode")));
  e.log_likelihoods = in.vector(field("log_likelihoods"), name_of("log_likelihoods"), modes);
  e.nis = in.vector(field("nis"), name_of("nis"), modes);
  {
    const YAML::Node failures = in.sequence(field("mode_failures"), name_of("mode_failures"), modes);
    for (std::size_t j = 0; j < modes; ++j) {
      const std::string where = Reader::item(name_of("mode_failures"), j);
      const std::string text = in.string(failures[j], where);
      bool known = false;
      for (const auto& [value, failure] : kFailures) {
        if (text == failure) {
          e.mode_failures.push_back(value);
          known = true;
        }
      }
      if (!known) fields.fail(failures[j], where, "not a mode failure: '" + text + "'");
    }
  }
  e.failure_reasons =
      in.names(in.sequence(field("failure_reasons"), name_of("failure_reasons"), modes), name_of("failure_reasons"));
  {
    const YAML::Node states = in.sequence(field("mode_states"), name_of("mode_states"), modes);
    const YAML::Node covariances = in.sequence(field("mode_covariances"), name_of("mode_covariances"), modes);
    for (std::size_t j = 0; j < modes; ++j) {
      e.mode_states.push_back(in.vector(states[j], Reader::item(name_of("mode_states"), j), n));
      e.mode_covariances.push_back(in.matrix(covariances[j], Reader::item(name_of("mode_covariances"), j), n));
    }
  }
  e.state = in.vector(field("state"), name_of("state"), n);
  e.covariance = in.matrix(field("covariance"), name_of("covariance"), n);

  const YAML::Node innovations = in.sequence(in.child(root, "innovations", ""), "innovations");
  for (std::size_t j = 0; j < innovations.size(); ++j) {
    const std::string where = Reader::item("innovations", j);
    const YAML::Node node = innovations[j];
    fields.check_keys(node, {"remembers", "steps_since", "rows", "whitened"}, where);
    InnovationMemory memory;
    memory.remembers = in.boolean(in.child(node, "remembers", where), where + ".remembers");
    memory.steps_since = static_cast<int>(in.integer(in.child(node, "steps_since", where), where + ".steps_since"));
    const YAML::Node rows = in.sequence(in.child(node, "rows", where), where + ".rows");
    for (std::size_t a = 0; a < rows.size(); ++a) {
      memory.rows.push_back(static_cast<int>(in.integer(rows[a], Reader::item(where + ".rows", a))));
    }
    const Eigen::VectorXd whitened = in.vector(in.child(node, "whitened", where), where + ".whitened", rows.size());
    memory.whitened.assign(whitened.data(), whitened.data() + whitened.size());
    c.innovations.push_back(std::move(memory));
  }
  const YAML::Node anchors = in.child(root, "transition_anchors", "");
  fields.check_keys(anchors, {"dt", "used", "uses"}, "transition_anchors");
  const Eigen::VectorXd dt = in.vector(in.child(anchors, "dt", "transition_anchors"), "transition_anchors.dt");
  c.transition_anchors.dt.assign(dt.data(), dt.data() + dt.size());
  const YAML::Node used =
      in.sequence(in.child(anchors, "used", "transition_anchors"), "transition_anchors.used", dt.size());
  for (std::size_t a = 0; a < used.size(); ++a) {
    c.transition_anchors.used.push_back(in.integer(used[a], Reader::item("transition_anchors.used", a), 0, 9.0e15));
  }
  c.transition_anchors.uses =
      in.integer(in.child(anchors, "uses", "transition_anchors"), "transition_anchors.uses", 0, 9.0e15);
  if (const YAML::Node decision = root["decision"]) c.decision = read_decision(in, decision, "decision");
  return c;
}

ImmCheckpoint load_checkpoint(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    throw ConfigError(path.string(), 0, "",
                      std::filesystem::exists(path, ec) ? "is not a regular file" : "no such checkpoint file");
  }
  std::ifstream file(path, std::ios::binary);
  std::ostringstream text;
  text << file.rdbuf();
  if (!file && !file.eof()) throw ConfigError(path.string(), 0, "", "cannot read the checkpoint file");
  return parse_checkpoint(text.str(), path.string());
}

}  // namespace skidimm
