// The storages behind BagReader::open (bag_reader.h): private to core.
#ifndef SKIDIMM_CORE_SRC_ROS_BAG_STORAGE_H_
#define SKIDIMM_CORE_SRC_ROS_BAG_STORAGE_H_

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "skidimm/io/ros/bag_reader.h"

namespace skidimm {
namespace ros {

// What a bag directory's metadata.yaml says (rosbag2_bagfile_information).
struct BagMetadata {
  std::filesystem::path file;  // the metadata.yaml
  std::string storage_identifier;  // "mcap", "sqlite3"
  std::vector<std::filesystem::path> files;  // absolute, in order
  std::string compression_format;  // "" or "zstd"
  std::string compression_mode;    // "", "FILE" or "MESSAGE"
};

// Reads metadata.yaml. Throws LogError naming it and the key.
BagMetadata read_bag_metadata(const std::filesystem::path& file);

std::unique_ptr<BagReader> open_mcap_bag(const std::filesystem::path& path, const std::vector<std::filesystem::path>& files);
std::unique_ptr<BagReader> open_sqlite_bag(const std::filesystem::path& path, const BagMetadata& metadata);

}  // namespace ros
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_ROS_BAG_STORAGE_H_
