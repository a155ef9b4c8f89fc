// EstimateJson: one filter step as the JSON message skidimm publishes to
// Foxglove, in an MCAP file (run --output estimates.mcap) or live over its
// WebSocket protocol (run --serve). Topic /skidimm/estimate, schema
// "skidimm.Estimate" (a JSON Schema), one message per step:
//
//   {"t": 12.5,                                   s, the step's time
//    "probability": {"asphalt": 0.91, ...},       per mode, bank order
//    "mode": "asphalt", "mode_index": 0,          the most likely mode
//    "decision": "asphalt", "decision_index": 0,  the decision (decision.h); unknown: -1
//    "state": {"V": 0.4, ...}, "variance": {"V": 0.01, ...},
//    "truth_mode": "grass",                       when the log has a truth
//    "status": "updated", "reason": ""}
//
// Numbers are the shortest text that reads back to the same double (as the
// CSV output); a value that is not finite is null. Foxglove plots any of
// them by path, e.g. /skidimm/estimate.probability.asphalt, with no set-up
// (docs/foxglove.md).
#ifndef SKIDIMM_IO_ROS_ESTIMATE_JSON_H_
#define SKIDIMM_IO_ROS_ESTIMATE_JSON_H_

#include <string>
#include <vector>

#include "skidimm/config/bank.h"
#include "skidimm/engine/imm_estimate.h"

namespace skidimm {
namespace ros {

constexpr const char* kEstimateTopic = "/skidimm/estimate";
constexpr const char* kEstimateSchemaName = "skidimm.Estimate";

class EstimateJson {
 public:
  EstimateJson(const BankConfig& config, bool with_truth);

  // The JSON Schema of the messages.
  const std::string& schema() const { return schema_; }
  // One step, into a buffer the object reuses (valid until the next call).
  const std::string& format(double t, const ImmEstimate& estimate, const std::string& decision,
                            const std::string& truth);

 private:
  std::vector<std::string> mode_names_raw_;
  std::vector<std::string> mode_names_;   // quoted JSON strings
  std::vector<std::string> state_names_;  // quoted
  std::vector<std::string> class_names_;  // unquoted, to find the decision's index
  bool with_truth_;
  bool with_unknown_;  // the bank has an unknown hypothesis: its probability is a field
  std::string schema_;
  std::string out_;
  std::string reason_;
};

// `text` as a JSON string literal, quotes included.
std::string json_string(const std::string& text);

}  // namespace ros
}  // namespace skidimm

#endif  // SKIDIMM_IO_ROS_ESTIMATE_JSON_H_
