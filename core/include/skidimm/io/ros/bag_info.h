// What `skidimm bag FILE` prints: a bag's storage, time span, topics (type,
// message count, rate, which time a bank gets from them) and the column
// paths a bank can name, like `ros2 bag info` with the paths added.
#ifndef SKIDIMM_IO_ROS_BAG_INFO_H_
#define SKIDIMM_IO_ROS_BAG_INFO_H_

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace skidimm {
namespace ros {

struct BagTopicInfo {
  std::string name;
  std::string type;
  std::string serialization_format;
  std::uint64_t messages = 0;
  std::uint64_t first_log_time = 0;  // ns
  std::uint64_t last_log_time = 0;
  double rate = 0.0;  // Hz over the log times; 0 with fewer than two messages
  bool has_header = false;  // its time is header.stamp (else its log time)
  std::string definition;  // "stored (ros2msg)", "bundled", or why it cannot be read
  std::vector<std::string> columns;  // full paths a bank can name; JointState-like names filled in
};

struct BagInfo {
  std::filesystem::path path;
  std::string storage;  // "mcap (zstd chunks, indexed)"
  std::vector<std::pair<std::filesystem::path, std::uintmax_t>> files;  // with sizes
  std::uint64_t messages = 0;
  std::uint64_t start = 0, end = 0;  // ns, log times
  std::vector<BagTopicInfo> topics;
  std::string problem;  // an error met reading the messages (a file cut short): the counts stop there
};

// Reads the whole bag (counting, timing, and decoding each topic's first
// message for the names its sequences are indexed by). Throws LogError when
// the bag cannot be opened; a problem found later is kept in `problem`.
BagInfo describe_bag(const std::filesystem::path& path);

// The report `skidimm bag` prints.
std::string format_bag_info(const BagInfo& info);

}  // namespace ros
}  // namespace skidimm

#endif  // SKIDIMM_IO_ROS_BAG_INFO_H_
