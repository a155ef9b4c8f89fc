#include "skidimm/io/ros/estimate_json.h"

#include <cmath>

#include "skidimm/io/csv.h"
#include "skidimm/io/estimates_writer.h"

namespace skidimm {
namespace ros {

std::string json_string(const std::string& text) {
  std::string out = "\"";
  for (unsigned char c : text) {
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\t':
        out += "\\t";
        break;
      case '\r':
        out += "\\r";
        break;
      default:
        if (c < 0x20) {
          static const char* const kHex = "0123456789abcdef";
          out += "\\u00";
          out += kHex[c >> 4];
          out += kHex[c & 15];
        } else {
          out += static_cast<char>(c);
        }
    }
  }
  return out + "\"";
}

namespace {

void add_number(double value, std::string* out) {
  if (!std::isfinite(value)) {
    out->append("null");
    return;
  }
  char buffer[32];
  char* end = CsvWriter::format(value, buffer, buffer + sizeof(buffer));
  out->append(buffer, static_cast<std::size_t>(end - buffer));
}

std::string object_schema(const std::vector<std::string>& quoted_names, const char* description) {
  std::string out = "{\"type\":\"object\",\"description\":\"" + std::string(description) + "\",\"properties\":{";
  for (std::size_t i = 0; i < quoted_names.size(); ++i) {
    out += (i == 0 ? "" : ",") + quoted_names[i] + ":{\"type\":[\"number\",\"null\"]}";
  }
  return out + "}}";
}

}  // namespace

EstimateJson::EstimateJson(const BankConfig& config, bool with_truth)
    : with_truth_(with_truth), with_unknown_(config.unknown.enabled()) {
  for (const ModeConfig& m : config.modes) {
    mode_names_raw_.push_back(m.name);
    mode_names_.push_back(json_string(m.name));
  }
  for (const std::string& s : config.state_names) state_names_.push_back(json_string(s));
  class_names_ = config.class_names();
  schema_ = "{\"$schema\":\"https://json-schema.org/draft/2020-12/schema\",\"title\":\"skidimm.Estimate\","
            "\"description\":\"One step of skidimm's IMM estimator (docs/foxglove.md)\",\"type\":\"object\","
            "\"properties\":{\"t\":{\"type\":\"number\",\"description\":\"s\"},\"probability\":" +
            object_schema(mode_names_, "probability of each mode") +
            (with_unknown_ ? ",\"unknown_probability\":{\"type\":[\"number\",\"null\"],\"description\":\"probability "
                             "that none of the modes holds (the bank's unknown hypothesis)\"}"
                           : "") +
            ",\"mode\":{\"type\":\"string\",\"description\":\"the most likely mode" +
            (with_unknown_ ? ", or unknown" : "") + "\"},\"mode_index\":{\"type\":\"integer\"" +
            (with_unknown_ ? ",\"description\":\"-1 for unknown\"" : "") + "},"
            "\"decision\":{\"type\":\"string\",\"description\":\"the decision a controller acts on\"},"
            "\"decision_index\":{\"type\":\"integer\",\"description\":\"the decision's class, -1 for unknown\"},"
            "\"state\":" + object_schema(state_names_, "the combined state") + ",\"variance\":" +
            object_schema(state_names_, "the combined state's variances") +
            (with_truth ? ",\"truth_mode\":{\"type\":\"string\"}" : "") +
            ",\"status\":{\"type\":\"string\"},\"reason\":{\"type\":\"string\"}}}";
}

const std::string& EstimateJson::format(double t, const ImmEstimate& e, const std::string& decision,
                                        const std::string& truth) {
  out_.clear();
  out_ += "{\"t\":";
  add_number(t, &out_);
  out_ += ",\"probability\":{";
  for (std::size_t j = 0; j < mode_names_.size(); ++j) {
    if (j > 0) out_ += ',';
    out_ += mode_names_[j];
    out_ += ':';
    add_number(e.mode_probabilities[static_cast<Eigen::Index>(j)], &out_);
  }
  out_ += '}';
  if (with_unknown_) {
    out_ += ",\"unknown_probability\":";
    add_number(e.unknown_probability, &out_);
  }
  // As the estimates file's `mode` column: unknown when "none of these" outweighs every mode.
  const bool unknown = e.unknown_is_most_likely();
  out_ += ",\"mode\":";
  out_ += unknown ? std::string("\"unknown\"") : mode_names_[static_cast<std::size_t>(e.most_likely_mode)];
  out_ += ",\"mode_index\":";
  out_ += std::to_string(unknown ? -1 : e.most_likely_mode);
  out_ += ",\"decision\":";
  out_ += json_string(decision);
  int decision_index = -1;
  for (std::size_t c = 0; c < class_names_.size(); ++c) {
    if (class_names_[c] == decision) decision_index = static_cast<int>(c);
  }
  out_ += ",\"decision_index\":";
  out_ += std::to_string(decision_index);
  out_ += ",\"state\":{";
  for (std::size_t i = 0; i < state_names_.size(); ++i) {
    if (i > 0) out_ += ',';
    out_ += state_names_[i];
    out_ += ':';
    add_number(e.state[static_cast<Eigen::Index>(i)], &out_);
  }
  out_ += "},\"variance\":{";
  for (std::size_t i = 0; i < state_names_.size(); ++i) {
    if (i > 0) out_ += ',';
    out_ += state_names_[i];
    out_ += ':';
    add_number(e.covariance(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(i)), &out_);
  }
  out_ += '}';
  if (with_truth_) {
    out_ += ",\"truth_mode\":";
    out_ += json_string(truth);
  }
  out_ += ",\"status\":\"";
  out_ += to_string(e.status);
  out_ += "\",\"reason\":";
  describe_step(e, mode_names_raw_, &reason_);
  out_ += json_string(reason_);
  out_ += '}';
  return out_;
}

}  // namespace ros
}  // namespace skidimm
