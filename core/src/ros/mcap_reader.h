// McapReader: the messages of an MCAP file (https://mcap.dev/spec), the
// storage rosbag2 writes by default, read without any MCAP library.
//
// Opening reads the magic bytes and the Header. When the file ends with a
// Footer that points at a summary section, the summary is read (its CRC
// checked): schemas, channels, statistics and the chunk index, and messages
// are then read chunk by chunk in the order of their first log time. A file
// without a summary (a writer that wrote none, or a recording cut short) is
// scanned front to back twice: once when opened, for its schemas, channels
// and counts, then for the messages.
//
// Chunks may be uncompressed, "zstd" or "lz4" (compression.h). A chunk's CRC
// of its uncompressed records, and in a scan the data section's CRC
// (DataEnd), are checked when the file recorded them (non-zero).
//
// Errors are LogErrors naming the file, the record (its opcode name and byte
// offset) and what was expected: a file cut in the middle of a record, a
// wrong CRC, a chunk that does not decompress, a message on an undefined
// channel. An error found while reading messages is thrown when reading gets
// to it: every message before it has been returned (a caller keeps what it
// computed from them).
//
// Sizes recorded in the file are checked against the file's size before
// anything is allocated; a chunk may decompress to at most 1 GiB.
#ifndef SKIDIMM_CORE_SRC_ROS_MCAP_READER_H_
#define SKIDIMM_CORE_SRC_ROS_MCAP_READER_H_

#include <cstdint>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace skidimm {
namespace ros {

struct McapSchema {
  std::uint16_t id = 0;
  std::string name;      // e.g. "sensor_msgs/msg/Imu"
  std::string encoding;  // "ros2msg", "ros2idl", "jsonschema", ... ; empty for none
  std::string data;      // the definition
};

struct McapChannel {
  std::uint16_t id = 0;
  std::uint16_t schema_id = 0;  // 0: no schema
  std::string topic;
  std::string message_encoding;  // "cdr" for ROS 2
  std::vector<std::pair<std::string, std::string>> metadata;
};

// Counts and times over the whole file: the file's Statistics record, or
// counted by the scan of a file without one.
struct McapStatistics {
  std::uint64_t message_count = 0;
  std::uint64_t message_start_time = 0;  // ns, log time
  std::uint64_t message_end_time = 0;
  std::uint32_t chunk_count = 0;
  std::map<std::uint16_t, std::uint64_t> channel_message_counts;
};

// One message; `data` points into the reader's buffer, valid until the next
// call to next().
struct McapMessage {
  std::uint16_t channel_id = 0;
  std::uint32_t sequence = 0;
  std::uint64_t log_time = 0;      // ns
  std::uint64_t publish_time = 0;  // ns
  const std::uint8_t* data = nullptr;
  std::size_t size = 0;
};

class McapReader {
 public:
  // Opens and indexes the file (see above). Throws LogError.
  explicit McapReader(const std::filesystem::path& path);
  ~McapReader();
  McapReader(const McapReader&) = delete;
  McapReader& operator=(const McapReader&) = delete;

  const std::filesystem::path& path() const { return path_; }
  const std::string& profile() const { return profile_; }  // "ros2" for rosbag2
  const std::string& library() const { return library_; }  // the writer
  // True when messages are read through the summary's chunk index.
  bool indexed() const { return indexed_; }
  // True when the file's summary was read (its schemas, channels and
  // statistics); a file with one but no chunk (no message, or messages
  // written outside chunks) is still read by a scan.
  bool has_summary() const { return has_summary_; }
  const std::map<std::uint16_t, McapSchema>& schemas() const { return schemas_; }
  const std::map<std::uint16_t, McapChannel>& channels() const { return channels_; }
  const McapStatistics& statistics() const { return statistics_; }
  // The chunks' compressions, each once ("" for uncompressed chunks).
  const std::vector<std::string>& compressions() const { return compressions_; }
  // A problem the opening scan found (a file cut short, a wrong CRC), which
  // next() throws when it gets there; null when there is none.
  const std::exception_ptr& scan_error() const { return scan_error_; }
  // What the file lacks that reading it did without, for a bag's
  // description: a summary that could not be read (a wrong CRC: the file is
  // read by a scan, each chunk checked by its own), or an index cut short
  // after the last message (a recording stopped while closing). "" if none.
  const std::string& mended() const { return mended_; }

  // The next message in file order (chunk index order when indexed). Returns
  // false at the end. Throws LogError.
  bool next(McapMessage* message);
  // Starts the messages again from the first.
  void rewind();
  // The fraction of the file's bytes read by next(), 0..1.
  double progress() const;

 private:
  struct ChunkLocation {
    std::uint64_t start_time = 0;
    std::uint64_t offset = 0;
    std::uint64_t length = 0;
  };
  struct Record {
    std::uint8_t opcode = 0;
    std::uint64_t offset = 0;  // of the opcode byte
    std::vector<std::uint8_t> content;
  };

  void read_summary(std::uint64_t summary_start, std::uint64_t footer_offset, std::uint32_t summary_crc);
  void scan_for_index();
  bool read_record(std::uint64_t offset, Record* record, bool in_scan);
  void load_chunk(const Record& record);
  bool next_in_chunk(McapMessage* message);
  void add_schema(const std::uint8_t* data, std::size_t size, std::uint64_t offset);
  void add_channel(const std::uint8_t* data, std::size_t size, std::uint64_t offset);
  [[noreturn]] void fail(std::uint64_t offset, const std::string& what) const;

  std::filesystem::path path_;
  std::FILE* file_ = nullptr;
  std::uint64_t file_size_ = 0;
  std::uint64_t data_start_ = 0;  // first record after the Header
  std::uint64_t data_end_ = 0;    // where the data section ends (DataEnd, summary or the file's end)
  std::string profile_;
  std::string library_;
  bool indexed_ = false;
  bool has_summary_ = false;
  std::map<std::uint16_t, McapSchema> schemas_;
  std::map<std::uint16_t, McapChannel> channels_;
  McapStatistics statistics_;
  std::vector<std::string> compressions_;
  std::vector<ChunkLocation> chunks_;
  std::exception_ptr scan_error_;
  std::string mended_;
  bool counting_ = false;  // the opening scan counts chunks
  // read_record(): the opcode of a record the file ends inside, when it does.
  int cut_opcode_ = -1;
  bool footer_found_ = false;  // a Footer and the closing magic: the file was not cut short

  // Reading messages.
  std::size_t next_chunk_ = 0;   // indexed
  std::uint64_t position_ = 0;   // scanning: the next record's offset
  std::uint32_t data_crc_ = 0;   // scanning: CRC of the bytes before position_
  bool finished_ = false;
  Record record_;
  std::vector<std::uint8_t> chunk_;  // the current chunk's records, uncompressed
  std::size_t chunk_position_ = 0;
  std::uint64_t chunk_offset_ = 0;
  bool in_chunk_ = false;
  std::uint64_t bytes_done_ = 0;
};

// The name of an MCAP record opcode ("Chunk", "Message", ...), for messages.
std::string mcap_opcode_name(std::uint8_t opcode);

}  // namespace ros
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_ROS_MCAP_READER_H_
