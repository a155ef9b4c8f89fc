// LiveEstimates: `skidimm run --serve [HOST:]PORT`. Each step is published
// as it is computed, as the JSON message of estimate_json.h on
// /skidimm/estimate, to every Foxglove client connected to a
// FoxgloveServer (foxglove_server.h).
//
// Replaying a recorded log (a file), steps are paced to the log's clock,
// `speed` times real time (a person watches the probabilities move as the
// robot drove); 0 publishes as fast as the filter runs. A log read from a
// pipe or standard input is published as it arrives, unpaced: it is already
// live.
#ifndef SKIDIMM_IO_ROS_LIVE_ESTIMATES_H_
#define SKIDIMM_IO_ROS_LIVE_ESTIMATES_H_

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "skidimm/config/bank.h"
#include "skidimm/engine/imm_estimate.h"
#include "skidimm/io/ros/estimate_json.h"
#include "skidimm/io/ros/foxglove_server.h"
#include "skidimm/io/ros/replay_pacer.h"

namespace skidimm {
namespace ros {

class LiveEstimates {
 public:
  // Listens (FoxgloveServer; throws Error when it cannot) before the log is
  // opened: a log coming through a pipe may wait for its first line.
  LiveEstimates(const std::string& host, std::uint16_t port, const std::string& bank_name);

  std::uint16_t port() const { return server_.port(); }
  // Advertises /skidimm/estimate for `config`'s modes and states, once the
  // log is open. `speed` <= 0: unpaced.
  void advertise(const BankConfig& config, bool with_truth, double speed);
  // Publishes one step, first waiting for the log's clock when paced
  // (ReplayPacer). A stop request (stop_request.h) ends the wait: the row is
  // published at once, and the run stops at its next row.
  void publish(double t, const ImmEstimate& estimate, const std::string& decision, const std::string& truth);
  // Messages a client that fell behind did not get.
  long dropped() const { return server_.dropped(); }
  // Sends what is queued (at most `seconds`), then closes every connection.
  void close(double seconds = 2.0) { server_.close(seconds); }

  // "[HOST:]PORT" as --serve takes it; HOST defaults to 127.0.0.1 (this
  // machine only; 0.0.0.0 for every interface). Throws Error.
  static void parse_address(const std::string& text, std::string* host, std::uint16_t* port);

 private:
  FoxgloveServer server_;
  std::unique_ptr<EstimateJson> json_;
  std::uint32_t channel_ = 0;
  std::optional<ReplayPacer> pacer_;  // when paced
};

}  // namespace ros
}  // namespace skidimm

#endif  // SKIDIMM_IO_ROS_LIVE_ESTIMATES_H_
