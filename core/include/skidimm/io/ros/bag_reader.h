// BagReader: the messages of a ROS 2 bag, whatever its storage:
//  * an MCAP file (.mcap, rosbag2's default since Iron): mcap_reader.h;
//  * a SQLite 3 file (.db3, the default before), which needs the bag's
//    metadata.yaml beside it (it says how messages are stored: compression,
//    the split files);
//  * a bag directory (metadata.yaml and its files, split bags included: the
//    files in the order metadata.yaml lists them).
// Messages come in storage order (log time for rosbag2), with their topic,
// log time and serialized bytes. Each topic has its type, serialization
// format and, where the bag stores one, its message definition (MCAP schema
// records; the message_definitions table of .db3 files from Iron on).
//
// Errors are LogErrors naming the file (and record or table).
#ifndef SKIDIMM_IO_ROS_BAG_READER_H_
#define SKIDIMM_IO_ROS_BAG_READER_H_

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace skidimm {
namespace ros {

struct BagTopic {
  std::string name;                  // "/imu/data"
  std::string type;                  // "sensor_msgs/msg/Imu"
  std::string serialization_format;  // "cdr"
  std::string definition;            // the complete message definition; empty when the bag has none
  std::string definition_encoding;   // "ros2msg", "ros2idl", ...; empty when none
  std::uint64_t message_count = 0;
  std::uint64_t first_log_time = 0;  // ns, when message_count > 0
  std::uint64_t last_log_time = 0;
};

struct BagMessage {
  int topic = -1;  // index into topics()
  std::uint64_t log_time = 0;  // ns
  const std::uint8_t* data = nullptr;  // valid until the next call to next()
  std::size_t size = 0;
};

class BagReader {
 public:
  // Opens a bag (see above). Throws LogError.
  static std::unique_ptr<BagReader> open(const std::filesystem::path& path);
  // Whether `path` is read as a bag: a .mcap or .db3 file, a file that starts
  // with MCAP's magic bytes, or a directory with a metadata.yaml.
  static bool is_bag(const std::filesystem::path& path);
  // For a directory that holds a bag's files (.db3, .mcap) but no
  // metadata.yaml, which rosbag2 writes when a recording ends (one stopped
  // hard leaves none): what it is and what to do, for an error message;
  // "" for any other path.
  static std::string unfinished_recording(const std::filesystem::path& directory);

  virtual ~BagReader() = default;
  BagReader(const BagReader&) = delete;
  BagReader& operator=(const BagReader&) = delete;

  const std::filesystem::path& path() const { return path_; }
  const std::vector<BagTopic>& topics() const { return topics_; }
  int topic_index(const std::string& name) const;  // -1 if absent
  // The storage files, in reading order.
  const std::vector<std::filesystem::path>& files() const { return files_; }
  // "mcap" or "sqlite3", and a few words on how it is stored ("zstd chunks,
  // indexed"), for `skidimm bag`.
  virtual std::string storage() const = 0;
  virtual std::string storage_details() const = 0;

  // The next message. Returns false at the end. Throws LogError.
  virtual bool next(BagMessage* message) = 0;
  virtual void rewind() = 0;
  virtual double progress() const = 0;  // 0..1

 protected:
  BagReader() = default;
  std::filesystem::path path_;
  std::vector<BagTopic> topics_;
  std::vector<std::filesystem::path> files_;
};

}  // namespace ros
}  // namespace skidimm

#endif  // SKIDIMM_IO_ROS_BAG_READER_H_
