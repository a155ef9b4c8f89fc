// EstimatesMcapWriter: `skidimm run --output estimates.mcap`. Every step as a
// JSON message on /skidimm/estimate (estimate_json.h), which Foxglove plots
// with no set-up, at the step's time (its log and publish time: t in
// nanoseconds, 0 for a negative t), in zstd chunks with a full summary
// (mcap_writer.h). With copy_topics(), the bag topics the bank read are
// copied alongside, with their message definitions, so one file shows the
// robot's data and the estimates together.
//
// Written as "<path>.partial", renamed by commit(); destroyed without
// commit(), the file is finished as it is and kept as "<path>.partial".
#ifndef SKIDIMM_CORE_SRC_ROS_ESTIMATES_MCAP_WRITER_H_
#define SKIDIMM_CORE_SRC_ROS_ESTIMATES_MCAP_WRITER_H_

#include <filesystem>
#include <string>
#include <vector>

#include "mcap_writer.h"
#include "skidimm/config/bank.h"
#include "skidimm/engine/imm_estimate.h"
#include "skidimm/io/ros/estimate_json.h"

namespace skidimm {
namespace ros {

class EstimatesMcapWriter {
 public:
  EstimatesMcapWriter(const std::filesystem::path& path, const BankConfig& config, bool with_truth);

  void write(double t, const ImmEstimate& estimate, const std::string& decision, const std::string& truth);
  // Copies the messages of the topics of `bag` that `column_texts` name
  // (bag_log.h), as they are (CDR), with their definitions. Throws LogError.
  void copy_topics(const std::filesystem::path& bag, const std::vector<std::string>& column_texts);
  void commit() { writer_.commit(); }
  const std::filesystem::path& partial_path() const { return writer_.partial_path(); }

  static bool is_mcap(const std::filesystem::path& path) { return path.extension() == ".mcap"; }

 private:
  McapWriter writer_;
  EstimateJson json_;
  std::uint16_t channel_ = 0;
};

// A step's time in nanoseconds for MCAP (the live server's stamps): 0 for
// negative or non-finite times, clamped at 1.8e19. EstimatesMcapWriter::write()
// refuses such times instead.
std::uint64_t nanoseconds_from_seconds(double t);

}  // namespace ros
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_ROS_ESTIMATES_MCAP_WRITER_H_
