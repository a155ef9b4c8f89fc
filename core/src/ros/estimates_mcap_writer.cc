#include "estimates_mcap_writer.h"

#include <cmath>

#include "bag_log.h"
#include "bundled_message_definitions.h"
#include "skidimm/errors.h"
#include "skidimm/io/csv.h"
#include "skidimm/io/ros/bag_reader.h"

namespace skidimm {
namespace ros {

std::uint64_t nanoseconds_from_seconds(double t) {
  if (!(t > 0.0)) return 0;
  const double ns = std::round(t * 1e9);
  if (ns >= 1.8e19) return std::uint64_t{18000000000000000000u};
  return static_cast<std::uint64_t>(ns);
}

namespace {

McapWriter::Options estimates_options() {
  McapWriter::Options options;
  options.library = "skidimm";
  return options;
}

}  // namespace

EstimatesMcapWriter::EstimatesMcapWriter(const std::filesystem::path& path, const BankConfig& config, bool with_truth)
    : writer_(path, estimates_options()), json_(config, with_truth) {
  const std::uint16_t schema = writer_.add_schema(kEstimateSchemaName, "jsonschema", json_.schema());
  channel_ = writer_.add_channel(kEstimateTopic, "json", schema, {{"bank", config.name}});
}

void EstimatesMcapWriter::write(double t, const ImmEstimate& estimate, const std::string& decision,
                                const std::string& truth) {
  // A time the log-time field cannot hold is not clamped: every such step
  // would land on one instant, and Foxglove draw the run as a point.
  if (!(t >= 0.0 && t < 1.8e10)) {
    throw Error("the step at t = " + CsvWriter::format(t) +
                " s cannot be written to an MCAP file, whose log times are nanoseconds from 0 to 1.8e10 s: shift the "
                "log's clock (FILE@OFFSET), or write CSV or .npy");
  }
  const std::string& message = json_.format(t, estimate, decision, truth);
  const std::uint64_t ns = nanoseconds_from_seconds(t);
  writer_.write(channel_, ns, ns, message.data(), message.size());
}

void EstimatesMcapWriter::copy_topics(const std::filesystem::path& bag_path,
                                      const std::vector<std::string>& column_texts) {
  const auto bag = BagReader::open(bag_path);
  const std::vector<int> topics = topics_named(*bag, column_texts);
  std::vector<int> channel_of(bag->topics().size(), -1);
  for (int topic : topics) {
    const BagTopic& t = bag->topics()[static_cast<std::size_t>(topic)];
    std::string definition = t.definition;
    std::string encoding = t.definition_encoding;
    if ((definition.empty() || encoding != "ros2msg") && is_bundled_message_type(t.type)) {
      definition = bundled_complete_definition(t.type);
      encoding = "ros2msg";
    }
    const std::uint16_t schema = writer_.add_schema(t.type, encoding, definition);
    channel_of[static_cast<std::size_t>(topic)] = writer_.add_channel(t.name, t.serialization_format, schema);
  }
  BagMessage m;
  while (bag->next(&m)) {
    const int channel = channel_of[static_cast<std::size_t>(m.topic)];
    if (channel >= 0) writer_.write(static_cast<std::uint16_t>(channel), m.log_time, m.log_time, m.data, m.size);
  }
}

}  // namespace ros
}  // namespace skidimm
