#include "skidimm/io/ros/live_estimates.h"

#include <charconv>
#include <thread>

#include "estimates_mcap_writer.h"
#include "skidimm/errors.h"

namespace skidimm {
namespace ros {

LiveEstimates::LiveEstimates(const std::string& host, std::uint16_t port, const std::string& bank_name)
    : server_(host, port, "skidimm: " + bank_name) {}

void LiveEstimates::advertise(const BankConfig& config, bool with_truth, double speed) {
  json_ = std::make_unique<EstimateJson>(config, with_truth);
  speed_ = speed;
  channel_ = server_.add_channel(kEstimateTopic, "json", kEstimateSchemaName, json_->schema(), "jsonschema");
}

void LiveEstimates::publish(double t, const ImmEstimate& estimate, const std::string& decision,
                            const std::string& truth) {
  if (speed_ > 0.0) {
    if (!started_) {
      started_ = true;
      first_t_ = t;
      start_ = std::chrono::steady_clock::now();
    } else {
      // Never sleeps for a backwards or absurd time jump longer than a minute.
      const double wait = std::min((t - first_t_) / speed_, 1e9);
      const auto due = start_ + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                    std::chrono::duration<double>(wait));
      const auto now = std::chrono::steady_clock::now();
      if (due > now + std::chrono::seconds(60)) {
        start_ = now - std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                           std::chrono::duration<double>((t - first_t_) / speed_));
      } else if (due > now) {
        std::this_thread::sleep_until(due);
      }
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
