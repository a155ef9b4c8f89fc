#include "skidimm/io/ros/live_estimates.h"

#include <algorithm>
#include <charconv>
#include <thread>

#include "estimates_mcap_writer.h"
#include "skidimm/errors.h"
#include "skidimm/stop_request.h"

namespace skidimm {
namespace ros {

LiveEstimates::LiveEstimates(const std::string& host, std::uint16_t port, const std::string& bank_name)
    : server_(host, port, "skidimm: " + bank_name) {}

void LiveEstimates::advertise(const BankConfig& config, bool with_truth, double speed) {
  json_ = std::make_unique<EstimateJson>(config, with_truth);
  pacer_.reset();
  if (speed > 0.0) pacer_.emplace(speed);
  channel_ = server_.add_channel(kEstimateTopic, "json", kEstimateSchemaName, json_->schema(), "jsonschema");
}

void LiveEstimates::publish(double t, const ImmEstimate& estimate, const std::string& decision,
                            const std::string& truth) {
  if (pacer_) {
    using Clock = ReplayPacer::Clock;
    const Clock::time_point due = pacer_->due(t, Clock::now());
    // In slices, so that a Ctrl-C during a slow replay's long wait is heard.
    constexpr auto kSlice = std::chrono::milliseconds(100);
    for (Clock::time_point now = Clock::now(); now < due && stop_requested() == 0; now = Clock::now()) {
      std::this_thread::sleep_until(std::min(due, now + kSlice));
    }
  }
  if (!json_) return;
  server_.publish(channel_, nanoseconds_from_seconds(t), json_->format(t, estimate, decision, truth));
}

void LiveEstimates::parse_address(const std::string& text, std::string* host, std::uint16_t* port) {
  const auto colon = text.rfind(':');
  *host = colon == std::string::npos ? "127.0.0.1" : text.substr(0, colon);
  const std::string number = colon == std::string::npos ? text : text.substr(colon + 1);
  unsigned value = 0;
  const auto parsed = std::from_chars(number.data(), number.data() + number.size(), value);
  if (number.empty() || parsed.ec != std::errc() || parsed.ptr != number.data() + number.size() || value > 65535 ||
      host->empty()) {
    throw Error("--serve '" + text + "': expected [HOST:]PORT, a port from 0 (any free port) to 65535");
  }
  *port = static_cast<std::uint16_t>(value);
}

}  // namespace ros
}  // namespace skidimm
