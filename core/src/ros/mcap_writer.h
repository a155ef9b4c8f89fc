// McapWriter: an MCAP file (https://mcap.dev/spec) that Foxglove, the MCAP
// command-line tools and @mcap/core read: messages in chunks (zstd, lz4 or
// uncompressed) with a message index after each chunk, and a summary with
// the schemas, channels, statistics and chunk index; every CRC written
// (chunks, data section, summary).
//
// The file is written through an OutputFile (output_file.h): as
// "<path>.partial", renamed to <path> by commit(). Destroyed without
// commit() (an error upstream), it finishes the file as it is (the last
// chunk, the summary) and keeps it as "<path>.partial": every message
// written before is readable there.
#ifndef SKIDIMM_CORE_SRC_ROS_MCAP_WRITER_H_
#define SKIDIMM_CORE_SRC_ROS_MCAP_WRITER_H_

#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "skidimm/io/output_file.h"

namespace skidimm {
namespace ros {

class McapWriter {
 public:
  struct Options {
    std::string profile;                  // "" for none; "ros2" for ROS 2 messages
    std::string library = "skidimm";      // the Header's writer
    std::string compression = "zstd";     // "zstd", "lz4" or "" for uncompressed chunks
    std::size_t chunk_size = 1 << 20;     // bytes of records before a chunk is written
  };

  // Creates "<path>.partial" and writes the magic and Header. Throws Error.
  McapWriter(const std::filesystem::path& path, Options options);
  explicit McapWriter(const std::filesystem::path& path) : McapWriter(path, Options{}) {}
  ~McapWriter();
  McapWriter(const McapWriter&) = delete;
  McapWriter& operator=(const McapWriter&) = delete;

  // A schema ("jsonschema", "ros2msg", ...); returns its id (1, 2, ...).
  std::uint16_t add_schema(const std::string& name, const std::string& encoding, const std::string& data);
  // A channel; schema 0 for none. Returns its id (0, 1, ...).
  std::uint16_t add_channel(const std::string& topic, const std::string& message_encoding, std::uint16_t schema_id,
                            const std::vector<std::pair<std::string, std::string>>& metadata = {});
  // One message. Times in nanoseconds.
  void write(std::uint16_t channel, std::uint64_t log_time, std::uint64_t publish_time, const void* data,
             std::size_t size);

  // Writes the last chunk, DataEnd, the summary and the Footer, then renames
  // the file to its final name. Throws Error.
  void commit();
  const std::filesystem::path& partial_path() const { return out_->written_path(); }
  std::uint64_t messages() const { return message_count_; }

 private:
  struct ChunkIndex {
    std::uint64_t start_time, end_time, offset, length;
    std::vector<std::pair<std::uint16_t, std::uint64_t>> message_index_offsets;
    std::uint64_t message_index_length;
    std::uint64_t compressed_size, uncompressed_size;
  };

  void put(const std::string& bytes);  // to the file, counting offset and CRC
  void flush_chunk();
  void finish();

  std::unique_ptr<OutputFile> out_;
  Options options_;
  std::uint64_t offset_ = 0;
  std::uint32_t data_crc_ = 0;
  bool finished_ = false;
  std::vector<std::string> schemas_;   // records, for the summary
  std::vector<std::string> channels_;  // records, for the summary
  std::uint16_t next_schema_ = 1;
  std::uint16_t next_channel_ = 0;
  // The chunk being filled.
  std::string chunk_records_;
  std::uint64_t chunk_start_ = 0, chunk_end_ = 0;
  bool chunk_has_messages_ = false;
  std::map<std::uint16_t, std::vector<std::pair<std::uint64_t, std::uint64_t>>> chunk_index_;  // (log time, offset)
  std::vector<ChunkIndex> chunks_;
  // Statistics.
  std::uint64_t message_count_ = 0;
  std::uint64_t start_time_ = 0, end_time_ = 0;
  std::map<std::uint16_t, std::uint64_t> channel_counts_;
};

}  // namespace ros
}  // namespace skidimm

#endif  // SKIDIMM_CORE_SRC_ROS_MCAP_WRITER_H_
